"""A scene's lights as one distribution: the tables compiled code reads (`Lights`) and how they
are built.

`LightSampler` builds the tables. One discrete distribution picks a light in proportion to an
estimate of its power; the light's own sampler (one module per kind: triangles.py for emissive
triangles, area.py, point.py and sun.py for Blender's lamps, world.py for the world) then picks a
point or a direction; dispatch.py switches on the kind.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..jit import jit
from ..light_groups import group_tables
from ..textures import REC709
from ..vec import row
from .area import spread_constants
from .codes import (AREA, CASTS_SHADOW, EMISSIVE_TRIANGLE, POINT, SUN, USES_MIS, VISIBLE_CAMERA,
                    VISIBLE_DIFFUSE, VISIBLE_GLOSSY, VISIBLE_TRANSMISSION, WORLD)
from .dispatch import sample_light
from .triangles import pdf_triangle
from .world import EnvironmentMap, build_environment, empty_environment

AREA_SHAPE_CODES = {"rectangle": 0, "square": 0, "disk": 1, "ellipse": 1}


class Lights(NamedTuple):
    """Every light of a scene as tables for compiled code (vectors are (n, 3) rows)."""
    kind: np.ndarray             # (K,) the kind of each light of the distribution
    index: np.ndarray            # (K,) its row in its kind's tables
    pmf: np.ndarray              # (K,) selection probability
    cdf: np.ndarray              # (K,)
    tri_prim: np.ndarray         # (E,) the mesh triangle of each light triangle
    tri_corners: np.ndarray      # (E, 3, 3)
    tri_normal: np.ndarray       # (E, 3)
    tri_area: np.ndarray         # (E,)
    tri_edge2: np.ndarray        # (E,) longest edge, squared
    tri_radiance: np.ndarray     # (E, 3)
    light_of_prim: np.ndarray    # (T,) light triangle of each mesh triangle (0 where none)
    tri_pmf: np.ndarray          # (T,) selection probability of each mesh triangle
    area_center: np.ndarray      # (L, 3)
    area_ex: np.ndarray          # (L, 3) unit axes of the lamp's plane
    area_ey: np.ndarray          # (L, 3)
    area_emit: np.ndarray        # (L, 3) unit direction each lamp emits towards (local -Z)
    area_half: np.ndarray        # (L, 2) half sizes along ex, ey
    area_ellipse: np.ndarray     # (L,) disk or ellipse (else rectangle)
    area_radiance: np.ndarray    # (L, 3)
    area_area: np.ndarray        # (L,)
    area_spread_tan: np.ndarray  # (L,) tan(spread / 2), inf for 180 degrees
    area_spread_norm: np.ndarray  # (L,) the spread's normalisation K
    area_flags: np.ndarray       # (L,) codes.VISIBLE_* | CASTS_SHADOW | USES_MIS
    area_pmf: np.ndarray         # (L,)
    point_pos: np.ndarray        # (P, 3) point and spot lamps
    point_intensity: np.ndarray  # (P, 3) W/sr; radiance intensity / (pi r^2) for radius r
    point_radius: np.ndarray     # (P,)
    point_sphere: np.ndarray     # (P,) a sphere (else the disk facing the shading point)
    point_spot: np.ndarray       # (P,)
    point_inverse: np.ndarray    # (P, 3, 3) world to the spot's own (scaled) frame
    point_cos_half: np.ndarray   # (P,) cos(spot size / 2)
    point_smooth: np.ndarray     # (P,) 1 / ((1 - cos_half) blend), inf for blend 0
    point_flags: np.ndarray      # (P,)
    point_pmf: np.ndarray        # (P,)
    sun_dir: np.ndarray          # (S, 3) unit direction the light travels
    sun_irradiance: np.ndarray   # (S, 3) at normal incidence
    sun_one_minus_cos: np.ndarray  # (S,) 1 - cos(angle / 2), 0 for a direction
    sun_radiance: np.ndarray     # (S, 3) of the disc, for angle > 0
    sun_flags: np.ndarray        # (S,)
    sun_pmf: np.ndarray          # (S,)
    world: np.ndarray            # (3,) uniform world radiance (without an environment map)
    world_pmf: float
    has_world: bool              # the world gives light (a colour above 0, or a map)
    has_env: bool                # the world is an environment map (env), else the colour
    env: EnvironmentMap
    # Each light's light group (light_groups.py; -1: none), by kind as above, and each mesh
    # triangle's (its object's), which emissive triangles and shader programs' emission take.
    area_group: np.ndarray       # (L,) int64
    point_group: np.ndarray      # (P,) int64
    sun_group: np.ndarray        # (S,) int64
    world_group: int
    prim_group: np.ndarray       # (T,) int64


def luminance(rgb) -> np.ndarray:
    """Rec.709 luminance."""
    rgb = np.asarray(rgb, dtype=np.float64)
    return rgb @ np.array(REC709)


def light_flags(light: dict) -> int:
    """A scene light entry's visibility, shadow and MIS options as codes.* flags."""
    flags = 0
    for key, flag in (("visible_camera", VISIBLE_CAMERA), ("visible_diffuse", VISIBLE_DIFFUSE),
                      ("visible_glossy", VISIBLE_GLOSSY),
                      ("visible_transmission", VISIBLE_TRANSMISSION),
                      ("cast_shadow", CASTS_SHADOW), ("use_mis", USES_MIS)):
        if light.get(key, True):
            flags |= flag
    return flags


