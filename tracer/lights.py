"""Light sources: emissive triangles, area, point and sun lamps, and the uniform world.

One discrete distribution picks a light in proportion to an estimate of its power; each light
then samples a point (or direction). `LightSampler.sample` serves next-event estimation and the
`pdf_*` methods give the same densities for multiple importance sampling of BSDF-sampled hits.
"""
from __future__ import annotations

import numpy as np

from . import bsdf
from .bsdf import dot

EMISSIVE_TRIANGLE, AREA, POINT, SUN, WORLD = range(5)
AREA_SHAPE_CODES = {"rectangle": 0, "square": 0, "disk": 1, "ellipse": 1}


def luminance(rgb) -> np.ndarray:
    """Rec.709 luminance."""
    rgb = np.asarray(rgb, dtype=np.float64)
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


class AreaLights:
    """Blender area lamps as analytic one-sided rectangles and ellipses (not Embree geometry)."""

    def __init__(self, lights: list):
        n = len(lights)
        self.count = n
        self.center = np.zeros((n, 3))
        self.ex = np.zeros((n, 3))
        self.ey = np.zeros((n, 3))
        self.emit = np.zeros((n, 3))   # unit direction the lamp emits towards (local -Z)
        self.half = np.zeros((n, 2))
        self.ellipse = np.zeros(n, bool)
        self.radiance = np.zeros((n, 3))
        self.area = np.zeros(n)
        self.visible_camera = np.zeros(n, bool)
        for i, light in enumerate(lights):
            m = np.asarray(light["matrix"], dtype=np.float64)
            self.center[i] = m[:3, 3]
            self.ex[i] = bsdf.normalize(m[None, :3, 0])[0]
            self.ey[i] = bsdf.normalize(m[None, :3, 1])[0]
            self.emit[i] = -bsdf.normalize(m[None, :3, 2])[0]
            self.half[i] = 0.5 * np.asarray(light["size"], dtype=np.float64)
            self.ellipse[i] = AREA_SHAPE_CODES[light["shape"]] == 1
            full = 4.0 * self.half[i, 0] * self.half[i, 1]
            self.area[i] = full * (np.pi / 4.0 if self.ellipse[i] else 1.0)
            self.radiance[i] = light["radiance"]
            self.visible_camera[i] = bool(light.get("visible_camera", True))

    def intersect(self, o, d, tmax, camera_rays: bool):
        """Nearest front-face lamp hit closer than tmax: (lamp index or -1, t)."""
        n = len(o)
        best = np.full(n, -1, np.int64)
        best_t = np.asarray(tmax, dtype=np.float64).copy()
        for i in range(self.count):
            if camera_rays and not self.visible_camera[i]:
                continue
            denom = d @ self.emit[i]
            front = denom < 0.0  # the ray travels against the emission direction
            if not front.any():
                continue
            with np.errstate(divide="ignore", invalid="ignore"):
                t = ((self.center[i] - o) @ self.emit[i]) / denom
            ok = front & (t > 0.0) & (t < best_t)
            if not ok.any():
                continue
            idx = np.nonzero(ok)[0]
            q = o[idx] + t[idx, None] * d[idx] - self.center[i]
            a = (q @ self.ex[i]) / self.half[i, 0]
            b = (q @ self.ey[i]) / self.half[i, 1]
            inside = (a * a + b * b <= 1.0) if self.ellipse[i] else ((np.abs(a) <= 1.0) & (np.abs(b) <= 1.0))
            idx = idx[inside]
            best[idx] = i
            best_t[idx] = t[idx]
        return best, best_t

    def sample_points(self, lamp: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Uniform points on the given lamps."""
        disk = bsdf.sample_uniform_disk(u)
        square = 2.0 * u - 1.0
        local = np.where(self.ellipse[lamp][:, None], disk, square) * self.half[lamp]
        return self.center[lamp] + local[:, :1] * self.ex[lamp] + local[:, 1:] * self.ey[lamp]


class LightSampler:
    """Chooses lights by power and samples them; also gives MIS densities of BSDF-sampled hits."""

    def __init__(self, scene, geometry, material_kind, material_radiance):
        lights = scene.lights
        self.area_lights = AreaLights([l for l in lights if l["kind"] == "area"])
        points = [l for l in lights if l["kind"] == "point"]
        suns = [l for l in lights if l["kind"] == "sun"]
        self.point_pos = np.array([l["position"] for l in points], np.float64).reshape(-1, 3)
        self.point_intensity = np.array([l["intensity"] for l in points], np.float64).reshape(-1, 3)
        self.sun_dir = np.array([l["direction"] for l in suns], np.float64).reshape(-1, 3)
        if len(suns):
            self.sun_dir = bsdf.normalize(self.sun_dir)
        self.sun_irradiance = np.array([l["irradiance"] for l in suns], np.float64).reshape(-1, 3)
        self.world = np.asarray(scene.world["color"], np.float64)

        mats = scene.material_ids
        emissive = np.nonzero(material_kind[mats] == bsdf.EMISSION)[0] if len(mats) else np.zeros(0, np.int64)
        tri_radiance = material_radiance[mats[emissive]] if len(emissive) else np.zeros((0, 3))
        keep = (luminance(tri_radiance) > 0) & (geometry.area[emissive] > 0) if len(emissive) else np.zeros(0, bool)
        self.tri = emissive[keep]
        self.tri_radiance = tri_radiance[keep]
        radius = 0.5 * geometry.extent if geometry.count else 1.0
        # Power estimates: only the ratios matter, and any positive choice stays unbiased.
        power = [
            (EMISSIVE_TRIANGLE, luminance(self.tri_radiance) * geometry.area[self.tri] * 2.0 * np.pi),
            (AREA, luminance(self.area_lights.radiance) * self.area_lights.area * np.pi),
            (POINT, luminance(self.point_intensity) * 4.0 * np.pi),
            (SUN, luminance(self.sun_irradiance) * np.pi * radius ** 2),
            (WORLD, np.array([luminance(self.world) * 4.0 * np.pi ** 2 * radius ** 2]) if luminance(self.world) > 0 else np.zeros(0)),
        ]
        self.kind = np.concatenate([np.full(len(p), k) for k, p in power]).astype(np.int64)
        self.index = np.concatenate([np.arange(len(p)) for _, p in power]).astype(np.int64)
        weights = np.concatenate([np.maximum(p, 0.0) for _, p in power])
        total = weights.sum()
        self.count = int((weights > 0).sum())
        self.pmf = weights / total if total > 0 else weights
        self.cdf = np.cumsum(self.pmf)
        # pmf per triangle, per area lamp and of the world, for MIS of BSDF-sampled hits.
        self.tri_pmf = np.zeros(geometry.count)
        start = 0
        self.tri_pmf[self.tri] = self.pmf[start:start + len(self.tri)]
        start += len(self.tri)
        self.area_pmf = self.pmf[start:start + self.area_lights.count]
        self.world_pmf = float(self.pmf[-1]) if len(power[-1][1]) else 0.0
        self.geometry = geometry

    @property
    def has_any(self) -> bool:
        """Whether next-event estimation has anything to sample."""
        return self.count > 0

    def sample(self, p: np.ndarray, rng: np.random.Generator):
        """Sample one light per shading point.

        Returns (wi, the light point (NaN for lights at infinity), radiance / pdf as (n, 3),
        pdf in solid angle for MIS with 0 for delta lights).
        """
        n = len(p)
        u = rng.random((n, 3))
        pick = np.minimum(np.searchsorted(self.cdf, u[:, 0] * self.cdf[-1], side="right"), len(self.cdf) - 1)
        kind, index, pmf = self.kind[pick], self.index[pick], self.pmf[pick]
        wi = np.zeros((n, 3))
        target = np.full((n, 3), np.nan)
        weight = np.zeros((n, 3))
        pdf = np.zeros(n)
        for k in np.unique(kind):
            sel = np.nonzero(kind == k)[0]
            q, uv, m = p[sel], u[sel, 1:], pmf[sel]
            if k == EMISSIVE_TRIANGLE:
                tri = self.tri[index[sel]]
                corners = self.geometry.corners[tri]
                su = np.sqrt(uv[:, 0])[:, None]
                b1, b2 = 1.0 - su, uv[:, 1:2] * su
                point = corners[:, 0] * b1 + corners[:, 1] * (su - b2) + corners[:, 2] * b2
                normal = self.geometry.face_normal[tri]
                area = self.geometry.area[tri]
                radiance = self.tri_radiance[index[sel]]
                two_sided = True
            elif k == AREA:
                lamp = index[sel]
                point = self.area_lights.sample_points(lamp, uv)
                normal = self.area_lights.emit[lamp]
                area = self.area_lights.area[lamp]
                radiance = self.area_lights.radiance[lamp]
                two_sided = False
            elif k == POINT:
                target[sel] = self.point_pos[index[sel]]
                to = target[sel] - q
                d2 = dot(to, to)
                wi[sel] = to / np.sqrt(d2)[:, None]
                weight[sel] = self.point_intensity[index[sel]] / (d2 * m)[:, None]
                continue
            elif k == SUN:
                wi[sel] = -self.sun_dir[index[sel]]
                weight[sel] = self.sun_irradiance[index[sel]] / m[:, None]
                continue
            else:
                wi[sel] = bsdf.sample_uniform_sphere(uv)
                pdf[sel] = m / (4.0 * np.pi)
                weight[sel] = self.world / pdf[sel][:, None]
                continue
            to = point - q
            d2 = dot(to, to)
            d = np.sqrt(d2)
            w = to / d[:, None]
            cos_l = -dot(w, normal)
            cos_l = np.abs(cos_l) if two_sided else np.maximum(cos_l, 0.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                pdf_sa = m * d2 / (area * cos_l)
                contrib = np.where((cos_l > 0)[:, None], radiance / pdf_sa[:, None], 0.0)
            wi[sel] = w
            target[sel] = point
            weight[sel] = contrib
            pdf[sel] = np.where(cos_l > 0, pdf_sa, 0.0)
        return wi, target, weight, pdf

    def pdf_triangle(self, prim, d, t):
        """Solid-angle density with which `sample` would have chosen this emissive-triangle hit."""
        cos_l = np.abs(dot(d, self.geometry.face_normal[prim]))
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = self.tri_pmf[prim] * t * t / (self.geometry.area[prim] * cos_l)
        return np.where(cos_l > 0, pdf, 0.0)

    def pdf_area(self, lamp, d, t):
        """Solid-angle density with which `sample` would have chosen this area-lamp hit."""
        cos_l = -dot(d, self.area_lights.emit[lamp])
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = self.area_pmf[lamp] * t * t / (self.area_lights.area[lamp] * cos_l)
        return np.where(cos_l > 0, pdf, 0.0)

    def pdf_world(self) -> float:
        """Solid-angle density of sampling the world in a given direction."""
        return self.world_pmf / (4.0 * np.pi)
