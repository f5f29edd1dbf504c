"""The cases of `snell stress`: scenes with exact answers, each with its analytic value.

A case renders one or more tracer Scenes (built in Python, no bpy) and returns an Outcome: the
measured value and what bounds its error. Four kinds of check (compare/stress.py applies them):

- exact: every sample has a known value (a white furnace: exactly 1). The only error allowed is
  float rounding (`tolerance`) plus `allowance`, the share of samples the integrator itself
  counted as ended early (stats: total internal reflection under a refraction-only BSDF,
  samples rejected by Cycles' shading-normal rules, paths cut by the depth limit): each such
  event turns exactly one sample of 1 into 0, so the deficit must equal their count / N.
- statistical: a Monte Carlo estimate; its standard error comes from the samples' own variance
  (the independent sampler, so that per-pixel variances are honest), and the runner allows
  z * SE with z Sidak-corrected over all statistical cases.
- at most: a one-sided bound (peak memory, samples that differ from a reference).
- not supported: the feature does not exist; the table says so instead of faking a result.

The analytic values are computed here independently of the tracer's own code (a textbook
Fresnel, not tracer/bsdf.py): a shared formula would make a wrong formula pass.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import json
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..tracer.integrator import CHUNK, PASS_PATHS, Renderer
from .stress_geometry import WHITE, box, camera, icosphere, quad, rotate_x, scene

EXACT, STATISTICAL, AT_MOST, UNSUPPORTED = "exact", "statistical", "at most", "not supported"
UNIT_ROUNDING = 2.0 ** -53
ENDED_EVENTS = ("tir_absorbed", "rejected", "depth_limited")   # each ends one sample at 0


@dataclass
class Outcome:
    """What one case measured, and the deterministic parts of its error bound."""
    measured: float
    se: float | None = None       # standard error of `measured` (statistical checks)
    tolerance: float = 0.0        # float rounding (exact checks)
    allowance: float = 0.0        # counted events (exact) or slack (at most)
    events: int = 0               # counted early ends behind the allowance
    nan_count: int = 0            # NaN/Inf samples over all renders of the case
    image: np.ndarray | None = None      # (H, W, 3) linear, for the report
    error_map: np.ndarray | None = None  # (H, W) signed error, for the report
    error_label: str = "error map"
    note: str = ""
    settings: dict = field(default_factory=dict)


@dataclass
class Case:
    """One stress case: what it measures, its analytic value and how to run it."""
    id: str
    group: str
    measures: str
    failure_means: str
    check: str
    analytic: float
    run: Callable[[int, int], Outcome] | None   # (threads, seed) -> Outcome
    quick: bool = False
    expected_failure: str = ""     # why this case is known to fail (shown in the table)


# ---------------------------------------------------------------------------------------------
# Analytic values


def fresnel_unpolarised(cos_i: float, n: float) -> float:
    """Reflectance of a smooth dielectric for unpolarised light from the outside (textbook s/p form)."""
    sin2_t = (1.0 - cos_i * cos_i) / (n * n)
    if sin2_t >= 1.0:
        return 1.0
    cos_t = math.sqrt(1.0 - sin2_t)
    rs = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    rp = (cos_t - n * cos_i) / (cos_t + n * cos_i)
    return 0.5 * (rs * rs + rp * rp)


def slab_transmission(f: float, max_depth: int | None) -> float:
    """Light through a lossless slab, each face reflecting f (the same from both sides, Stokes):
    (1 - f)^2 sum_k f^2k over the paths that fit in max_depth bounces (2 + 2k bounces for k
    internal round trips); None is the limit (1 - f) / (1 + f)."""
    if max_depth is None:
        return (1.0 - f) / (1.0 + f)
    trips = (max_depth - 2) // 2
    return sum((1.0 - f) ** 2 * f ** (2 * k) for k in range(trips + 1)) if max_depth >= 2 else 0.0


# ---------------------------------------------------------------------------------------------
# Rendering and measuring


def _render(scn, threads, seed):
    return Renderer(scn.with_render(seed=seed), threads=threads, sampler="independent").render()


def _settings(scn):
    w, h = scn.camera["resolution"]
    return {"resolution": f"{w}x{h}", "spp": scn.render["spp"], "max_depth": scn.render["max_depth"]}


def _image_mean(result):
    """Mean of channel 0 over all samples and its standard error (pixels are independent)."""
    npix = result.width * result.height
    mean = float(result.sum[..., 0].sum()) / (npix * result.spp)
    se = math.sqrt(float(result.variance_of_mean()[..., 0].sum())) / npix
    return mean, se


Z_LABEL = "per-pixel z: (pixel - analytic) / its standard error"


def _z_map(result, expected):
    var = result.variance_of_mean()[..., 0]
    diff = result.mean()[..., 0] - expected
    return np.where(var > 0, diff / np.sqrt(np.where(var > 0, var, 1.0)), np.sign(diff) * 99.0)


def _furnace_outcome(result, scn, note=""):
    """An exact white-furnace outcome: the mean of all samples against 1, counted ends allowed."""
    n = result.width * result.height * result.spp
    # Every sample is a product of weights of exactly 1, hence exactly 0 or 1, and the float64
    # sums of integers below 2^53 are exact; the tolerance bounds the rounding anyway: one
    # product rounding per bounce plus one per addition.
    measured = float(result.sum[..., 0].sum()) / n
    events = sum(int(result.stats.get(k, 0)) for k in ENDED_EVENTS)
    tolerance = (scn.render["max_depth"] + 2 + n) * UNIT_ROUNDING
    channels_equal = np.array_equal(result.sum[..., 0], result.sum[..., 2])
    img = result.mean()
    return Outcome(measured=measured if channels_equal else math.nan, tolerance=tolerance,
                   allowance=events / n, events=events, nan_count=result.nan_count, image=img,
                   error_map=img[..., 0] - 1.0, error_label="image - 1", settings=_settings(scn),
                   note=(note + "; " if note else "") + _events_note(result.stats))


def _events_note(stats):
    parts = [f"{k} {stats.get(k, 0)}" for k in ENDED_EVENTS if stats.get(k, 0)]
    return "ended early: " + (", ".join(parts) if parts else "none")


# ---------------------------------------------------------------------------------------------
# White furnace


LOSSLESS = ("mirror", "glass", "refraction")


def _material(kind, ior=1.5):
    mat = {"name": kind, "kind": kind, "color": WHITE}
    if kind != "mirror":
        mat["ior"] = float(ior)
    return mat


def furnace_scene(kind, shape="sphere", scale=1.0, offset=0.0, ior=1.5, smooth=True,
                  resolution=32, spp=16, max_depth=1000):
    """A lossless object filling most of the view inside a world of radiance 1."""
    center = np.array([offset, 0.0, 0.0])
    if shape == "sphere":
        pos, tri, nrm = icosphere(4, radius=scale, center=center)
        mesh = (pos, tri, 0, nrm) if smooth else (pos, tri, 0)
    else:
        pos, tri = box(center - scale, center + scale)
        mesh = (pos, tri, 0)
    cam = camera(position=center + (0.0, 0.0, 4.0 * scale), resolution=(resolution, resolution),
                 clip_start=0.01 * scale, clip_end=1e3 * scale + abs(offset))
    return scene([mesh], [_material(kind, ior)], cam, world=WHITE, spp=spp, max_depth=max_depth)


def _furnace_case(kind, shape="sphere", scale=1.0, offset=0.0, ior=1.5, smooth=True, quick=False):
    normals = "smooth" if smooth and shape == "sphere" else "flat"
    name = f"furnace {kind} {shape} {normals} scale {scale:g} offset {offset:g} ior {ior:g}"
    if kind == "mirror":
        name = f"furnace mirror {shape} {normals} scale {scale:g} offset {offset:g}"
    note = ""
    if kind == "refraction" and shape == "cube":
        note = "a refraction-only BSDF absorbs under total internal reflection (as Cycles')"

    def run(threads, seed):
        scn = furnace_scene(kind, shape, scale, offset, ior, smooth)
        return _furnace_outcome(_render(scn, threads, seed), scn, note)
    return Case(name, "white furnace", "mean of all samples (each exactly 1)",
                "a path was lost, weighted or ended without the integrator counting why "
                "(self-intersection, NaN, a skipped or doubled surface)",
                EXACT, 1.0, run, quick)


def furnace_cases():
    """Lossless spheres and cubes in a white furnace across scale, offset, IOR and normals."""
    cases = []
    for kind in LOSSLESS:
        cases.append(_furnace_case(kind, "sphere", quick=kind == "glass"))
        cases.append(_furnace_case(kind, "sphere", smooth=False, quick=kind == "mirror"))
        cases.append(_furnace_case(kind, "cube", quick=kind == "refraction"))
    for scale in (1e-4, 1e6):
        cases.append(_furnace_case("glass", "sphere", scale=scale, quick=scale == 1e-4))
        cases.append(_furnace_case("glass", "cube", scale=scale))
    # float32 spacing at 1e6 is 0.0625: objects of size 1e3 there are still resolved (1.6e4
    # steps across), size 1 at 1e3 (1.6e4 steps).
    cases.append(_furnace_case("glass", "sphere", scale=1.0, offset=1e3))
    cases.append(_furnace_case("glass", "sphere", scale=1e3, offset=1e6, quick=True))
    cases.append(_furnace_case("refraction", "cube", scale=1e3, offset=1e6))
    for ior in (1.0001, 4.0):
        cases.append(_furnace_case("glass", "sphere", ior=ior))
        cases.append(_furnace_case("refraction", "sphere", ior=ior))
        cases.append(_furnace_case("glass", "cube", ior=ior, quick=ior == 4.0))
    return cases


# ---------------------------------------------------------------------------------------------
# Glass slabs


SLAB_IOR = 1.5
# The camera is about 1 unit beyond the slab: Embree's float32 ray distances then resolve
# 1.2e-7, 80 times finer than the thinnest slab (see _far_slab_case for 1000 units away).
SLAB_CAMERA_DISTANCE = 1.0
SLAB_LENS_MM = 1e6     # half field 1.8e-5 rad: F varies by < 1e-7 across the image


def slab_scene(thickness, angle, max_depth=100, spp=256, resolution=16, faces="closed",
               distance=SLAB_CAMERA_DISTANCE, offset=0.0):
    """A glass slab tilted by `angle` degrees under a far, narrow camera, an emitter of radiance 1
    behind it: each sample is 1 if its path reaches the emitter, else 0.

    faces: "closed" (a box), "duplicate_top" (the top face twice, coplanar), "degenerate_top"
    (the top face as a 1e7:1 sliver, a zero-area triangle and a duplicated vertex) or "sheet"
    (the top face alone: an open mesh).
    """
    half = max(1.0, 25.0 * thickness)  # room for the sideways walk of internal reflections at 80°
    pos, tri = box((-half, -half, -thickness / 2), (half, half, thickness / 2))
    top = tri[2:4]      # box() face (4, 5, 7, 6): z = hi
    if faces == "duplicate_top":
        tri = np.concatenate([tri, top])
    elif faces == "degenerate_top":
        pos, tri = _degenerate_top(pos, tri)
    elif faces == "sheet":
        tri = top
    shift = np.array([offset, 0.0, 0.0])
    pos = rotate_x(pos, angle) + shift
    lamp_z = -(half + 100.0)
    # Reflected light leaves at 2 * angle from the view axis and lands 36 units beside the
    # emitter at 80 degrees; transmitted light lands within a few units of its centre.
    lamp = quad((offset, 0.0, lamp_z), 10.0, 10.0)
    mats = [_material("glass", SLAB_IOR),
            {"name": "lamp", "kind": "emission", "color": WHITE, "strength": 1.0}]
    # Outside the tilted slab's volume, which reaches up to (t / 2) / cos(angle) on the axis.
    above = 0.5 * thickness / math.cos(math.radians(angle))
    cam = camera(position=shift + (0, 0, above + distance), resolution=(resolution, resolution),
                 lens=SLAB_LENS_MM)
    return scene([(pos, tri, 0), (*lamp, 1)], mats, cam, spp=spp, max_depth=max_depth)


def _degenerate_top(pos, tri):
    """The top face (corners 4, 5, 7, 6 = A, B, C, D) split through a point M 1e-7 of the diagonal
    off it: the sliver A-C-M (aspect 1e7:1) across the image centre, plus a zero-area triangle
    and a corner duplicated as its own vertex (unwelded, as some exporters write)."""
    a, b, c, d = pos[4], pos[5], pos[7], pos[6]
    diag = c - a
    normal_in_plane = np.array([-diag[1], diag[0], 0.0]) / np.linalg.norm(diag[:2])
    m = 0.5 * (a + c) + 1e-7 * np.linalg.norm(diag) * normal_in_plane   # towards D
    pos = np.concatenate([pos, [m, c]])
    im, ic2 = len(pos) - 2, len(pos) - 1
    rest = np.concatenate([tri[:2], tri[4:]])
    top = np.array([[4, 5, 7], [4, 7, im], [ic2, 6, im], [6, 4, im], [4, 7, 7]], np.int32)
    return pos, np.concatenate([rest, top])


def _slab_value(angle, max_depth, faces="closed"):
    f = fresnel_unpolarised(math.cos(math.radians(angle)), SLAB_IOR)
    if faces == "sheet":   # one glass-air interface, never left: what passes it goes on
        return 1.0 - f if max_depth is None or max_depth >= 1 else 0.0
    return slab_transmission(f, max_depth)


def _slab_case(thickness, angle, max_depth=100, faces="closed", quick=False, name=None,
               group="glass slab", failure=None, distance=SLAB_CAMERA_DISTANCE, expected_failure="",
               note="", offset=0.0):
    limit = max_depth >= 100
    expected = _slab_value(angle, None if limit else max_depth, faces)
    name = name or (f"slab {thickness:g} thick at {angle:g} deg, max depth {max_depth}")
    measures = ("share of samples reaching the emitter: " +
                ("(1-F)/(1+F)" if limit else f"partial sum for max depth {max_depth}"))
    if faces == "sheet":
        measures = "share of samples reaching the emitter through one glass face: 1-F"

    def run(threads, seed):
        scn = slab_scene(thickness, angle, max_depth, faces=faces, distance=distance, offset=offset)
        result = _render(scn, threads, seed)
        mean, se = _image_mean(result)
        return Outcome(mean, se=se, nan_count=result.nan_count, image=result.mean(),
                       error_map=_z_map(result, expected), error_label=Z_LABEL, settings=_settings(scn),
                       note=(note + "; " if note else "")
                       + f"F = {fresnel_unpolarised(math.cos(math.radians(angle)), SLAB_IOR):.6f}")
    return Case(name, group, measures,
                failure or "light is lost or gained crossing a thin or tilted interface (offsets, "
                           "Fresnel, or the depth count)", STATISTICAL, expected, run, quick,
                expected_failure=expected_failure)


def slab_cases():
    """Slabs 1e-5 to 1 thick at 0 and 80 degrees; partial sums at max depth 1, 2, 3."""
    cases = []
    for thickness in (1e-5, 1e-3, 1.0):
        for angle in (0.0, 80.0):
            cases.append(_slab_case(thickness, angle,
                                    quick=(thickness, angle) in ((1e-5, 0.0), (1.0, 80.0))))
    for depth in (1, 2, 3, 4):
        cases.append(_slab_case(1e-3, 0.0, depth, quick=depth in (2, 4)))
    cases.append(_slab_case(1e-3, 80.0, 3))
    cases.append(_far_slab_case())
    cases += _offset_slab_cases()
    return cases


def _offset_slab_cases():
    """Slabs away from the origin, thin in float32 ulps of their coordinates (ulp(1e3) = 6.1e-5,
    ulp(1e6) = 0.0625): 1e-3 at 1e2 is 131 ulps thick, 1e-3 at 1e3 16, 1 at 1e6 16, 8 at 1e6 128."""
    reason = ("the self-intersection offset is 2^-18 of the hit's coordinates (about 32 float32 "
              "ulps; tracer/geometry.py RELATIVE_OFFSET): the ray entering glass thinner than that "
              "starts beyond its far face, and the slab acts as one interface (1-F = 0.96)")
    cases = []
    for thickness, offset, quick in ((1e-3, 1e2, False), (1e-3, 1e3, True), (1.0, 1e6, True),
                                     (8.0, 1e6, False)):
        thin = thickness < 32 * np.spacing(np.float32(offset))
        cases.append(_slab_case(thickness, 0.0, offset=offset, quick=quick,
                                name=f"slab {thickness:g} thick at offset {offset:g}",
                                expected_failure=reason if thin else ""))
    return cases


def _far_slab_case():
    """The float32 limit, shown rather than hidden: a 1e-5 slab seen from 1000 units away."""
    return _slab_case(
        1e-5, 0.0, distance=1000.0, quick=True, name="slab 1e-5 thick seen from 1000 units away",
        failure="(known limit) the first hit of a ray is not resolved along its length",
        expected_failure="Embree intersects in float32: at t = 1000 one ulp is 6.1e-5, more than "
                         "the slab's thickness, so a ray may report the far face first and the slab "
                         "acts as one interface (1-F = 0.96); Cycles' float32 rays share the limit")


# ---------------------------------------------------------------------------------------------
# Nested and coincident surfaces


BALL_LENS_MM = 3600.0    # half field 0.005 rad at 10 units: incidence below 2.9 degrees


def ball_scene(inner_radius=None, spp=256, resolution=16):
    """A glass ball (radius 1; optionally a concentric glass ball of the same IOR inside) seen
    on axis at near-normal incidence against an emitter of radiance 1 far behind."""
    meshes = []
    pos, tri, nrm = icosphere(5, radius=1.0)
    meshes.append((pos, tri, 0, nrm))
    if inner_radius:
        pos, tri, nrm = icosphere(5, radius=inner_radius)
        meshes.append((pos, tri, 0, nrm))
    lamp = quad((0.0, 0.0, -20.0), 20.0, 20.0)
    mats = [_material("glass", SLAB_IOR),
            {"name": "lamp", "kind": "emission", "color": WHITE, "strength": 1.0}]
    cam = camera(position=(0, 0, 10.0), resolution=(resolution, resolution), lens=BALL_LENS_MM)
    return scene(meshes + [(*lamp, 1)], mats, cam, spp=spp, max_depth=64)


def _ball_case(inner_radius, quick):
    f = fresnel_unpolarised(1.0, SLAB_IOR)
    expected = (1.0 - f) / (1.0 + f)
    if inner_radius:
        four = (1.0 - f) / (1.0 + 3.0 * f)
        name, reason = ("glass ball inside a glass ball, same IOR",
                        "Snell, like Cycles, has no medium stack: every surface is glass against air, "
                        f"so the inner ball adds two interfaces and transmits (1-F)/(1+3F) = {four:.4f}")
        measures = "share of near-axis samples through both balls: as one ball, (1-F)/(1+F)"
    else:
        name, reason, measures = ("glass ball alone (control)", "",
                                  "share of near-axis samples through the ball: (1-F)/(1+F)")

    def run(threads, seed):
        scn = ball_scene(inner_radius)
        result = _render(scn, threads, seed)
        mean, se = _image_mean(result)
        return Outcome(mean, se=se, nan_count=result.nan_count, image=result.mean(),
                       error_map=_z_map(result, expected), error_label=Z_LABEL, settings=_settings(scn))
    return Case(name, "nested and coincident", measures,
                "a surface inside glass is not the interface it should be" if inner_radius else
                "the near-axis ball model itself is off (the nested case would mean nothing)",
                STATISTICAL, expected, run, quick, expected_failure=reason)


def coplanar_emitters_case():
    """Two coincident emissive quads: every camera sample sees exactly one of them."""
    def run(threads, seed):
        a, b = quad((0, 0, 0), 3, 3), quad((0, 0, 0), 3, 3)
        mats = [{"name": "lamp", "kind": "emission", "color": WHITE, "strength": 1.0}]
        scn = scene([(*a, 0), (*b, 0)], mats, camera(position=(0, 0, 5), resolution=(32, 32)),
                    spp=16, max_depth=4)
        return _furnace_outcome(_render(scn, threads, seed), scn)
    return Case("two coplanar emissive faces", "nested and coincident",
                "mean of all samples (each exactly 1: one face is hit, never both or neither)",
                "rays pass between or through coincident faces, or add both", EXACT, 1.0, run, True)


# addon/export.py's warning for such a mesh, word for word:
OPEN_MESH_WARNING = ("exporter warning: object '...': glass material '...' on a mesh that is not "
                     "closed (its edges are not all shared by two triangles)")


def nested_cases():
    """Nested balls, a doubled face, coplanar emitters and an open glass mesh."""
    return [
        _ball_case(None, quick=True),
        _ball_case(0.5, quick=True),
        _slab_case(1e-3, 0.0, faces="duplicate_top", quick=True, group="nested and coincident",
                   name="slab 1e-3 thick with its top face doubled (coplanar)",
                   failure="a ray re-hits the coplanar copy of the face it just crossed"),
        coplanar_emitters_case(),
        _slab_case(1e-3, 0.0, faces="sheet", quick=True, group="nested and coincident",
                   name="open glass mesh (one quad; exporter warns 'not closed')",
                   note=OPEN_MESH_WARNING,
                   failure="an open glass surface is not the one interface Cycles makes of it"),
    ]


# ---------------------------------------------------------------------------------------------
# Thin lens


LENS_WIDTH = 48          # pixels
COC_PIXELS = 12.0        # the circle of confusion's radius each lens case is set up for
SENSOR_MM = 36.0


def lens_setup(focus, fstop):
    """(lens mm, aperture radius m, CoC radius px) putting an on-axis object at twice the focus
    distance into a circle of confusion of COC_PIXELS: tangent radius a (1/f - 1/2f) over a pixel
    of sensor / (lens width), with a = lens / (2 fstop)."""
    lens_mm = math.sqrt(COC_PIXELS * SENSOR_MM * 4000.0 * fstop * focus / LENS_WIDTH)
    aperture = lens_mm * 1e-3 / (2.0 * fstop)
    pixel = SENSOR_MM / (lens_mm * LENS_WIDTH)
    return lens_mm, aperture, aperture * (1.0 / focus - 1.0 / (2.0 * focus)) / pixel


def lens_scene(focus, fstop, blades=0, emitter="square", spp=64, use_dof=True):
    """An emitter of radiance 1 at twice the focus distance on the axis of a thin-lens camera.

    emitter "square": a square of half-size = half the CoC (in the image); "point": a point lamp
    of radius a tenth of the CoC. Returns (scene, CoC px, emitter half-size px).
    """
    z = 2.0 * focus
    lens_mm, aperture, coc_px = lens_setup(focus, fstop)
    pixel = SENSOR_MM / (lens_mm * LENS_WIDTH)
    dof = {"use_dof": use_dof, "focus_distance": focus, "fstop": fstop, "blades": blades}
    cam = camera(position=(0, 0, 0), resolution=(LENS_WIDTH, LENS_WIDTH), lens=lens_mm, dof=dof,
                 clip_start=z * 1e-4, clip_end=z * 10.0)
    if emitter == "square":
        half_px = coc_px / 2.0
        pos, tri = quad((0.0, 0.0, -z), half_px * pixel * z, half_px * pixel * z)
        mats = [{"name": "lamp", "kind": "emission", "color": WHITE, "strength": 1.0}]
        return scene([(pos, tri, 0)], mats, cam, spp=spp, max_depth=0), coc_px, half_px
    radius_px = coc_px / 10.0
    lamp = {"name": "point", "kind": "point", "position": [0.0, 0.0, -z], "intensity": WHITE,
            "radius": radius_px * pixel * z, "soft_falloff": True}
    return scene([], [], cam, lights=[lamp], spp=spp, max_depth=0), coc_px, radius_px


def _pixel_offsets(w, h):
    """Squared distance in pixels of every pixel centre from the image centre."""
    ys, xs = np.mgrid[0:h, 0:w] + 0.5
    return (xs - w / 2.0) ** 2 + (ys - h / 2.0) ** 2


def coc_radius(result, half_px):
    """The circle of confusion's radius in pixels from the image's second moment about the centre,
    with its standard error (delta method): E[r^2] = R^2/2 + 2 h^2/3 (square) + 1/6 (pixel box)."""
    v = result.mean()[..., 0].astype(np.float64)
    var = result.variance_of_mean()[..., 0]
    r2 = _pixel_offsets(result.width, result.height)
    total = v.sum()
    m = float((r2 * v).sum() / total)
    se_m = math.sqrt(float((((r2 - m) / total) ** 2 * var).sum()))
    radius2 = 2.0 * (m - 1.0 / 6.0 - 2.0 * half_px ** 2 / 3.0)
    radius = math.sqrt(max(radius2, 0.0))
    return radius, se_m / max(radius, 1e-12)


def _coc_case(focus, fstop, blades=0, quick=False):
    lens_mm, aperture, coc_px = lens_setup(focus, fstop)
    # A regular polygon inscribed in radius a has E[r^2] = a^2 (2 + cos(2 pi / B)) / 6 (its B
    # triangles from the centre); a disk a^2 / 2. Measured as sqrt(2 E[r^2]).
    expected = coc_px * (math.sqrt((2.0 + math.cos(2.0 * math.pi / blades)) / 3.0) if blades else 1.0)
    shape = f"{blades}-blade polygon" if blades else "disk"

    def run(threads, seed):
        scn, coc, half_px = lens_scene(focus, fstop, blades)
        result = _render(scn, threads, seed)
        radius, se = coc_radius(result, half_px)
        return Outcome(radius, se=se, nan_count=result.nan_count, image=result.mean(),
                       error_map=result.mean()[..., 0] - result.mean()[..., 0].mean(),
                       error_label="image - its mean (the blur's shape)", settings=_settings(scn),
                       note=f"lens {lens_mm:.4g} mm, aperture radius {aperture:.3g} m")
    return Case(f"CoC focus {focus:g} f/{fstop:g} {shape}", "thin lens",
                f"RMS circle-of-confusion radius (px) of a square at twice the focus distance, "
                f"{shape} aperture",
                "the lens samples, the focus plane or the aperture size are wrong at this scale",
                STATISTICAL, expected, run, quick)


def _pinhole_limit_case(quick):
    focus, fstop = 1.0, 1e6
    lens_mm = 50.0

    def run(threads, seed):
        scn = _pinhole_scene(focus, fstop, lens_mm, True)
        pin = _pinhole_scene(focus, fstop, lens_mm, False)
        a, b = _render(scn, threads, seed), _render(pin, threads, seed)
        differing = float(np.abs(a.sum[..., 0] - b.sum[..., 0]).sum())
        # A sample differs only if the lens moves its ray across the emitter's edge: within the
        # CoC radius of it. Expected count: samples x (edge length x 2 CoC) / image area; the
        # allowance is its Poisson quantile at the case's share of alpha.
        aperture = lens_mm * 1e-3 / (2 * fstop)
        pixel = SENSOR_MM / (lens_mm * LENS_WIDTH)
        coc = aperture * (1 / focus - 1 / 2.0) / pixel
        n = LENS_WIDTH ** 2 * a.spp
        expected_flips = n * (4 * 2 * LENS_WIDTH / 3) * 2 * coc / LENS_WIDTH ** 2
        from scipy import stats
        allowed = float(stats.poisson.isf(1e-4, expected_flips))
        return Outcome(differing, allowance=allowed, nan_count=a.nan_count + b.nan_count,
                       image=a.mean(), error_map=(a.mean() - b.mean())[..., 0],
                       error_label="depth of field - pinhole", settings=_settings(scn),
                       note=f"CoC {coc:.2g} px; expected differing samples {expected_flips:.2g}")
    return Case("pinhole limit f/1e6", "thin lens",
                "samples that differ from the pinhole render (same seed)",
                "a vanishing aperture still moves rays: the lens sampling or focus math is unstable",
                AT_MOST, 0.0, run, quick)


def _pinhole_scene(focus, fstop, lens_mm, use_dof):
    z = 2.0 * focus
    half = z * SENSOR_MM / (2 * lens_mm) / 3.0   # a square a third of the image wide
    dof = {"use_dof": use_dof, "focus_distance": focus, "fstop": fstop}
    cam = camera(position=(0, 0, 0), resolution=(LENS_WIDTH, LENS_WIDTH), lens=lens_mm, dof=dof)
    pos, tri = quad((0.0, 0.0, -z), half, half)
    mats = [{"name": "lamp", "kind": "emission", "color": WHITE, "strength": 1.0}]
    return scene([(pos, tri, 0)], mats, cam, spp=16, max_depth=0)


def point_light_area(result, coc_px, radius_px):
    """Area (px^2) of an out-of-focus lamp's image as its total over its plateau level, with the
    delta-method standard error; the plateau is the pixels wholly inside radius R - r."""
    v = result.mean()[..., 0].astype(np.float64)
    var = result.variance_of_mean()[..., 0]
    r = np.sqrt(_pixel_offsets(result.width, result.height))
    plateau = r + math.sqrt(0.5) <= coc_px - radius_px
    total, level = v.sum(), v[plateau].mean()
    grad = np.full(v.shape, 1.0 / level)
    grad[plateau] -= total / (level ** 2 * plateau.sum())
    return total / level, math.sqrt(float((grad ** 2 * var).sum()))


def _point_light_case(focus, fstop, quick):
    _, _, coc_px = lens_setup(focus, fstop)

    def run(threads, seed):
        scn, coc, radius_px = lens_scene(focus, fstop, emitter="point", spp=256)
        result = _render(scn, threads, seed)
        area, se = point_light_area(result, coc, radius_px)
        return Outcome(area, se=se, nan_count=result.nan_count, image=result.mean(),
                       error_map=result.mean()[..., 0] - result.mean()[..., 0].mean(),
                       error_label="image - its mean (the blur's shape)",
                       settings=_settings(scn), note=f"CoC {coc:.2f} px, lamp radius {radius_px:.2f} px")
    return Case(f"point lamp out of focus, focus {focus:g} f/{fstop:g}", "thin lens",
                "area (px^2) of the lamp's blurred image: total / plateau = pi R^2",
                "an out-of-focus lamp spreads over the wrong area (lens sampling or lamp hits)",
                STATISTICAL, math.pi * coc_px ** 2, run, quick)


def lens_cases():
    """CoC across focus 1e-3 to 1e6 and f/0.5 to f/1e6, polygons, pinhole limit, point lamp."""
    cases = []
    for focus, fstop in ((1e-3, 0.5), (1e-3, 1e6), (1.0, 2.8), (1e6, 0.5), (1e6, 1e6)):
        cases.append(_coc_case(focus, fstop, quick=(focus, fstop) in ((1e-3, 0.5), (1e6, 1e6))))
    cases.append(_coc_case(1.0, 2.8, blades=6, quick=True))
    cases.append(_coc_case(1.0, 2.8, blades=3))
    cases.append(_pinhole_limit_case(quick=True))
    cases.append(_point_light_case(1.0, 2.8, quick=True))
    return cases


# ---------------------------------------------------------------------------------------------
# Lights


def lit_floor_scene(strength=1.0, spp=16):
    """A diffuse floor under an area lamp and beside an emissive quad, all emitters x strength."""
    floor = quad((0, 0, 0), 5, 5)
    panel = quad((2.0, 0, 1.0), 0.5, 0.5, normal_sign=-1)
    m = np.eye(4)
    m[:3, 3] = (-1.0, 0.0, 2.0)
    area = {"name": "area", "kind": "area", "shape": "disk", "matrix": m.tolist(), "size": [1.0, 1.0],
            "radiance": [4.0 * strength] * 3, "visible_camera": True}
    point = {"name": "point", "kind": "point", "position": [0.0, 1.0, 1.5],
             "intensity": [2.0 * strength] * 3, "radius": 0.2}
    mats = [{"name": "floor", "kind": "diffuse", "color": [0.8, 0.6, 0.4]},
            {"name": "panel", "kind": "emission", "color": WHITE, "strength": 3.0 * strength}]
    cam = camera(position=(0, 0, 6), resolution=(32, 32), lens=30.0)
    return scene([(*floor, 0), (*panel, 1)], mats, cam, lights=[area, point], spp=spp, max_depth=3)


def _strength_case(strength, quick):
    def run(threads, seed):
        base, scaled = lit_floor_scene(1.0), lit_floor_scene(strength)
        a, b = _render(base, threads, seed), _render(scaled, threads, seed)
        finite = bool(np.all(np.isfinite(b.sum)) and np.all(np.isfinite(b.sum_sq))
                      and np.all(np.isfinite(b.mean())))
        ref = a.sum
        rel = np.abs(b.sum / strength - ref) / np.where(ref > 0, ref, 1.0)
        measured = float(rel.max()) if finite else math.inf
        # Each sample is a product of at most ~4 factors per bounce (3 bounces) and one strength;
        # summing spp of them adds spp roundings: relative error <= (4 * 3 + 2 + spp) u per sum,
        # for each of the two renders.
        tolerance = 2 * (4 * 3 + 2 + a.spp) * UNIT_ROUNDING
        return Outcome(measured, tolerance=tolerance, nan_count=a.nan_count + b.nan_count,
                       image=b.mean() / strength, error_map=(b.sum / strength - ref)[..., 0],
                       error_label="sums / strength - sums at strength 1",
                       settings=_settings(scaled),
                       note="all sums finite" if finite else "non-finite sums")
    return Case(f"emitters x {strength:g}", "lights",
                "largest relative difference between the render / strength and the render at 1",
                "the image does not scale linearly with light strength (overflow, underflow, "
                "a clamp or a strength-dependent choice)", EXACT, 0.0, run, quick)


def _zero_size_lamp_case(quick):
    height, intensity, albedo = 1.0, 1.0, 0.5
    cam_height, lens_mm, res = 5.0, 5000.0, 9
    # Radiance at distance r from the foot of the lamp: albedo I h / (pi (h^2 + r^2)^1.5).
    expected = albedo * intensity / (math.pi * height ** 2)
    footprint = cam_height * SENSOR_MM / lens_mm / res        # one pixel on the floor
    r_max = footprint * math.sqrt(0.5)
    spread = expected * (1.0 - (1.0 + (r_max / height) ** 2) ** -1.5)

    def run(threads, seed):
        floor = quad((0, 0, 0), 50, 50)
        mats = [{"name": "floor", "kind": "diffuse", "color": [albedo] * 3}]
        lamp = {"name": "point", "kind": "point", "position": [0, 0, height],
                "intensity": [intensity] * 3, "radius": 0.0}
        scn = scene([(*floor, 0)], mats, camera(position=(0, 0, cam_height), resolution=(res, res),
                                                  lens=lens_mm), lights=[lamp], spp=16, max_depth=1)
        result = _render(scn, threads, seed)
        img = result.mean()
        return Outcome(float(result.sum[res // 2, res // 2, 0] / result.spp),
                       tolerance=spread + 64 * UNIT_ROUNDING, nan_count=result.nan_count, image=img,
                       error_map=img[..., 0] - expected, error_label="image - analytic (centre)",
                       settings=_settings(scn),
                       note=f"the pixel spans {spread:.2g} of falloff")
    return Case("zero-size point lamp over a floor", "lights",
                "radiance of the floor pixel under the lamp: albedo I / (pi h^2)",
                "a lamp of radius 0 is not a point of intensity I (NaN, 0 or a wrong 1/r^2)",
                EXACT, expected, run, quick)


def _zero_angle_sun_case(quick):
    albedo, irradiance, elevation = 0.5, 2.0, 30.0
    cos = math.sin(math.radians(elevation))
    expected = albedo * irradiance * cos / math.pi     # the same at every pixel of the floor

    def run(threads, seed):
        floor = quad((0, 0, 0), 50, 50)
        mats = [{"name": "floor", "kind": "diffuse", "color": [albedo] * 3}]
        d = [0.0, -math.cos(math.radians(elevation)), -cos]
        sun = {"name": "sun", "kind": "sun", "direction": d, "irradiance": [irradiance] * 3,
               "angle": 0.0}
        scn = scene([(*floor, 0)], mats, camera(position=(0, 0, 5), resolution=(16, 16)),
                    lights=[sun], spp=16, max_depth=1)
        result = _render(scn, threads, seed)
        img = result.mean()
        values = result.sum[..., 0] / result.spp
        farthest = float(values.flat[np.argmax(np.abs(values - expected))])
        # Each sample is albedo * E * cos / pi from a handful of products, then spp are summed.
        return Outcome(farthest, tolerance=(16 + result.spp) * expected * UNIT_ROUNDING,
                       nan_count=result.nan_count, image=img, error_map=img[..., 0] - expected,
                       error_label="image - analytic", settings=_settings(scn),
                       note="measured: the pixel farthest from the analytic value")
    return Case("sun of angle 0 over a floor", "lights",
                "floor radiance, the pixel farthest from albedo E cos(theta) / pi",
                "a sun of zero angle is not a delta direction (NaN, 0 or a wrong cosine)",
                EXACT, expected, run, quick)


def _lamp_in_glass_case(quick):
    def run(threads, seed):
        with_glass, without = _lamp_in_glass_scene(True), _lamp_in_glass_scene(False)
        a, b = _render(with_glass, threads, seed), _render(without, threads, seed + 1)
        sa, sb = a.sum[..., 0].sum() / a.spp, b.sum[..., 0].sum() / b.spp
        va, vb = a.variance_of_mean()[..., 0].sum(), b.variance_of_mean()[..., 0].sum()
        ratio = sa / sb
        se = math.sqrt(va / sb ** 2 + vb * sa ** 2 / sb ** 4)
        return Outcome(float(ratio), se=se, nan_count=a.nan_count + b.nan_count, image=a.mean(),
                       error_map=(a.mean() - b.mean())[..., 0], error_label="with glass - without",
                       settings=_settings(with_glass),
                       note=f"IOR {SLAB_IOR}; IOR^2 = {SLAB_IOR ** 2:g}")
    return Case("lamp inside a closed glass ball", "lights",
                "light leaving the ball towards the camera / the same lamp without the ball",
                "glass creates or destroys light", STATISTICAL, 1.0, run, quick,
                expected_failure="Snell, like Cycles, refracts radiance unscaled (no 1/IOR^2, "
                                 "tracer/bsdf.py): light leaving glass keeps its radiance over a "
                                 "solid angle IOR^2 larger, so about IOR^2 (1-F) comes out; "
                                 "Cycles 5.0 gave 2.23 on the same scene")


def _lamp_in_glass_scene(glass):
    pos, tri, nrm = icosphere(4, radius=1.0)
    lamp = {"name": "point", "kind": "point", "position": [0.0, 0.0, 0.0], "intensity": WHITE,
            "radius": 0.1, "soft_falloff": True}
    cam = camera(position=(0, 0, 10), resolution=(48, 48), lens=150.0)
    meshes = [(pos, tri, 0, nrm)] if glass else []
    return scene(meshes, [_material("glass", SLAB_IOR)], cam, lights=[lamp], spp=256, max_depth=64)


def light_cases():
    """Lamp strengths 1e-30 and 1e30, zero-size lamps, a lamp inside glass."""
    return [_strength_case(1e-30, quick=True), _strength_case(1e30, quick=True),
            _zero_size_lamp_case(quick=True), _zero_angle_sun_case(quick=True),
            _lamp_in_glass_case(quick=True)]


# ---------------------------------------------------------------------------------------------
# Degenerate geometry


def _camera_in_glass_case(quick):
    def run(threads, seed):
        pos, tri, nrm = icosphere(4, radius=1.0)
        cam = camera(position=(0, 0, 0), resolution=(32, 32), lens=20.0)
        scn = scene([(pos, tri, 0, nrm)], [_material("glass", SLAB_IOR)], cam, world=WHITE,
                    spp=16, max_depth=1000)
        return _furnace_outcome(_render(scn, threads, seed), scn)
    return Case("camera inside a glass ball (at its centre)", "degenerate geometry",
                "mean of all samples in a white furnace (each exactly 1)",
                "rays that start inside glass are refracted the wrong way or lost", EXACT, 1.0, run,
                quick)


def _unwelded_cube_case(quick):
    def run(threads, seed):
        pos, tri = box((-1, -1, -1), (1, 1, 1))
        pos, tri = pos[tri].reshape(-1, 3), np.arange(3 * len(tri), dtype=np.int32).reshape(-1, 3)
        scn = scene([(pos, tri, 0)], [_material("glass", SLAB_IOR)],
                    camera(position=(0.3, 0.2, 4), resolution=(32, 32)), world=WHITE, spp=16,
                    max_depth=1000)
        return _furnace_outcome(_render(scn, threads, seed), scn)
    return Case("glass cube with duplicated (unwelded) vertices", "degenerate geometry",
                "mean of all samples in a white furnace (each exactly 1)",
                "rays leak through edges between triangles that share no vertices", EXACT, 1.0,
                run, quick)


def degenerate_cases():
    """Slivers, zero-area triangles, duplicated vertices, a camera inside glass."""
    return [
        _slab_case(1e-3, 0.0, faces="degenerate_top", quick=True, group="degenerate geometry",
                   name="slab whose top face has a 1e7:1 sliver, a zero-area triangle and a "
                        "duplicated vertex",
                   failure="rays leak through or bounce off degenerate triangles"),
        _unwelded_cube_case(quick=False),
        _camera_in_glass_case(quick=True),
    ]


# ---------------------------------------------------------------------------------------------
# Image extremes


def _small_image_case(resolution, spp, quick):
    def run(threads, seed):
        scn = furnace_scene("glass", resolution=resolution, spp=spp)
        if resolution == 1:      # the ball fills the single pixel
            scn = scn.with_camera(lens=200.0)
        return _furnace_outcome(_render(scn, threads, seed), scn)
    return Case(f"{resolution}x{resolution} at {spp} spp", "image extremes",
                "mean of all samples in a white furnace (each exactly 1)",
                "a tiny image or a single sample breaks the pass and chunk arithmetic",
                EXACT, 1.0, run, quick)


BIG_SIZE, BIG_SIZE_QUICK = 8192, 1024
MEMORY_SLACK = 16 << 20   # the allocator's per-thread arenas and Python's own objects
JOB_BYTES = 2048          # one chunk job of a pass: its tuple and its Future (measured 1.7 KB)


def working_set_bytes(threads: int, npix: int) -> int:
    """What a render needs besides its two (H, W, 3) float64 sums: each thread's chunk buffers
    (tracer/integrator._Buffers), one pass's chunk jobs (the pool holds a Future per chunk of the
    pass: at most max(npix, PASS_PATHS) / CHUNK of them, whatever the sample count) and
    MEMORY_SLACK."""
    from ..tracer import wavefront
    per_thread = (sum(a.nbytes for a in wavefront.new_paths(CHUNK)) * 2
                  + sum(a.nbytes for a in wavefront.new_shadows(CHUNK))
                  + CHUNK * (3 * 8 + 8))
    jobs = (max(npix, PASS_PATHS) // CHUNK + 1) * JOB_BYTES
    return threads * per_thread + jobs + MEMORY_SLACK


def _big_scene(size, spp):
    pos, tri = quad((0.0, 0.0, 0.0), 1.0, 1.0)
    cam = camera(position=(0, 0, 20.0), resolution=(size, size), lens=50.0)
    return scene([(pos, tri, 0)], [_material("glass", SLAB_IOR)], cam, world=WHITE, spp=spp,
                 max_depth=8)


MEMORY_CHILD = r"""
import importlib, json, sys
sys.path[:0] = {path!r}
cases = importlib.import_module({module!r})
print(json.dumps(cases.memory_child({size}, {spp}, {threads})))
"""


def memory_child(size, spp, threads):
    """Run in a child process: render the big image, report peak RSS (VmHWM) and the sums."""
    scn = _big_scene(size, spp)
    result = _render(scn, threads, 0)
    with open("/proc/self/status") as f:
        peak = next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmHWM:"))
    events = sum(int(result.stats.get(k, 0)) for k in ENDED_EVENTS)
    return {"peak_bytes": peak, "sum": float(result.sum[..., 0].sum()), "n": size * size * spp,
            "events": events, "nan": result.nan_count, "time_s": result.time_s}


def _child(size, spp, threads):
    code = MEMORY_CHILD.format(path=list(sys.path), module=__name__, size=size, spp=spp,
                               threads=threads)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=3600)
    if out.returncode != 0:
        raise RuntimeError(f"memory child failed: {out.stderr.strip().splitlines()[-1:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def _big_cases(quick):
    size = BIG_SIZE_QUICK if quick else BIG_SIZE
    buffers = 2 * size * size * 3 * 8
    runs = {}

    def measure(threads):
        if threads not in runs:
            if not os.path.exists("/proc/self/status"):
                raise RuntimeError("peak RSS needs Linux's /proc")
            runs[threads] = (_child(1, 1, threads), _child(size, 1, threads),
                             _child(size, 2, threads))
        return runs[threads]

    def run_furnace(threads, seed):
        _, one, two = measure(threads)
        n = one["n"] + two["n"]
        events = one["events"] + two["events"]
        return Outcome((one["sum"] + two["sum"]) / n, tolerance=(10 + n) * UNIT_ROUNDING,
                       allowance=events / n, events=events, nan_count=one["nan"] + two["nan"],
                       settings={"resolution": f"{size}x{size}", "spp": "1 and 2", "max_depth": 8},
                       note=f"render {one['time_s']:.0f} s + {two['time_s']:.0f} s")

    def run_memory(threads, seed):
        base, one, two = measure(threads)
        above = max(one["peak_bytes"], two["peak_bytes"]) - base["peak_bytes"]
        return Outcome(float(above), allowance=float(working_set_bytes(threads, size * size)),
                       nan_count=one["nan"] + two["nan"],
                       settings={"resolution": f"{size}x{size}", "spp": "1 and 2", "max_depth": 8},
                       note=(f"peak above a 1x1 render: {(one['peak_bytes'] - base['peak_bytes']) / 2**20:.1f} MiB "
                             f"at 1 spp, {(two['peak_bytes'] - base['peak_bytes']) / 2**20:.1f} MiB at "
                             f"2 spp; sums {buffers / 2**20:.1f} MiB"))
    return [
        Case(f"{size}x{size} furnace (glass quad)", "image extremes",
             "mean of all samples at 1 and 2 spp (each exactly 1)",
             "a large image loses or corrupts samples (index overflow, chunking)", EXACT, 1.0,
             run_furnace, True),
        Case(f"{size}x{size} peak memory", "image extremes",
             "peak RSS above a 1x1 render (bytes), at 1 and 2 spp: at most the two float64 sums "
             "plus the working set", "the render holds per-sample or per-pass images: memory grows "
             "with the sample count", AT_MOST, float(buffers), run_memory, True),
    ]


def extreme_cases(quick=False):
    """1x1 pixel, 1 spp, and a big render's value and peak memory."""
    return [_small_image_case(1, 64, True), _small_image_case(64, 1, True)] + _big_cases(quick)


# ---------------------------------------------------------------------------------------------


def all_cases(quick: bool = False) -> list[Case]:
    """Every case of the matrix, or the --quick subset."""
    cases = (furnace_cases() + slab_cases() + nested_cases() + lens_cases() + light_cases()
             + degenerate_cases() + extreme_cases(quick))
    return [c for c in cases if c.quick] if quick else cases