def world_environment(scene, env_sampling=True):
    """The scene's environment map (None for a uniform world colour); env_sampling=False samples
    it uniformly over the sphere instead of by its image (for measurements)."""
    spec = scene.world.get("environment")
    if spec is None:
        return None
    return build_environment(scene.images[spec["image"]]["pixels"], strength=spec["strength"],
                             matrix=spec["matrix"], offset=spec["offset"],
                             closest=spec["interpolation"] == "closest",
                             uniform=not env_sampling)


def environment_power(env: EnvironmentMap) -> float:
    """The map's mean luminance over the sphere of texture directions, times its strength."""
    h = env.image.shape[0]
    sin_row = np.sin(np.pi * (np.arange(h) + 0.5) / h)
    lum = np.maximum(luminance(env.image.mean(axis=1, dtype=np.float64)), 0.0)
    return float(env.strength * (lum * sin_row).sum() / sin_row.sum())


def _rows(values, n=3) -> np.ndarray:
    return np.ascontiguousarray(np.array(values, np.float64).reshape(-1, n))


def _unit_rows(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=1, keepdims=True) if len(v) else v


def _column(values, dtype=np.float64) -> np.ndarray:
    return np.array(values, dtype).reshape(-1)


def _area_tables(areas: list) -> dict:
    matrices = np.array([light["matrix"] for light in areas], np.float64).reshape(-1, 4, 4)
    half = _rows([0.5 * np.asarray(light["size"], np.float64) for light in areas], 2)
    ellipse = _column([AREA_SHAPE_CODES[light["shape"]] == 1 for light in areas], bool)
    spread = [spread_constants(light.get("spread", math.pi)) for light in areas]
    return dict(
        area_center=np.ascontiguousarray(matrices[:, :3, 3]),
        area_ex=_unit_rows(matrices[:, :3, 0]), area_ey=_unit_rows(matrices[:, :3, 1]),
        area_emit=-_unit_rows(matrices[:, :3, 2]), area_half=half, area_ellipse=ellipse,
        area_radiance=_rows([light["radiance"] for light in areas]),
        area_area=4.0 * half[:, 0] * half[:, 1] * np.where(ellipse, np.pi / 4, 1.0),
        area_spread_tan=_column([s[0] for s in spread]),
        area_spread_norm=_column([s[1] for s in spread]),
        area_flags=_column([light_flags(light) for light in areas], np.int64))


