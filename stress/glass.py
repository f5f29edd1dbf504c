"""Stress cases of glass and mirrors: white furnaces, slabs, nested, coincident and degenerate
surfaces."""
from __future__ import annotations

import math

import numpy as np

from .cases import (EXACT, LOSSLESS, STATISTICAL, Case, Outcome, fresnel_unpolarised,
                    furnace_outcome, image_mean, material, render, settings_of,
                    Z_LABEL, slab_transmission, z_map)
from .geometry import WHITE, box, camera, icosphere, quad, rotate_x, scene


# ---------------------------------------------------------------------------------------------
# White furnace


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
    return scene([mesh], [material(kind, ior)], cam, world=WHITE, spp=spp, max_depth=max_depth)


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
        return furnace_outcome(render(scn, threads, seed), scn, note)
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
    mats = [material("glass", SLAB_IOR),
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
        result = render(scn, threads, seed)
        mean, se = image_mean(result)
        return Outcome(mean, se=se, nan_count=result.nan_count, image=result.mean(),
                       error_map=z_map(result, expected), error_label=Z_LABEL,
                       settings=settings_of(scn),
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
                         "the slab's thickness, so a ray may report the far face first "
                         "and the slab "
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
    mats = [material("glass", SLAB_IOR),
            {"name": "lamp", "kind": "emission", "color": WHITE, "strength": 1.0}]
    cam = camera(position=(0, 0, 10.0), resolution=(resolution, resolution), lens=BALL_LENS_MM)
    return scene(meshes + [(*lamp, 1)], mats, cam, spp=spp, max_depth=64)


def _ball_case(inner_radius, quick):
    f = fresnel_unpolarised(1.0, SLAB_IOR)
    expected = (1.0 - f) / (1.0 + f)
    if inner_radius:
        four = (1.0 - f) / (1.0 + 3.0 * f)
        name, reason = ("glass ball inside a glass ball, same IOR",
                        "Snell, like Cycles, has no medium stack: every surface is glass against "
                        "air, so the inner ball adds two interfaces and transmits (1-F)/(1+3F) = "
                        f"{four:.4f}")
        measures = "share of near-axis samples through both balls: as one ball, (1-F)/(1+F)"
    else:
        name, reason, measures = ("glass ball alone (control)", "",
                                  "share of near-axis samples through the ball: (1-F)/(1+F)")

    def run(threads, seed):
        scn = ball_scene(inner_radius)
        result = render(scn, threads, seed)
        mean, se = image_mean(result)
        return Outcome(mean, se=se, nan_count=result.nan_count, image=result.mean(),
                       error_map=z_map(result, expected), error_label=Z_LABEL,
                       settings=settings_of(scn))
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
        return furnace_outcome(render(scn, threads, seed), scn)
    return Case("two coplanar emissive faces", "nested and coincident",
                "mean of all samples (each exactly 1: one face is hit, never both or neither)",
                "rays pass between or through coincident faces, or add both", EXACT, 1.0, run, True)


# addon/export/depsgraph.py's warning for such a mesh, word for word:
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
# Degenerate geometry


def _camera_in_glass_case(quick):
    def run(threads, seed):
        pos, tri, nrm = icosphere(4, radius=1.0)
        cam = camera(position=(0, 0, 0), resolution=(32, 32), lens=20.0)
        scn = scene([(pos, tri, 0, nrm)], [material("glass", SLAB_IOR)], cam, world=WHITE,
                    spp=16, max_depth=1000)
        return furnace_outcome(render(scn, threads, seed), scn)
    return Case("camera inside a glass ball (at its centre)", "degenerate geometry",
                "mean of all samples in a white furnace (each exactly 1)",
                "rays that start inside glass are refracted the wrong way or lost", EXACT, 1.0, run,
                quick)


def _unwelded_cube_case(quick):
    def run(threads, seed):
        pos, tri = box((-1, -1, -1), (1, 1, 1))
        pos, tri = pos[tri].reshape(-1, 3), np.arange(3 * len(tri), dtype=np.int32).reshape(-1, 3)
        scn = scene([(pos, tri, 0)], [material("glass", SLAB_IOR)],
                    camera(position=(0.3, 0.2, 4), resolution=(32, 32)), world=WHITE, spp=16,
                    max_depth=1000)
        return furnace_outcome(render(scn, threads, seed), scn)
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
