"""The wavefront's stages, one compiled kernel each, in the order a bounce runs them.

pbrt-v4's wavefront integrator is the model: `generate` makes camera rays, Embree intersects
every live ray in one call, `emitters` adds the light of lamps, the world and emissive surfaces
and keeps the paths that go on, `materials` samples each kept hit (light samples queue shadow
rays; the BSDF sample, after Russian roulette, becomes the next ray), Embree traces every shadow
ray of the bounce in one call, and `shadow_rays` adds the light of those that arrive. `film`
adds a finished chunk's paths to the image. Paths live in `Paths`, a structure of arrays that
each chunk reuses from bounce to bounce: no allocation in the hot loop.

Max depth m is the seed's max_ray_depth: emission plus up to m bounces (Cycles' max_bounces =
m - 1). A path's random numbers are keyed by its pixel, sample index and a dimension: 0 pixel
position, 1 lens position, and per bounce k the pairs 2 + 3k (light choice, roulette),
3 + 3k (point on the light) and 4 + 3k (BSDF).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from . import bsdf
from .bsdf import DIFFUSE, EMISSION, REFRACTION, power_heuristic
from .camera import camera_ray
from .geometry import FAR, hit_point, offset_origin
from .jit import jit
from .lights import intersect_area_lamp, pdf_area, pdf_triangle, pdf_world, sample_light
from .sampler import pixel_key, sample_pair
from .vec import dot, max3, mul, neg, row, store, sub

STRATIFIED_BOUNCES = 2    # bounces whose light and BSDF samples are stratified (then random)
RR_START = 3              # Russian roulette from this bounce on ...
RR_THRESHOLD = 0.1        # ... for paths whose throughput has fallen below this
# Event counters (RenderResult.stats), by index.
STATS = ("tir", "tir_absorbed", "rejected", "transmissions", "reflections", "diffuse",
         "rr_killed", "depth_limited")
(TIR_COUNT, TIR_ABSORBED_COUNT, REJECTED, TRANSMISSIONS, REFLECTIONS, DIFFUSE_HITS, RR_KILLED,
 DEPTH_LIMITED) = range(len(STATS))
FAR32 = np.float32(FAR)


class Paths(NamedTuple):
    """The state of up to n paths (row i = path i of the current wavefront)."""
    path: np.ndarray         # (n,) int64: the path's row in the chunk's radiance
    key: np.ndarray          # (n,) uint64: its pixel's sampler key
    sample: np.ndarray       # (n,) int64: its sample index in the pixel
    o: np.ndarray            # (n, 3) float64 ray origin
    d: np.ndarray            # (n, 3) float64 unit ray direction
    o32: np.ndarray          # (n, 3) float32 copies for Embree
    d32: np.ndarray          # (n, 3)
    tmax: np.ndarray         # (n,) float32: in, the ray's length; out (Embree), the hit distance
    beta: np.ndarray         # (n, 3) throughput
    specular: np.ndarray     # (n,) bool: the ray left a specular vertex (or the camera)
    pdf_prev: np.ndarray     # (n,) solid-angle density of the BSDF sample that made the ray


class Shadows(NamedTuple):
    """The shadow rays of one bounce."""
    path: np.ndarray         # (n,) int64
    o32: np.ndarray          # (n, 3) float32
    d32: np.ndarray          # (n, 3) float32
    tmax: np.ndarray         # (n,) float32 segment length
    contrib: np.ndarray      # (n, 3) radiance the path gets if the segment is free


class Materials(NamedTuple):
    """Per-material tables."""
    kind: np.ndarray         # (M,) int64 kind codes (bsdf.DIFFUSE, ...)
    color: np.ndarray        # (M, 3)
    trans_color: np.ndarray  # (M, 3) refraction weight of glass
    ior: np.ndarray          # (M,)
    radiance: np.ndarray     # (M, 3) emission (colour x strength)
    of_triangle: np.ndarray  # (T,) int64 material of each triangle


def new_paths(n: int) -> Paths:
    """Uninitialised path buffers for n paths."""
    return Paths(np.empty(n, np.int64), np.empty(n, np.uint64), np.empty(n, np.int64),
                 np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3), np.float32),
                 np.empty((n, 3), np.float32), np.empty(n, np.float32), np.empty((n, 3)),
                 np.empty(n, np.bool_), np.empty(n))


def new_shadows(n: int) -> Shadows:
    """Uninitialised shadow-ray buffers for n rays."""
    return Shadows(np.empty(n, np.int64), np.empty((n, 3), np.float32),
                   np.empty((n, 3), np.float32), np.empty(n, np.float32), np.empty((n, 3)))


@jit
def set_ray(paths, i, o, d, tmax):
    """Write ray i (float64, and the float32 copies Embree reads)."""
    store(paths.o, i, o)
    store(paths.d, i, d)
    for k in range(3):
        paths.o32[i, k] = o[k]
        paths.d32[i, k] = d[k]
    paths.tmax[i] = tmax


@jit
def mis_weight(next_event, specular, pdf_bsdf, pdf_light):
    """Weight of light found by BSDF sampling: 1 after specular bounces (no light sample could
    have found it) or without light sampling, else the power heuristic."""
    if specular or not next_event:
        return 1.0
    return power_heuristic(pdf_bsdf, pdf_light)


@jit
def add_light(radiance, path, beta, light, w):
    """radiance[path] += beta * light * w."""
    for k in range(3):
        radiance[path, k] += beta[k] * light[k] * w


@jit
def generate(cam, seed, start, in_pass, first_sample, bits, stratified, n, paths):
    """Camera rays for the chunk's paths start .. start + n of a pass of in_pass samples per
    pixel (pixel = path // in_pass, sample = first_sample + path % in_pass)."""
    for i in range(n):
        g = start + i
        pixel = g // in_pass
        sample = first_sample + g - pixel * in_pass
        key = pixel_key(pixel, seed)
        u0, u1 = sample_pair(key, sample, 0, bits, stratified)
        l0, l1 = 0.0, 0.0
        if cam.lens_radius > 0.0:
            l0, l1 = sample_pair(key, sample, 1, bits, stratified)
        o, d, far = camera_ray(cam, pixel, u0, u1, l0, l1)
        set_ray(paths, i, o, d, far)
        paths.path[i] = i
        paths.key[i] = key
        paths.sample[i] = sample
        for k in range(3):
            paths.beta[i, k] = 1.0
        paths.specular[i] = True     # what the camera sees directly gets no MIS weight
        paths.pdf_prev[i] = 0.0


@jit
def emitters(lights, mats, next_event, depth, max_depth, m, paths, prim, t, radiance,
             active, stats):
    """Lamps, the world and emissive triangles add their light; returns how many paths go on to
    scatter (their rows in `active`).

    Lamps have no surface, as in Cycles: a ray adds the light of every lamp it crosses before its
    hit (or escape) and goes on as if the lamp were not there. Camera rays skip lamps that are
    invisible to the camera.
    """
    kept = 0
    for i in range(m):
        o, d = row(paths.o, i), row(paths.d, i)
        beta, path, specular = row(paths.beta, i), paths.path[i], paths.specular[i]
        t_surface = np.float64(t[i])     # Embree leaves a miss's t at the ray's length
        for lamp in range(lights.area_area.shape[0]):
            if depth == 0 and not lights.area_visible_camera[lamp]:
                continue
            t_lamp = intersect_area_lamp(lights, lamp, o, d)
            if 0.0 < t_lamp < t_surface:
                w = mis_weight(next_event, specular, paths.pdf_prev[i],
                               pdf_area(lights, lamp, d, t_lamp))
                add_light(radiance, path, beta, row(lights.area_radiance, lamp), w)
        if prim[i] < 0:
            if lights.world[0] > 0.0 or lights.world[1] > 0.0 or lights.world[2] > 0.0:
                w = mis_weight(next_event, specular, paths.pdf_prev[i], pdf_world(lights))
                add_light(radiance, path, beta, lights.world, w)
            continue
        mat = mats.of_triangle[prim[i]]
        if mats.kind[mat] == EMISSION:
            w = 1.0
            if next_event and not specular:
                w = power_heuristic(paths.pdf_prev[i], pdf_triangle(lights, prim[i], o, d, t_surface))
            add_light(radiance, path, beta, row(mats.radiance, mat), w)
            continue
        if depth == max_depth:
            stats[DEPTH_LIMITED] += 1     # the depth limit, not the scene, ends this path
            continue
        active[kept] = i
        kept += 1
    return kept


@jit
def materials(lights, mesh, mats, fresnel_model, next_event, bits, stratified, depth,
              n_active, active, paths, prim, u, v, out, shadows, stats):
    """Sample every kept hit: a light sample at diffuse vertices (queued as a shadow ray), then
    the BSDF; after Russian roulette the surviving paths' next rays go into `out`.

    Returns (paths in out, shadow rays queued).
    """
    n_out = 0
    n_shadow = 0
    has_normals = mesh.corner_normals.shape[0] > 0
    can_sample_lights = next_event and lights.cdf.shape[0] > 0 and lights.cdf[-1] > 0.0
    strat = stratified and depth < STRATIFIED_BOUNCES
    for j in range(n_active):
        i = active[j]
        tri = prim[i]
        p, ng, ns, eps = hit_point(mesh, tri, np.float64(u[i]), np.float64(v[i]))
        d = row(paths.d, i)
        # Face the normals towards the incoming ray (two-sided surfaces, inside of glass).
        entering = dot(d, ng) < 0.0
        side = 1.0 if entering else -1.0
        ng_f, ns_f = mul(ng, side), mul(ns, side)
        mat = mats.of_triangle[tri]
        kind = mats.kind[mat]
        key, sample = paths.key[i], paths.sample[i]
        u_pick, u_roulette = sample_pair(key, sample, 2 + 3 * depth, bits, strat)
        u0, u1 = sample_pair(key, sample, 4 + 3 * depth, bits, strat)
        beta = row(paths.beta, i)
        if kind == DIFFUSE:
            stats[DIFFUSE_HITS] += 1
            albedo = row(mats.color, mat)
            if can_sample_lights:
                l0, l1 = sample_pair(key, sample, 3 + 3 * depth, bits, strat)
                wi, target, infinite, weight, pdf_light = sample_light(lights, mesh, p, u_pick, l0, l1)
                cos = dot(wi, ns_f)
                if cos > 0.0 and dot(wi, ng_f) > 0.0 and max3(weight) > 0.0:
                    w = power_heuristic(pdf_light, cos / math.pi) if pdf_light > 0.0 else 1.0
                    f = cos / math.pi * w
                    for k in range(3):
                        shadows.contrib[n_shadow, k] = beta[k] * albedo[k] * weight[k] * f
                    queue_shadow(shadows, n_shadow, paths.path[i], offset_origin(p, ng_f, eps, wi),
                                 wi, target, infinite)
                    n_shadow += 1
            wi, pdf = bsdf.sample_cosine_hemisphere(ns_f, u0, u1)
            # Shading normals can point a sample into the surface: it carries nothing.
            beta = (0.0, 0.0, 0.0) if dot(wi, ng_f) <= 0.0 else \
                (beta[0] * albedo[0], beta[1] * albedo[1], beta[2] * albedo[2])
            new_d, specular, pdf_prev = wi, False, pdf
        else:
            n = ns_f
            if has_normals and kind != REFRACTION:
                n = bsdf.valid_reflection_normal(ng_f, neg(d), ns_f)
            new_d, weight, event, valid = bsdf.sample_specular(
                kind, d, ng_f, n, entering, row(mats.color, mat),
                row(mats.trans_color, mat), mats.ior[mat], fresnel_model, u0)
            count_specular(stats, event, valid)
            beta = (beta[0] * weight[0], beta[1] * weight[1], beta[2] * weight[2]) if valid \
                else (0.0, 0.0, 0.0)
            specular, pdf_prev = True, 0.0
        peak = max3(beta)
        if not peak > 0.0:
            continue
        if depth + 1 >= RR_START:
            # Survival probability throughput / 0.1: in a closed room a path's remaining light
            # is large, and killing paths at throughput 0.5 (q = throughput) cost more
            # variance than it saved time (measured: 1.5x worse relMSE x time).
            q = min(peak / RR_THRESHOLD, 1.0)
            if u_roulette >= q:
                stats[RR_KILLED] += 1
                continue
            beta = mul(beta, 1.0 / q)
        set_ray(out, n_out, offset_origin(p, ng, eps, new_d), new_d, FAR32)
        store(out.beta, n_out, beta)
        out.path[n_out] = paths.path[i]
        out.key[n_out] = key
        out.sample[n_out] = sample
        out.specular[n_out] = specular
        out.pdf_prev[n_out] = pdf_prev
        n_out += 1
    return n_out, n_shadow


@jit
def queue_shadow(shadows, j, path, origin, wi, target, infinite):
    """Shadow ray j from origin towards the light point target (or along wi to infinity)."""
    direction, length = wi, FAR
    if not infinite:
        segment = sub(target, origin)
        length = math.sqrt(dot(segment, segment))
        if length > 0.0:
            direction = mul(segment, 1.0 / length)
    shadows.path[j] = path
    for k in range(3):
        shadows.o32[j, k] = origin[k]
        shadows.d32[j, k] = direction[k]
    shadows.tmax[j] = length


@jit
def count_specular(stats, event, valid):
    """Count what a specular vertex did."""
    if event == bsdf.TIR:
        stats[TIR_COUNT] += 1
    elif event == bsdf.TIR_ABSORBED:
        stats[TIR_ABSORBED_COUNT] += 1
        return
    elif event == bsdf.TRANSMITTED:
        stats[TRANSMISSIONS] += 1
    else:
        stats[REFLECTIONS] += 1
    if not valid:
        stats[REJECTED] += 1


@jit
def shadow_rays(n, blocked, shadows, radiance):
    """Add the light of every shadow ray that nothing blocked (Embree: 0 where blocked)."""
    for j in range(n):
        if blocked[j] != 0:
            for k in range(3):
                radiance[shadows.path[j], k] += shadows.contrib[j, k]


@jit
def film(radiance, n, start, in_pass, total, total_sq):
    """Add the chunk's n path radiances to their pixels' sums and sums of squares (rows of
    (pixels, 3)); non-finite samples count as 0. Returns how many there were."""
    bad = 0
    for i in range(n):
        if not (math.isfinite(radiance[i, 0]) and math.isfinite(radiance[i, 1])
                and math.isfinite(radiance[i, 2])):
            bad += 1
            continue
        pixel = (start + i) // in_pass
        for k in range(3):
            value = radiance[i, k]
            total[pixel, k] += value
            total_sq[pixel, k] += value * value
    return bad


@jit
def clear(radiance, n):
    """Zero the first n rows."""
    for i in range(n):
        for k in range(3):
            radiance[i, k] = 0.0