def _point_tables(points: list) -> dict:
    inverse, cos_half, smooth = [], [], []
    for light in points:
        if light["kind"] == "spot":
            m = np.asarray(light["matrix"], np.float64)[:3, :3]
            inverse.append(np.linalg.inv(m))
            c = math.cos(0.5 * light["spot_size"])
            cos_half.append(c)
            blend = light["spot_blend"] * (1.0 - c)
            smooth.append(1.0 / blend if blend > 0 else math.inf)
        else:
            inverse.append(np.eye(3))
            cos_half.append(-1.0)
            smooth.append(math.inf)
    return dict(
        point_pos=_rows([light["position"] for light in points]),
        point_intensity=_rows([light["intensity"] for light in points]),
        point_radius=_column([light.get("radius", 0.0) for light in points]),
        point_sphere=_column([not light.get("soft_falloff", True) for light in points], bool),
        point_spot=_column([light["kind"] == "spot" for light in points], bool),
        point_inverse=np.array(inverse, np.float64).reshape(-1, 3, 3),
        point_cos_half=_column(cos_half), point_smooth=_column(smooth),
        point_flags=_column([light_flags(light) for light in points], np.int64))


def _sun_tables(suns: list) -> dict:
    half = np.array([0.5 * light.get("angle", 0.0) for light in suns], np.float64)
    irradiance = _rows([light["irradiance"] for light in suns])
    sin2 = np.sin(half) ** 2
    # The disc's radiance: irradiance at normal incidence over its projected solid angle.
    # A sun without a disc (angle 0) has no radiance; divide only where the disc exists, or
    # a strong sun's irradiance over the placeholder denominator overflows.
    disc = np.broadcast_to((sin2 > 0)[:, None], irradiance.shape)
    radiance = np.divide(irradiance, (np.pi * sin2)[:, None], out=np.zeros_like(irradiance),
                         where=disc)
    return dict(
        sun_dir=_unit_rows(_rows([light["direction"] for light in suns])),
        sun_irradiance=irradiance, sun_one_minus_cos=2.0 * np.sin(0.5 * half) ** 2,
        sun_radiance=np.ascontiguousarray(radiance),
        sun_flags=_column([light_flags(light) for light in suns], np.int64))


