"""The wavefront path tracer: whole arrays of paths advance one bounce at a time.

Each bounce runs the stages of pbrt-v4's wavefront integrator over numpy arrays: intersect all
live rays (one Embree call), add emission from lamps, the world and emissive triangles, scatter
by material kind, trace every shadow ray of the bounce (one Embree call), then Russian roulette
and compaction. Max depth m is the seed's max_ray_depth: emission plus up to m bounces, which is
Cycles' max_bounces = m - 1.

A render is a sequence of passes. Each pass is cut into fixed-size chunks with their own random
streams (keyed by seed, pass and chunk), so the image depends on the seed and sample count only,
not on the thread count. Chunks run on a thread pool: Embree and most numpy kernels release the
GIL.
"""
from __future__ import annotations

import math
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from . import bsdf
from .bsdf import DIFFUSE, EMISSION, GLASS, MIRROR, REFRACTION, dot
from .camera import Camera
from .geometry import FAR, Geometry, offset_origin
from .lights import LightSampler
from .scene import MATERIAL_KINDS, Scene

CHUNK = 1 << 15           # paths per chunk: big enough to amortise Python, small enough for cache
PASS_PATHS = 1 << 17      # aim for about this many paths per progressive pass
RR_START = 3              # Russian roulette from this bounce on
SHADOW_SHORTEN = 2.0 ** -16  # relative; well above Embree's float32 error in t


@dataclass
class RenderResult:
    """Per-pixel sums of the samples and of their squares (row 0 = top), plus counters."""
    width: int
    height: int
    sum: np.ndarray
    sum_sq: np.ndarray
    spp: int = 0
    nan_count: int = 0
    time_s: float = 0.0
    build_s: float = 0.0
    embree_time_s: float = 0.0
    rays: int = 0
    threads: int = 1
    cancelled: bool = False
    stats: dict = field(default_factory=dict)

    def mean(self) -> np.ndarray:
        """The image: per-pixel mean radiance, float32 (H, W, 3), linear."""
        if self.spp == 0:
            return np.zeros_like(self.sum, dtype=np.float32)
        return (self.sum / self.spp).astype(np.float32)

    def variance_of_mean(self) -> np.ndarray:
        """Per-pixel variance of the mean (sample variance / n), float64 (H, W, 3)."""
        n = self.spp
        if n < 2:
            return np.full_like(self.sum, np.inf)
        var = (self.sum_sq - self.sum * self.sum / n) / (n - 1)
        return np.maximum(var, 0.0) / n

    @property
    def rays_per_second(self) -> float:
        """All rays traced (camera, bounce and shadow) per second of render wall time."""
        return self.rays / self.time_s if self.time_s > 0 else 0.0

    @property
    def embree_share(self) -> float:
        """Fraction of the threads' wall time spent inside Embree queries."""
        return self.embree_time_s / (self.time_s * self.threads) if self.time_s > 0 else 0.0


def power_heuristic(a, b):
    """MIS weight of strategy a against b (both pdfs in solid angle)."""
    a2, b2 = a * a, b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(a2 + b2 > 0, a2 / (a2 + b2), 0.0)