class LightSampler:
    """Builds the light tables of a scene and samples them (arrays, for tests and tools)."""

    def __init__(self, scene, geometry, material_radiance, env_sampling=True):
        lights = scene.lights
        areas = _area_tables([light for light in lights if light["kind"] == "area"])
        points = _point_tables([light for light in lights if light["kind"] in ("point", "spot")])
        suns = _sun_tables([light for light in lights if light["kind"] == "sun"])
        env = world_environment(scene, env_sampling)
        world = np.asarray(scene.world["color"], np.float64)
        if env is not None:
            world = np.zeros(3)

        mats = scene.material_ids
        # Emission materials and Principled BSDFs with emission.
        emissive = np.nonzero(np.any(material_radiance[mats] > 0, axis=1))[0]
        tri_radiance = material_radiance[mats[emissive]]                    # (E, 3)
        keep = (luminance(tri_radiance) > 0) & (geometry.area[emissive] > 0)
        tri = emissive[keep]
        tri_corners = np.ascontiguousarray(geometry.corners[tri])
        edges = tri_corners - np.roll(tri_corners, 1, axis=1)
        light_of_prim = np.zeros(geometry.count, np.int64)      # 0 also where tri_pmf is 0
        light_of_prim[tri] = np.arange(len(tri))
        radius = 0.5 * geometry.extent if geometry.count else 1.0
        # Power estimates: only the ratios matter, and any positive choice stays unbiased.
        world_lum = luminance(world) if env is None else environment_power(env)
        world_power = world_lum * 4.0 * np.pi ** 2 * radius ** 2
        power = [
            (EMISSIVE_TRIANGLE, luminance(tri_radiance[keep]) * geometry.area[tri] * 2.0 * np.pi),
            (AREA, luminance(areas["area_radiance"]) * areas["area_area"] * np.pi),
            (POINT, luminance(points["point_intensity"]) * 4.0 * np.pi),
            (SUN, luminance(suns["sun_irradiance"]) * np.pi * radius ** 2),
            (WORLD, np.array([world_power]) if world_power > 0 else np.zeros(0)),
        ]
        kind = np.concatenate([np.full(len(p), k) for k, p in power]).astype(np.int64)
        index = np.concatenate([np.arange(len(p)) for _, p in power]).astype(np.int64)
        weights = np.concatenate([np.maximum(p, 0.0) for _, p in power])
        total = weights.sum()
        self.count = int((weights > 0).sum())
        pmf = weights / total if total > 0 else weights
        per_kind = {k: pmf[kind == k].copy() for k, _ in power}
        tri_pmf = np.zeros(geometry.count)
        tri_pmf[tri] = per_kind[EMISSIVE_TRIANGLE]
        self.tables = Lights(
            kind=kind, index=index, pmf=pmf, cdf=np.cumsum(pmf),
            tri_prim=tri.astype(np.int64), tri_corners=tri_corners,
            tri_normal=np.ascontiguousarray(geometry.face_normal[tri]),
            tri_area=geometry.area[tri].copy(), tri_edge2=(edges * edges).sum(axis=2).max(axis=1),
            tri_radiance=np.ascontiguousarray(tri_radiance[keep]), light_of_prim=light_of_prim,
            tri_pmf=tri_pmf, area_pmf=per_kind[AREA], point_pmf=per_kind[POINT],
            sun_pmf=per_kind[SUN], world=world,
            world_pmf=float(per_kind[WORLD][0]) if world_power > 0 else 0.0,
            has_world=bool(world_power > 0), has_env=env is not None,
            env=env if env is not None else empty_environment(),
            **areas, **points, **suns, **group_tables(scene, geometry.count))
        self.geometry = geometry

    @property
    def has_any(self) -> bool:
        """Whether next-event estimation has anything to sample."""
        return self.count > 0

    def sample(self, p: np.ndarray, u: np.ndarray, n: np.ndarray | None = None):
        """sample_light for shading points p (3, n) with shading normals n (default +Z) and
        uniform numbers u (3, n): (wi (3, n), light point (3, n) (NaN for lights at infinity),
        radiance / pdf (3, n), pdf (n))."""
        count = p.shape[1]
        n = np.tile([[0.0], [0.0], [1.0]], (1, count)) if n is None else n
        wi, target = np.empty((count, 3)), np.empty((count, 3))
        weight, pdf = np.empty((count, 3)), np.empty(count)
        _sample_rows(self.tables, self.geometry.mesh, np.ascontiguousarray(p.T),
                     np.ascontiguousarray(n.T), np.ascontiguousarray(u), wi, target, weight, pdf)
        return wi.T, target.T, weight.T, pdf

    def pdf_triangle(self, prim, o, d, t):
        """pdf_triangle for hits prim (n) of rays o + t d ((3, n) and (n))."""
        out = np.empty(len(prim))
        _pdf_triangle_rows(self.tables, np.asarray(prim, np.int64), np.ascontiguousarray(o.T),
                           np.ascontiguousarray(d.T), np.asarray(t, np.float64), out)
        return out


@jit
def _sample_rows(lights, mesh, p, n, u, wi, target, weight, pdf):
    for j in range(p.shape[0]):
        w, point, infinite, f, density, _ = sample_light(
            lights, mesh, row(p, j), row(n, j), VISIBLE_DIFFUSE, u[0, j], u[1, j], u[2, j])
        for k in range(3):
            wi[j, k] = w[k]
            target[j, k] = np.nan if infinite else point[k]
            weight[j, k] = f[k]
        pdf[j] = density


@jit
def _pdf_triangle_rows(lights, prim, o, d, t, out):
    for j in range(prim.shape[0]):
        out[j] = pdf_triangle(lights, prim[j], row(o, j), row(d, j), t[j])