class Renderer:
    """A scene prepared for rendering: camera, Embree geometry, materials and lights."""

    def __init__(self, scene: Scene, threads: int = 2):
        start = time.perf_counter()
        self.scene = scene
        self.threads = max(1, int(threads))
        self.camera = Camera(scene.camera)
        self.geometry = Geometry(scene.positions, scene.triangles, scene.normals)
        mats = scene.materials
        self.kind = np.array([MATERIAL_KINDS.index(m["kind"]) for m in mats], np.int64)
        self.color = np.array([m["color"] for m in mats], np.float64).reshape(-1, 3)
        self.trans_color = np.array([m.get("transmission_color", m["color"]) for m in mats],
                                    np.float64).reshape(-1, 3)
        self.ior = np.array([m.get("ior", 1.0) for m in mats], np.float64)
        self.radiance = self.color * np.array([m.get("strength", 0.0) if m["kind"] == "emission" else 0.0
                                               for m in mats]).reshape(-1, 1)
        self.tri_material = scene.material_ids.astype(np.int64)
        self.lights = LightSampler(scene, self.geometry, self.kind, self.radiance)
        self.world = np.asarray(scene.world["color"], np.float64)
        self.has_world = bool(np.any(self.world > 0))
        render = scene.render
        self.max_depth = int(render["max_depth"])
        self.seed = int(render["seed"])
        self.fresnel = bsdf.FRESNEL[render["fresnel"]]
        self.build_s = time.perf_counter() - start

    # -- one chunk of paths ---------------------------------------------------------------

    def trace(self, pixel: np.ndarray, rng: np.random.Generator):
        """Radiance of one path per entry of `pixel`: (L (n, 3) float64, event counters)."""
        n = len(pixel)
        geom, lights, area = self.geometry, self.lights, self.lights.area_lights
        cam = self.camera
        o, d, tmax = cam.generate(pixel, rng.random((n, 2)), rng.random((n, 2)) if cam.has_lens else None)
        radiance = np.zeros((n, 3))
        path = np.arange(n)
        beta = np.ones((n, 3))
        specular = np.ones(n, bool)   # the camera ray counts as specular: no MIS on what it sees
        pdf_prev = np.zeros(n)
        stats = {"tir": 0, "tir_absorbed": 0, "transmissions": 0, "reflections": 0, "diffuse": 0, "rr_killed": 0}

        for depth in range(self.max_depth + 1):
            if len(path) == 0:
                break
            # Stage 1: intersect.
            prim, u, v, t = geom.intersect(o, d, tmax)
            t = np.where(prim >= 0, t, np.inf).astype(np.float64)
            alive = np.ones(len(path), bool)

            # Stage 2: lamps, world and emissive surfaces add their light.
            if area.count:
                lamp, t_lamp = area.intersect(o, d, np.minimum(t, tmax), camera_rays=depth == 0)
                hit = np.nonzero(lamp >= 0)[0]
                if len(hit):
                    w = np.where(specular[hit], 1.0,
                                 power_heuristic(pdf_prev[hit], lights.pdf_area(lamp[hit], d[hit], t_lamp[hit])))
                    radiance[path[hit]] += beta[hit] * area.radiance[lamp[hit]] * w[:, None]
                    alive[hit] = False     # lamps do not scatter
                    prim[hit] = -1
            missed = np.nonzero((prim < 0) & alive)[0]
            if len(missed):
                alive[missed] = False
                if self.has_world:
                    w = np.where(specular[missed], 1.0, power_heuristic(pdf_prev[missed], lights.pdf_world()))
                    radiance[path[missed]] += beta[missed] * self.world * w[:, None]
            keep = np.nonzero(alive)[0]
            path, beta, specular, pdf_prev = path[keep], beta[keep], specular[keep], pdf_prev[keep]
            d, prim, u, v, t = d[keep], prim[keep], u[keep], v[keep], t[keep]
            if len(path) == 0:
                break
            hits = geom.hits(prim, u, v, t)
            mat = self.tri_material[prim]
            kind = self.kind[mat]
            emits = kind == EMISSION
            if emits.any():
                e = np.nonzero(emits)[0]
                w = np.where(specular[e], 1.0,
                             power_heuristic(pdf_prev[e], lights.pdf_triangle(prim[e], d[e], t[e])))
                radiance[path[e]] += beta[e] * self.radiance[mat[e]] * w[:, None]
            if depth == self.max_depth:
                break

            # Stage 3: materials. Emitters do not scatter; the rest are sampled by kind.
            keep = np.nonzero(~emits)[0]
            path, beta, d, mat, kind = path[keep], beta[keep], d[keep], mat[keep], kind[keep]
            p, ng, ns, eps = hits.p[keep], hits.ng[keep], hits.ns[keep], hits.eps[keep]
            # Face the normals towards the incoming ray (two-sided surfaces, inside of glass).
            entering = dot(d, ng) < 0.0
            side = np.where(entering, 1.0, -1.0)[:, None]
            ng_f, ns_f = ng * side, ns * side
            m = len(path)
            new_d = np.empty((m, 3))
            specular = np.ones(m, bool)
            pdf_prev = np.zeros(m)
            shadow = None

            sel = np.nonzero(kind == DIFFUSE)[0]
            if len(sel):
                stats["diffuse"] += len(sel)
                albedo = self.color[mat[sel]]
                if lights.has_any:
                    shadow = self._next_event(sel, p[sel], ng_f[sel], ns_f[sel], eps[sel], albedo, beta[sel], rng)
                wi, pdf = bsdf.sample_cosine_hemisphere(ns_f[sel], rng.random((len(sel), 2)))
                below = dot(wi, ng_f[sel]) <= 0.0   # shading normals can point a sample inside
                beta[sel] *= np.where(below[:, None], 0.0, albedo)
                new_d[sel] = wi
                specular[sel] = False
                pdf_prev[sel] = pdf

            sel = np.nonzero(kind == MIRROR)[0]
            if len(sel):
                stats["reflections"] += len(sel)
                new_d[sel] = bsdf.reflect(d[sel], ns_f[sel])
                beta[sel] *= self.color[mat[sel]]

            sel = np.nonzero((kind == GLASS) | (kind == REFRACTION))[0]
            if len(sel):
                self._dielectric(sel, d, ns_f, entering, mat, kind, beta, new_d, rng, stats)

            # Stage 4: shadow rays of the whole bounce in one Embree call.
            if shadow is not None:
                rows, origin, wi, dist, contrib = shadow
                blocked = geom.occluded(origin, wi, dist)
                free = ~blocked
                radiance[path[rows[free]]] += contrib[free]

            # Stage 5: next rays, Russian roulette on the throughput, compaction.
            o = offset_origin(p, ng, eps, new_d)
            d = new_d
            tmax = np.full(m, FAR, np.float64)
            live = np.any(beta > 0.0, axis=1)
            if depth + 1 >= RR_START:
                q = np.minimum(beta.max(axis=1), 1.0)
                survive = rng.random(m) < q
                stats["rr_killed"] += int((live & ~survive).sum())
                live &= survive
                beta = beta / np.where(q > 0, q, 1.0)[:, None]
            keep = np.nonzero(live)[0]
            path, beta, specular, pdf_prev = path[keep], beta[keep], specular[keep], pdf_prev[keep]
            o, d, tmax = o[keep], d[keep], tmax[keep]
        return radiance, stats

    def _next_event(self, rows, p, ng_f, ns_f, eps, albedo, beta, rng):
        """Light samples at diffuse vertices: (rows, shadow origins, directions, lengths, contributions)."""
        wi, target, weight, pdf_light = self.lights.sample(p, rng)
        cos = dot(wi, ns_f)
        ok = (cos > 0.0) & (dot(wi, ng_f) > 0.0) & np.any(weight > 0.0, axis=1)
        idx = np.nonzero(ok)[0]
        if len(idx) == 0:
            return None
        cos = cos[idx]
        w = np.where(pdf_light[idx] > 0, power_heuristic(pdf_light[idx], cos / np.pi), 1.0)
        contrib = beta[idx] * albedo[idx] * (cos / np.pi * w)[:, None] * weight[idx]
        origin = offset_origin(p[idx], ng_f[idx], eps[idx], wi[idx])
        # Aim from the offset origin at the light point and stop just short of it (the point
        # may lie on an emissive triangle, which must not count as its own blocker).
        segment = target[idx] - origin
        finite = np.isfinite(segment[:, 0])
        length = np.linalg.norm(np.where(finite[:, None], segment, 0.0), axis=1)
        direction = np.where(finite[:, None], segment / np.where(finite, length, 1.0)[:, None], wi[idx])
        length = np.where(finite, length * (1.0 - SHADOW_SHORTEN) - eps[idx], FAR)
        return rows[idx], origin, direction, length, contrib

    def _dielectric(self, sel, d, ns_f, entering, mat, kind, beta, new_d, rng, stats):
        """Smooth glass (reflect with probability F, else refract) and refraction-only surfaces."""
        ior = self.ior[mat[sel]]
        eta = np.where(entering[sel], ior, 1.0 / ior)
        dd, n = d[sel], ns_f[sel]
        cos_i = np.clip(-dot(dd, n), 0.0, 1.0)
        f, cos_t = self.fresnel(cos_i, eta)
        tir = f >= 1.0
        glass = kind[sel] == GLASS
        reflects = np.where(glass, rng.random(len(sel)) < f, False)
        refracted = bsdf.refract(dd, n, eta, cos_i, cos_t)
        new_d[sel] = np.where(reflects[:, None], bsdf.reflect(dd, n), refracted)
        weight = np.where(reflects[:, None], self.color[mat[sel]], self.trans_color[mat[sel]])
        # Refraction-only surfaces have nothing to give under total internal reflection.
        weight = np.where((~glass & tir)[:, None], 0.0, weight)
        beta[sel] *= weight
        stats["tir"] += int((tir & glass).sum())
        stats["tir_absorbed"] += int((tir & ~glass).sum())
        stats["reflections"] += int((reflects & ~tir).sum())
        stats["transmissions"] += int((~reflects & ~tir).sum())

    # -- passes ----------------------------------------------------------------------------

    def render(self, spp: int | None = None, progress=None) -> RenderResult:
        """Render progressively; `progress(result, pass_index, pass_count)` may return False to stop."""
        spp = int(spp if spp is not None else self.scene.render["spp"])
        w, h = self.camera.width, self.camera.height
        npix = w * h
        result = RenderResult(w, h, np.zeros((h, w, 3)), np.zeros((h, w, 3)), threads=self.threads,
                              build_s=self.build_s)
        per_pass = max(1, min(spp, PASS_PATHS // npix))
        passes = math.ceil(spp / per_pass)
        embree_before, rays_before = self.geometry.embree_time, self.geometry.ray_count
        totals: dict = {}
        start = time.perf_counter()
        flat_sum = result.sum.reshape(-1, 3)
        flat_sq = result.sum_sq.reshape(-1, 3)
        with ThreadPoolExecutor(max_workers=self.threads) as pool:
            for k in range(passes):
                count = min(per_pass, spp - k * per_pass)
                pixels = np.repeat(np.arange(npix, dtype=np.int64), count)
                chunks = [(k, c, pixels[s:s + CHUNK]) for c, s in enumerate(range(0, len(pixels), CHUNK))]
                for pix, value, stats in pool.map(self._run_chunk, chunks):
                    bad = ~np.all(np.isfinite(value), axis=1)
                    if bad.any():
                        result.nan_count += int(bad.sum())
                        value[bad] = 0.0
                    for c in range(3):
                        flat_sum[:, c] += np.bincount(pix, value[:, c], minlength=npix)
                        flat_sq[:, c] += np.bincount(pix, value[:, c] ** 2, minlength=npix)
                    for key, val in stats.items():
                        totals[key] = totals.get(key, 0) + val
                result.spp += count
                result.time_s = time.perf_counter() - start
                result.embree_time_s = self.geometry.embree_time - embree_before
                result.rays = self.geometry.ray_count - rays_before
                result.stats = totals
                if progress is not None and progress(result, k + 1, passes) is False:
                    result.cancelled = k + 1 < passes
                    break
        result.time_s = time.perf_counter() - start
        return result

    def _run_chunk(self, job):
        pass_index, chunk_index, pixels = job
        rng = np.random.default_rng([self.seed, pass_index, chunk_index])
        value, stats = self.trace(pixels, rng)
        return pixels, value, stats


def render(scene: Scene, *, threads: int = 2, progress=None, spp: int | None = None) -> RenderResult:
    """Render a scene with its own settings; see Renderer.render."""
    return Renderer(scene, threads=threads).render(spp=spp, progress=progress)
