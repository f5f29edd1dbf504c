"""The wavefront's stages, one compiled kernel each, in the order a bounce runs them.

pbrt-v4's wavefront integrator is the model: `generate` makes camera rays, Embree intersects
every live ray in one call, `emitters` adds the light of lamps, the world and emissive surfaces
and keeps the paths that go on, `materials` samples each kept hit (light samples queue shadow
rays; the BSDF sample, after Russian roulette, becomes the next ray), Embree traces every shadow
ray of the bounce in one call, and `shadow_rays` adds the light of those that arrive. `film`
adds a finished chunk's paths to the image. Paths live in `Paths`, a structure of arrays that
each chunk reuses from bounce to bounce: no allocation in the hot loop.

What a render does not make, the light passes (pass_sums) and the denoising features
(feature_albedo, feature_normal), is passed as None. Numba compiles a stage for the types of its
arguments and leaves out a branch on an argument that is None, so the stages of a render without
them hold none of their code: their code alone, never run, made the materials stage about 6%
slower on cornell_spheres (docs/measurements.md).

Max depth m is the seed's max_ray_depth: emission plus up to m bounces (Cycles' max_bounces =
m - 1). A path's random numbers are keyed by its pixel, sample index and a dimension: 0 pixel
position, 1 lens position, and per bounce k the pairs 2 + 3k (light choice, roulette),
3 + 3k (point on the light) and 4 + 3k (BSDF).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .adaptive import is_class_a
from .camera import camera_ray
# STATS, CAUSTIC_SPLATS, CONNECTIONS and VERTEX_RAYS are also read through this module.
from .counters import (CAUSTIC_SPLATS, CONNECTIONS, DEPTH_LIMITED, FRESNEL_SPLITS,  # noqa: F401
                       LENS_SAMPLES, RR_KILLED, STATS, VERTEX_RAYS)
from .direct_light import add_light
from .features import add_feature_light, record_features, smooth_lobes
from .geometry import FAR, facing, hit_point, offset_origin
from .jit import jit, jit_inline
from .light_groups import add_grouped, add_to_group, escape_group, lamp_group
from .light_tracer import NO_CAUSTIC, caustic_after, left_to_light_paths
from .light_passes import (ONE, ZERO, add_colors, add_found, add_shadow, pass_weights,
                           shadow_weights)
from .lights.codes import VISIBLE_CAMERA, VISIBLE_DIFFUSE, VISIBLE_GLOSSY, VISIBLE_TRANSMISSION
from .lights.dispatch import (crosses_a_lamp, lamp_crossed, lamps_to_cross, light_at_escape,
                              lights_at_escape, triangle_hit)
from .material_kinds import DIFFUSE, EMISSION, GLASS, LAYERED, PROGRAM
from .media import empty_stacks
from .mnee import NO_CHAIN, escape_left_to_mnee, left_to_mnee, mnee_after, reflected
from . import media as medium
from .path_limits import (DIFFUSE_BOUNCE, NO_BOUNCES, add_bounce, bounce_kind, clamp_light,
                          clamp_limit, dropped_at, kind_count, past_last_bounce)
from .pixel_filter import position as filter_position
from .sampler import pixel_key, sample_pair
from .sampling import power_heuristic3
from .scatter import glass_mirror, scatter_lit, scatter_program, scatter_specular
from .shader.closures import TOTAL_EMISSION, TOTAL_HOLDOUT, TOTAL_TRANSPARENCY
from .shader.inputs import LP_SHADOW, ray_flags
from .shader.program import (EMISSION_VARIES, HAS_HOLDOUT, MAX_REGISTERS, MAY_BE_TRANSPARENT,
                             run, total)
from .textures import surface_colors
from .vec import dot, finite_row, madd, max3, mean3, mul, neg, row, store, vmul

STRATIFIED_BOUNCES = 2    # bounces whose light and BSDF samples are stratified (then random)
RR_START = 3              # Russian roulette from this bounce on ...
RR_THRESHOLD = 0.1        # ... for paths whose throughput has fallen below this
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
    ray_kind: np.ndarray     # (n,) int64: the VISIBLE_* flag (lights.codes) of the event that
    #                          made the ray
    pdf_prev: np.ndarray     # (n,) solid-angle density of the BSDF sample that made the ray, 0
    #                          after the camera and specular bounces (no light sample competes)
    caustic: np.ndarray      # (n,) int64: NO_CAUSTIC, or FIRST_DIFFUSE (the camera's first hit was
    #                          diffuse) then CAUSTIC (and every vertex since specular): the light
    #                          tracer's paths, whose emitters the path tracer then skips
    connect: np.ndarray      # (n,) after a diffuse vertex y1 that a light vertex could stand in
    #                          for: cos_g(y1, ray) / the density of the camera's step to y1 (the
    #                          light vertex's MIS density per unit of light_vertex_density), else 0
    feature: np.ndarray      # (n, 3) the denoising features' weight (features.py), when a render
    #                          makes the Denoising Albedo and Normal passes
    feature_on: np.ndarray   # (n,) int64: 1 while the path has not written its features
    mis_t: np.ndarray        # (n,) how far the ray went, unbent, before its origin since the
    #                          vertex that sampled it: 0 but through transparent surfaces
    #                          (scatter_program), whose far side lights then weigh by the
    #                          densities of that vertex
    medium: np.ndarray       # (n, media.MAX_MEDIA) int64: the media the ray is inside
    #                          (media.py), read and written only in scenes with media
    bounce: np.ndarray       # (n,) int64: the path's bounces so far, Cycles' `bounce`: a pass
    #                          through a transparent surface is none (the wavefront's depth
    #                          minus this is the path's transparent bounces)
    pass_diffuse: np.ndarray  # (n, 3) the light passes' diffuse and glossy weights, set at the
    pass_glossy: np.ndarray   # (n, 3) first bounce (light_passes.py), when a render makes them
    kinds: np.ndarray         # (n,) int64: its diffuse, glossy and transmission bounces,
    #                           packed (path_limits.kind_count)
    see_through: np.ndarray   # (n,) int64: 1 while the path has only passed transparent surfaces
    #                           (and, with Transparent Glass, clear glass: go_on), Cycles'
    #                           PATH_RAY_TRANSPARENT_BACKGROUND
    mnee: np.ndarray          # (n,) int64: mnee.NO_CHAIN, or FROM_RECEIVER + the refractions at
    #                           shadow-caustics casters since the last receiver (mnee_after)
    light_scale: np.ndarray   # (n,) the share of the light of lamps, suns and emissive surfaces
    #                           at the ray's hit the path counts: 1, or glass's F where the
    #                           Fresnel split shares it (split_fresnel)
    world_scale: np.ndarray   # (n,) the share of the world's light it counts: 1, or 0 for the
    #                           split's mirror rays (the world's light is not split)


class Shadows(NamedTuple):
    """The shadow rays of one bounce."""
    path: np.ndarray         # (n,) int64
    o32: np.ndarray          # (n, 3) float32
    d32: np.ndarray          # (n, 3) float32
    tmax: np.ndarray         # (n,) float32 segment length
    contrib: np.ndarray      # (n, 3) radiance the path gets if the segment is free
    without: np.ndarray      # (n, 3) the same without light vertices (a pilot's, see emitters)
    bounce: np.ndarray       # (n,) int64: the bounces of the path that cast it (Paths.bounce)
    pass_diffuse: np.ndarray  # (n, 3) its light's diffuse and glossy pass weights, and whether
    pass_glossy: np.ndarray   # (n, 3) it is Direct light (1: a light sample of the first hit),
    pass_direct: np.ndarray   # (n,) int64 when a render makes the light passes (light_passes.py)
    group: np.ndarray        # (n,) int64: its light's light group (light_groups.py; -1 none)


def new_paths(n: int) -> Paths:
    """Uninitialised path buffers for n paths."""
    return Paths(np.empty(n, np.int64), np.empty(n, np.uint64), np.empty(n, np.int64),
                 np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3), np.float32),
                 np.empty((n, 3), np.float32), np.empty(n, np.float32), np.empty((n, 3)),
                 np.empty(n, np.int64), np.empty(n), np.empty(n, np.int64), np.empty(n),
                 np.empty((n, 3)), np.zeros(n, np.int64), np.zeros(n), empty_stacks(n),
                 np.zeros(n, np.int64), np.zeros((n, 3)), np.zeros((n, 3)),
                 np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n, np.int64),
                 np.ones(n), np.ones(n))


def new_shadows(n: int) -> Shadows:
    """Uninitialised shadow-ray buffers for n rays."""
    return Shadows(np.empty(n, np.int64), np.empty((n, 3), np.float32),
                   np.empty((n, 3), np.float32), np.empty(n, np.float32), np.empty((n, 3)),
                   np.empty((n, 3)), np.zeros(n, np.int64), np.zeros((n, 3)), np.zeros((n, 3)),
                   np.zeros(n, np.int64), np.full(n, -1, np.int64))


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
def mis_weight(next_event, pdf_bsdf, pdf_light, pdf_vertex):
    """Weight of light found by BSDF sampling: 1 after the camera and specular bounces (pdf_bsdf
    0: no light sample could have found it) or without light sampling, else the power
    heuristic against light sampling and the light vertex (light_vertices.py)."""
    if pdf_bsdf == 0.0 or not next_event:
        return 1.0
    return power_heuristic3(pdf_bsdf, pdf_light, pdf_vertex)


@jit
def generate(cam, filt, seed, start, in_pass, first_sample, pixels, bits, stratified, n, paths,
             stats, features):
    """Camera rays for the chunk's paths start .. start + n of a pass of in_pass samples per
    pixel (pixel = pixel_of(path // in_pass), sample = first_sample + path % in_pass), through
    positions in the pixel drawn from the pixel filter filt (pixel_filter.py); with `features`,
    each path carries the denoising features from weight 1."""
    for i in range(n):
        g = start + i
        row = g // in_pass
        pixel = pixel_of(pixels, row)
        sample = first_sample + g - row * in_pass
        key = pixel_key(pixel, seed)
        u0, u1 = sample_pair(key, sample, 0, bits, stratified)
        u0, u1 = filter_position(filt, u0), filter_position(filt, u1)
        l0, l1 = 0.0, 0.0
        if cam.lens_radius > 0.0:
            l0, l1 = sample_pair(key, sample, 1, bits, stratified)
            stats[LENS_SAMPLES] += 1
        o, d, far = camera_ray(cam, pixel, u0, u1, l0, l1)
        set_ray(paths, i, o, d, far)
        paths.path[i] = i
        paths.key[i] = key
        paths.sample[i] = sample
        for k in range(3):
            paths.beta[i, k] = 1.0
        paths.ray_kind[i] = VISIBLE_CAMERA
        paths.pdf_prev[i] = 0.0      # what the camera sees directly gets no MIS weight
        paths.caustic[i] = NO_CAUSTIC
        paths.connect[i] = 0.0
        paths.mis_t[i] = 0.0
        paths.bounce[i] = 0
        paths.kinds[i] = NO_BOUNCES
        paths.see_through[i] = 1
        paths.mnee[i] = NO_CHAIN
        paths.light_scale[i] = 1.0
        paths.world_scale[i] = 1.0
        if features:
            for k in range(3):
                paths.feature[i, k] = 1.0
            paths.feature_on[i] = 1


@jit
def emitters(lights, mats, media, next_event, caustics, world_caustics, depth, limits, clamp,
             m, paths, prim, t, radiance, without, active, stats, feature_albedo,
             film_transparent, transparent, pass_sums, mnee_lamps):
    """Lamps, the world, suns and emissive triangles add their light; returns how many paths go
    on to scatter (their rows in `active`).

    `without` (when it has rows) gets the light the same paths would carry without light
    vertices: the path tracer's samples are the same, only the MIS weights of light that a light
    vertex could have found change. A pilot compares the two (pilot.py).

    Lamps have no surface, as in Cycles: a ray adds the light of every lamp it crosses before its
    hit (or escape) and goes on as if the lamp were not there. What a ray gets from each kind of
    light is lights.dispatch's (lamp_crossed, light_at_escape, triangle_hit); the MIS weights
    are this stage's. With `caustics` (light_tracer.SPLIT_*: the light tracer runs), paths in
    the CAUSTIC state (and SDS_CAUSTIC with photon merging: light_tracer.left_to_light_paths)
    get no light from lamps, emissive triangles or suns, and with `world_caustics` (it starts
    paths on the world) none from the world: those paths are the light tracer's to count.
    Paths that refracted at shadow-caustics casters since a receiver get no light from the
    lamps and suns in `mnee_lamps` (mnee.left_to_mnee; empty: none): manifold next-event
    estimation counts those.
    limits (path_limits.bounce_limits): a path ends at a surface after its last bounce (of
    all, or of one kind), or after as many transparent surfaces as the second allows, as in
    Cycles (path_state_next): what it ends on still adds its light, and after the last bounce a
    path still passes through transparent surfaces (program_materials), since shadow rays do.
    What a path finds is clamped by `clamp` (path_limits.clamp_limits) as Cycles' film.
    When the render makes the denoising features (feature_albedo is not None), paths that
    still carry them add what they find to the Denoising Albedo too, as Cycles does
    (features.add_feature_light; a CAUSTIC path has written its features at its first, diffuse,
    hit).
    With `film_transparent` (Film > Transparent), a camera ray that escapes having passed only
    transparent surfaces (and clear glass with Transparent Glass: Paths.see_through, Cycles'
    PATH_RAY_TRANSPARENT_BACKGROUND) sees no world and adds its mean throughput to
    `transparent` (the path's uncovered share, 1 - alpha), as Cycles' integrate_background;
    suns still shine, as Cycles' distant lights do.
    Shader programs whose emission varies add it in program_emitters. In a scene with media
    (media.py), the ray's segment inside them attenuates what it finds and the path's
    throughput from here on. When pass_sums is not None (the render makes the light passes),
    each light found is also added to the path's row of them (light_passes.add_found); with
    Film > Transparent the world a camera ray sees still goes to Environment, as in Cycles'
    integrate_background. Each light found goes to its light's group too (light_groups.py).
    """
    kept = 0
    light_passes = pass_sums is not None
    for i in range(m):
        o, d = row(paths.o, i), row(paths.d, i)
        beta, path, kind = row(paths.beta, i), paths.path[i], paths.ray_kind[i]
        pdf_prev, connect, mis_t = paths.pdf_prev[i], paths.connect[i], paths.mis_t[i]
        t_surface = np.float64(t[i])     # Embree leaves a miss's t at the ray's length
        sigma = medium.sigma_of(media, paths.medium, i) if media.on else medium.ZERO
        light_tracers = left_to_light_paths(caustics, paths.caustic[i])
        emitters_count = not light_tracers
        if emitters_count:
            crossed_lamps(lights, media, next_event, clamp, paths, i, t_surface, sigma, radiance,
                          without, feature_albedo, pass_sums, mnee_lamps)
        if media.on and medium.absorbs(sigma):
            beta = medium.through(beta, sigma, t_surface)
            store(paths.beta, i, beta)
        scale, world_scale = paths.light_scale[i], paths.world_scale[i]
        if prim[i] < 0:
            clear_film = film_transparent and paths.see_through[i] != 0
            if clear_film:
                transparent[path] += world_scale * mean3(beta)
                if light_passes and lights.has_world:
                    found, light, _ = light_at_escape(lights, 0, d, kind)
                    if found:
                        seen = mul(clamp_light(vmul(beta, light), clamp[0]), world_scale)
                        add_found(pass_sums, paths, i, ONE, seen, 1.0, True)
                        # Cycles evaluates it for the Environment pass and writes it to the
                        # world's light group too (film_write_background).
                        add_to_group(radiance, path, lights.world_group, seen)
            first, end = lights_at_escape(lights, not (light_tracers and world_caustics
                                                       or clear_film), emitters_count)
            for k in range(first, end):
                if escape_left_to_mnee(lights, mnee_lamps, paths.mnee[i], k):
                    continue
                found, light, pdf_light = light_at_escape(lights, k, d, kind)
                world = lights.has_world and k == 0
                if found and (world_scale > 0.0 or not world):
                    w = mis_weight(next_event, pdf_prev, pdf_light, 0.0)
                    add_found_light(radiance, without, paths, i, beta, light, w, w,
                                    feature_albedo, pass_sums, world, clamp,
                                    escape_group(lights, k), world_scale if world else scale)
            continue
        mat = mats.of_triangle[prim[i]]
        emission = row(mats.radiance, mat)
        if emitters_count and max3(emission) > 0.0:     # Emission, or a Principled BSDF's
            pdf_light, pdf_vertex = triangle_hit(lights, prim[i], madd(o, -mis_t, d), d,
                                                 t_surface + mis_t, connect)
            add_found_light(radiance, without, paths, i, beta, emission,
                            mis_weight(next_event, pdf_prev, pdf_light, pdf_vertex),
                            mis_weight(next_event, pdf_prev, pdf_light, 0.0), feature_albedo,
                            pass_sums, False, clamp, lights.prim_group[prim[i]], scale)
        if mats.kind[mat] == EMISSION:
            continue
        if ended(mats, mat, depth, paths, i, limits):
            stats[DEPTH_LIMITED] += 1     # the depth limit, not the scene, ends this path
            continue
        active[kept] = i
        kept += 1
    return kept


@jit_inline
def crossed_lamps(lights, media, next_event, clamp, paths, i, t_surface, sigma, radiance, without,
                  feature_albedo, pass_sums, mnee_lamps):
    """The lamps path i's ray crosses before t_surface add their light (those left to manifold
    next-event estimation aside), attenuated by the medium it is in (sigma)."""
    o, d = row(paths.o, i), row(paths.d, i)
    beta, kind = row(paths.beta, i), paths.ray_kind[i]
    pdf_prev, connect, mis_t = paths.pdf_prev[i], paths.connect[i], paths.mis_t[i]
    for lamp in range(lamps_to_cross(lights)):
        if left_to_mnee(mnee_lamps, paths.mnee[i], lamp):
            continue
        crossed, light, pdf_light, pdf_vertex = lamp_crossed(lights, lamp, o, d, t_surface,
                                                             kind, pdf_prev, connect, mis_t)
        if crossed:
            if media.on:
                light = medium.through(light, sigma, medium.lamp_distance(lights, lamp, o, d))
            add_found_light(radiance, without, paths, i, beta, light,
                            mis_weight(next_event, pdf_prev, pdf_light, pdf_vertex),
                            mis_weight(next_event, pdf_prev, pdf_light, 0.0), feature_albedo,
                            pass_sums, False, clamp, lamp_group(lights, lamp),
                            paths.light_scale[i])


@jit_inline
def add_found_light(radiance, without, paths, i, beta, light, w, w_without, feature_albedo,
                    pass_sums, environment, clamp, group, scale):
    """Light path i finds, throughput beta, clamped (path_limits) and then weighed by `scale`
    (its light_scale or world_scale: split_fresnel): to its radiance at MIS weight w (and to
    its light group's columns: light_groups.py) and to its radiance without light vertices at
    w_without, to the Denoising Albedo while the path carries the features, and to the light
    passes when the render makes them (environment: the world's)."""
    # Cycles' film_clamp_light(bounce - 1): direct up to the first bounce's ray.
    limit = clamp_limit(clamp, paths.bounce[i] <= 1)
    found = vmul(beta, light)
    # The clamp applies to the sample the path would carry alone, as Cycles clamps it.
    contribution = mul(clamp_light(mul(found, w), limit), scale)
    add_grouped(radiance, paths.path[i], group, contribution)
    if without.shape[0] > 0:
        add_light(without, paths.path[i], mul(clamp_light(mul(found, w_without), limit), scale))
    if feature_albedo is not None and paths.feature_on[i] != 0:
        add_feature_light(feature_albedo, paths, i, beta, light, w_without * scale)
    if pass_sums is not None:
        add_found(pass_sums, paths, i, ONE, contribution, 1.0, environment)


@jit_inline
def carry_pass_weights(out, n_out, kept, weights):
    """Give the next ray go_on queued (row n_out of out, if kept > n_out) the light passes'
    (diffuse, glossy) weights."""
    if kept > n_out:
        store(out.pass_diffuse, n_out, weights[0])
        store(out.pass_glossy, n_out, weights[1])


@jit_inline
def ended(mats, mat, depth, paths, i, limits):
    """Whether path i, at wavefront depth `depth`, ends at a surface of material mat
    (emitters' limits)."""
    bounce = paths.bounce[i]
    crossed = depth - bounce
    if crossed > 0 and crossed >= limits[1]:
        return True     # Cycles' PATH_RAY_TERMINATE_ON_NEXT_SURFACE
    # After the last bounce only a transparent surface lets the path go on (Cycles'
    # PATH_RAY_TERMINATE_AFTER_TRANSPARENT).
    return past_last_bounce(bounce, paths.kinds[i], limits) and not (
        mats.kind[mat] == PROGRAM and mats.programs.flags[mat] & MAY_BE_TRANSPARENT)


@jit
def program_emitters(lights, mesh, mats, tables, caustics, depth, m, paths, prim, u, v, t,
                     radiance, without, feature_albedo, lobes, regs, pass_sums, clamp):
    """The emission of the shader programs whose emission varies over the surface or with
    the ray (shader/program.py; `lobes` and `regs` their scratch), each run at the hit of
    every path of the m: no light sample finds such emission, so it weighs 1 (a path the
    light tracer counts, as in emitters, gets none; negative emission is added as Cycles adds
    it)."""
    has_normals = mesh.corner_normals.shape[0] > 0
    for i in range(m):
        tri = prim[i]
        if tri < 0:
            continue
        mat = mats.of_triangle[tri]
        if mats.kind[mat] != PROGRAM or not mats.programs.flags[mat] & EMISSION_VARIES \
                or left_to_light_paths(caustics, paths.caustic[i]):
            continue
        b1, b2 = np.float64(u[i]), np.float64(v[i])
        p, _, ng_f, ns_f, _, entering, d = facing_hit(mesh, paths, i, tri, b1, b2)
        hit = (p, ng_f, ns_f, neg(d), entering, tri, b1, b2,
               ray_flags(paths.ray_kind[i], paths.pdf_prev[i]), paths.bounce[i],
               np.float64(t[i]))
        run(mats, mat, regs, hit, lobes, tables, has_normals)
        emission = total(regs, TOTAL_EMISSION)
        beta = row(paths.beta, i)
        add_found_light(radiance, without, paths, i, beta, emission, 1.0, 1.0, feature_albedo,
                        pass_sums, False, clamp, lights.prim_group[tri], paths.light_scale[i])


@jit
def materials(lights, mesh, mats, media, tables, fresnel_model, next_event, bits, stratified,
              depth, limits, clamp, clear, n_active, active, paths, prim, u, v, out, shadows,
              radiance, without, lobes, params, stats, lv, last_connection, feature_albedo,
              feature_normal, programs, pass_sums, mnee_flags, split):
    """Scatter each kept hit (rows `active`) by its surface kind (scatter.py): diffuse and
    layered vertices sample a light (a shadow ray, or direct light for lamps that cast no
    shadow) and, up to bounce last_connection (-1: never), connect to the path's light vertex
    in `lv` (light_vertices.py; another shadow ray); every kind samples its BSDF. After Russian
    roulette the surviving paths' next rays go into `out`. `lobes` is scratch for a layered
    hit's lobes (lobes.py), `tables` its albedo tables, `params` for a textured Principled
    BSDF's parameters; `without` as for emitters. Paths that still carry the denoising
    features apply this hit to them (features.py), writing into the rows of feature_albedo and
    feature_normal (None: the render makes no features). In a scene with media, the shadow
    rays are attenuated in the media they cross and the next rays carry their path's stack of
    media, entered or left where they pass through the surface (media.py). Hits on shader
    programs are left for program_materials, their rows written into `programs` (as pbrt-v4
    queues each material type for a kernel of its own: this one stays the size it was without
    programs). When pass_sums is not None, hits add to the light passes (record_passes). A lamp
    that casts no shadow adds its light at once, clamped by `clamp` as emitters'; `limits` as
    emitters', whose caustics switches drop lobes at the hits a diffuse ray reached (path_limits).
    `clear`: with Transparent Glass, which materials' transmissions keep a path see-through
    (go_on; empty: none). mnee_flags: the triangles' shadow-caustics flags (mnee.py; empty:
    none), from which each next ray's mnee state follows (mnee_after). `split`: None, or the
    Fresnel split's (mirror rays, scratch counters, whether lamps are the scene's only light)
    (split_fresnel).

    Returns (paths in out, shadow rays queued, program hits left, mirror rays queued).
    """
    n_out = 0
    n_shadow = 0
    n_programs = 0
    n_split = 0
    light_passes = pass_sums is not None
    has_normals = mesh.corner_normals.shape[0] > 0
    can_sample_lights = next_event and lights.cdf.shape[0] > 0 and lights.cdf[-1] > 0.0
    strat = stratified and depth < STRATIFIED_BOUNCES
    for j in range(n_active):
        i = active[j]
        tri = prim[i]
        mat = mats.of_triangle[tri]
        kind = mats.kind[mat]
        if kind == PROGRAM:
            programs[n_programs] = i
            n_programs += 1
            continue
        b1, b2 = np.float64(u[i]), np.float64(v[i])
        p, ng, ng_f, ns_f, eps, entering, d = facing_hit(mesh, paths, i, tri, b1, b2)
        color, trans_color = surface_colors(mats, mat, tri, b1, b2)
        key, sample = paths.key[i], paths.sample[i]
        u_pick, u_roulette = sample_pair(key, sample, 2 + 3 * depth, bits, strat)
        u0, u1 = sample_pair(key, sample, 4 + 3 * depth, bits, strat)
        beta = row(paths.beta, i)
        beta_in = beta
        path = paths.path[i]
        connects = can_connect(depth, last_connection, lv, paths, i, limits)
        # Passed as tuples: a call of more than 30 arguments compiles to a *args call, which
        # Numba cannot inline.
        rng, u_bounce, hit = (key, sample, bits, strat), (u_pick, u0, u1), (p, ng, ng_f, ns_f, eps)
        count = 0
        first_shadow = n_shadow
        drop = dropped_at(limits, paths.ray_kind[i])
        share = 0.0           # glass's F where the Fresnel split applies (split_fresnel)
        if kind == DIFFUSE or kind == LAYERED:
            new_d, beta, ray_kind, pdf_prev, caustic, connect, n_shadow, count = scatter_lit(
                kind, lights, mesh, mats, tables, can_sample_lights, has_normals, rng, depth,
                u_bounce, beta, path, (row(paths.o, i), d, paths.pdf_prev[i]), hit, entering,
                (mat, tri, b1, b2), color, trans_color, (last_connection, connects), lv, lobes,
                params, shadows, n_shadow, radiance, without, stats,
                clamp_limit(clamp, paths.bounce[i] == 0), drop)
        else:
            new_d, beta, ray_kind, pdf_prev, caustic, connect, share = scatter_specular(
                kind, has_normals, fresnel_model, u0, beta, paths.caustic[i], d, ng_f, ns_f,
                entering, color, trans_color, mats.ior[mat], stats, drop)
        caustic = caustic_after(paths.caustic[i], caustic, kind, depth)   # photon merging's
        shadows.bounce[first_shadow:n_shadow] = paths.bounce[i]
        if media.on:
            medium.attenuate_shadows(media, paths.medium, i, tri, mat, entering, ns_f, shadows,
                                     first_shadow, n_shadow)
        weights = features_and_passes(kind, paths, i, shadows, first_shadow, n_shadow, lobes,
                                      count, tables, d, (ns_f, entering), (color, trans_color),
                                      mats.ior[mat], (ray_kind, pdf_prev, new_d), beta_in,
                                      feature_albedo, feature_normal, pass_sums)
        kept = go_on(out, n_out, paths, i, u_roulette, (new_d, beta, ray_kind, pdf_prev,
                                                       caustic, connect, 0.0),
                     offset_origin(p, ng, eps, new_d), feature_albedo, stats, media,
                     (tri, mat, entering, ng_f), clear)
        if kept > n_out and mnee_flags.shape[0] > 0:
            out.mnee[n_out] = mnee_after(mnee_flags, paths.mnee[i], tri, kind, ray_kind,
                                         reflected(new_d, ng_f, ns_f, pdf_prev))
        if light_passes:
            carry_pass_weights(out, n_out, kept, weights)
        if split is not None and share > 0.0:
            n_split = split_fresnel(lights, split, n_split, out, n_out, kept, paths, i,
                                    u_roulette, ray_kind, share, caustic, beta_in, d,
                                    (p, ng, ng_f, ns_f, eps), has_normals, fresnel_model,
                                    (tri, mat, entering, color, mats.ior[mat]), drop,
                                    feature_albedo, media, clear, mnee_flags, light_passes,
                                    stats)
        n_out = kept
    return n_out, n_shadow, n_programs, n_split


@jit_inline
def features_and_passes(kind, paths, i, shadows, first_shadow, n_shadow, lobes, count, tables,
                        d, normal, colors, ior, scattered, beta_in, feature_albedo,
                        feature_normal, pass_sums):
    """Path i's hit applied to its denoising features and light passes, where the render
    makes them (features.py, light_passes.py): returns the (diffuse, glossy) pass weights its
    next ray (`scattered`: ray kind, BSDF density, direction) carries."""
    light_passes = pass_sums is not None
    with_features = feature_albedo is not None and paths.feature_on[i] != 0
    ray_kind, pdf_prev, new_d = scattered
    weights = (ONE, ZERO)
    if light_passes:
        # Before smooth_lobes: a diffuse hit's shadow rays need no lobes, a layered one's
        # are still in `lobes` from its scatter.
        weights = pass_weights_of(kind, paths, i, shadows, first_shadow, n_shadow, lobes,
                                  count, neg(d), ray_kind, pdf_prev, new_d)
    if kind != LAYERED and (with_features or light_passes and paths.bounce[i] == 0):
        count = smooth_lobes(kind, lobes, tables, neg(d), normal[0], normal[1], colors[0],
                             colors[1], ior)
    if with_features:
        record_features(lobes, count, tables, neg(d), paths, i, feature_albedo,
                        feature_normal)
    if light_passes and paths.bounce[i] == 0:
        add_colors(pass_sums, paths.path[i], lobes, count, tables, neg(d), beta_in)
    return weights


@jit_inline
def split_fresnel(lights, split, n_split, out, n_out, kept, paths, i, u_roulette, ray_kind,
                  share, caustic, beta_in, d, hit, has_normals, fresnel_model, surface, drop,
                  feature_albedo, media, clear, mnee_flags, light_passes, stats):
    """The Fresnel split at a smooth glass hit of path i of reflectance F (`share`), before
    the path's first diffuse bounce: a path that reflected (its next ray row n_out of out,
    if kept > n_out) counts the light at its next hit at F; one that refracted queues the
    mirror reflection it did not take (throughput: the path's times colour) as row n_split
    of the split's rays, which count the light at their hit at F and end. Returns the new
    count of those rays.

    Only before the first diffuse bounce: glints are seen through mirrors and glass, and
    after a diffuse bounce a mirror ray seldom meets a lamp the light tracer does not carry
    (split at every bounce, cornell_spheres took 6-8% longer for 2-7% less error).

    Glass picks reflection with probability F, and a path that reflects off water or a window
    rarely meets the lamp it mirrors: a glint's pixels are a few bright samples among dark
    ones (on the pool 85% of its per-sample variance). The split counts the light at the
    reflection's next hit as F x colour x (that light) in either case: the mirror ray carries
    it when the path refracted, and a path that reflected counts its next hit's light at F
    (Paths.light_scale) while it goes on at full weight. Each term's expectation is what the
    path alone counted, so the image's expectation is unchanged (with Cycles' clamp too: it
    applies before the scale, to the sample the path would carry alone); deeper light is the
    path's as before. The ray takes the path's state as the reflection would have (bounce,
    kinds, media, caustic and mnee states, pass weights), so emitters treats its light as the
    path's.

    The world's light is not split (the mirror ray counts none, a reflection all of it): where
    the reflection and the refraction both see a sky, the path alone is the better estimator
    (in a white furnace exact, where the split's would vary by F (1 - F)). So where lamps are
    the only light the split shares (no emissive surface, no sun), a mirror ray that crosses no
    lamp would find nothing and is not traced: most miss a small lamp."""
    if kind_count(paths.kinds[i], DIFFUSE_BOUNCE) > 0:
        return n_split
    if ray_kind == VISIBLE_GLOSSY:
        if kept > n_out:
            out.light_scale[n_out] = share
        return n_split
    p, ng, ng_f, ns_f, eps = hit
    tri, mat, entering, color, ior = surface
    mirror_d, beta = glass_mirror(has_normals, fresnel_model, beta_in, d, ng_f, ns_f, entering,
                                  color, ior, drop)
    stats[FRESNEL_SPLITS] += 1
    origin = offset_origin(p, ng, eps, mirror_d)
    rays, counters, lamps_only = split
    if lamps_only and not crosses_a_lamp(lights, origin, mirror_d, VISIBLE_GLOSSY):
        return n_split
    made = go_on(rays, n_split, paths, i, u_roulette, (mirror_d, beta, VISIBLE_GLOSSY, 0.0,
                                                       caustic, 0.0, 0.0),
                 origin, feature_albedo, counters, media, (tri, mat, entering, ng_f), clear)
    if made > n_split:
        rays.light_scale[n_split] = share
        rays.world_scale[n_split] = 0.0
        if mnee_flags.shape[0] > 0:     # glass is no receiver: a reflection ends a chain
            rays.mnee[n_split] = mnee_after(mnee_flags, paths.mnee[i], tri, GLASS,
                                            VISIBLE_GLOSSY, False)
        if light_passes:
            own = (row(paths.pass_diffuse, i), row(paths.pass_glossy, i))
            carry_pass_weights(rays, n_split, made,
                               singular_pass_weights(paths.bounce[i], own, VISIBLE_GLOSSY))
    return made


@jit_inline
def can_connect(depth, last_connection, lv, paths, i, limits):
    """Whether path i's vertex connects to its light vertex (light_vertices.py): up to bounce
    last_connection, and only if one more diffuse bounce (towards the light vertex, which then
    scatters towards its light) is within the diffuse limit."""
    return (depth <= last_connection and lv.found[paths.path[i]]
            and kind_count(paths.kinds[i], DIFFUSE_BOUNCE) < limits[2])


@jit_inline
def pass_weights_of(kind, paths, i, shadows, first_shadow, n_shadow, lobes, count, wi,
                    ray_kind, pdf_bsdf, wo):
    """The light passes' weights at path i's hit (light_passes.py): its shadow rays'
    (first_shadow .. n_shadow), and the (diffuse, glossy) weights its next ray carries: the
    path's own after its first bounce; at it, those of the sampled direction wo (a Lambert
    surface's all diffuse; a singular sample's by its kind, glossy for a reflection)."""
    bounce = paths.bounce[i]
    own = (row(paths.pass_diffuse, i), row(paths.pass_glossy, i))
    shadow_weights(shadows, first_shadow, n_shadow, bounce, own[0], own[1], lobes, count, wi,
                   kind == DIFFUSE)
    if bounce > 0:
        return own
    if kind == DIFFUSE:
        return ONE, ZERO
    if pdf_bsdf == 0.0:
        return singular_pass_weights(bounce, own, ray_kind)
    return pass_weights(lobes, count, wi, wo)


@jit_inline
def singular_pass_weights(bounce, own, ray_kind):
    """The (diffuse, glossy) pass weights of a singular sample's next ray: the path's own after
    its first bounce; at it, by the sample's kind (glossy for a reflection)."""
    if bounce > 0:
        return own
    if ray_kind == VISIBLE_DIFFUSE:
        return ONE, ZERO
    return (ZERO, ONE) if ray_kind == VISIBLE_GLOSSY else (ZERO, ZERO)


@jit
def program_materials(lights, mesh, mats, media, tables, next_event, bits, stratified, depth,
                      limits, clamp, clear, n_programs, programs, paths, prim, u, v, out, n_out,
                      shadows,
                      n_shadow, radiance, without, lobes, regs, stats, lv, last_connection,
                      feature_albedo, feature_normal, transparent, pass_sums, mnee_flags):
    """The materials stage for the hits on shader programs that `materials` left in
    `programs` (scatter.scatter_program), their next rays after out's first n_out and their
    shadow rays after the first n_shadow. Returns the new (n_out, n_shadow). A path past its
    last bounce (`limits`, as emitters') only passes through the surface's transparency. When
    `transparent`
    has rows (the film's alpha is rendered), a Holdout met before the first bounce adds its
    weight times the path's mean throughput to it, as Cycles' integrate_surface_holdout (a
    path that is still see-through: Paths.see_through). `clear`, pass_sums and mnee_flags as
    materials'."""
    light_passes = pass_sums is not None
    has_normals = mesh.corner_normals.shape[0] > 0
    can_sample_lights = next_event and lights.cdf.shape[0] > 0 and lights.cdf[-1] > 0.0
    strat = stratified and depth < STRATIFIED_BOUNCES
    for j in range(n_programs):
        i = programs[j]
        tri = prim[i]
        mat = mats.of_triangle[tri]
        b1, b2 = np.float64(u[i]), np.float64(v[i])
        p, ng, ng_f, ns_f, eps, entering, d = facing_hit(mesh, paths, i, tri, b1, b2)
        key, sample = paths.key[i], paths.sample[i]
        u_pick, u_roulette = sample_pair(key, sample, 2 + 3 * depth, bits, strat)
        u0, u1 = sample_pair(key, sample, 4 + 3 * depth, bits, strat)
        path = paths.path[i]
        connects = can_connect(depth, last_connection, lv, paths, i, limits)
        ray = (row(paths.o, i), d, paths.ray_kind[i], paths.pdf_prev[i], paths.mis_t[i])
        first_shadow = n_shadow
        bounce = paths.bounce[i]
        beta_in = row(paths.beta, i)
        (new_d, beta, ray_kind, pdf_prev, caustic, connect, n_shadow, count,
         mis_t) = scatter_program(lights, mesh, mats, tables, can_sample_lights, has_normals,
                                  (key, sample, bits, strat), depth,
                                  (bounce, past_last_bounce(bounce, paths.kinds[i], limits),
                                   clamp_limit(clamp, bounce == 0),
                                   dropped_at(limits, paths.ray_kind[i])), (u_pick, u0, u1),
                                  beta_in, path, ray, (p, ng, ng_f, ns_f, eps),
                                  entering, (mat, tri, b1, b2), connects, lv, lobes, regs,
                                  shadows, n_shadow, radiance, without, stats)
        shadows.bounce[first_shadow:n_shadow] = bounce
        if transparent.shape[0] > 0 and paths.see_through[i] != 0 \
                and mats.programs.flags[mat] & HAS_HOLDOUT:
            transparent[path] += regs[MAX_REGISTERS + TOTAL_HOLDOUT] * mean3(beta_in)
        if media.on:
            medium.attenuate_shadows(media, paths.medium, i, tri, mat, entering, ns_f, shadows,
                                     first_shadow, n_shadow)
        if feature_albedo is not None and paths.feature_on[i] != 0:
            record_features(lobes, count, tables, neg(d), paths, i, feature_albedo,
                            feature_normal)
        weights = (ONE, ZERO)
        if light_passes:
            weights = pass_weights_of(LAYERED, paths, i, shadows, first_shadow, n_shadow, lobes,
                                      count, neg(d), ray_kind, pdf_prev, new_d)
            if bounce == 0:
                add_colors(pass_sums, path, lobes, count, tables, neg(d), beta_in)
        kept = go_on(out, n_out, paths, i, u_roulette, (new_d, beta, ray_kind, pdf_prev,
                                                       caustic, connect, mis_t),
                     offset_origin(p, ng, eps, new_d), feature_albedo, stats, media,
                     (tri, mat, entering, ng_f), clear)
        # Passing a transparent surface (mis_t > 0) scatters nowhere: NO_CHAIN, as go_on left it.
        if kept > n_out and mnee_flags.shape[0] > 0 and mis_t == 0.0:
            out.mnee[n_out] = mnee_after(mnee_flags, paths.mnee[i], tri, PROGRAM, ray_kind,
                                         reflected(new_d, ng_f, ns_f, pdf_prev))
        if light_passes:
            carry_pass_weights(out, n_out, kept, weights)
        n_out = kept
    return n_out, n_shadow


@jit_inline
def facing_hit(mesh, paths, i, tri, b1, b2):
    """Path i's hit on triangle tri at (b1, b2): (point, geometric normal, both normals facing
    the incoming ray, offset size, entering (the ray met the front face), ray direction)."""
    p, ng, ns, eps = hit_point(mesh, tri, b1, b2)
    d = row(paths.d, i)
    # Normals facing the incoming ray (two-sided surfaces, the inside of glass).
    ng_f, ns_f, entering = facing(d, ng, ns)
    return p, ng, ng_f, ns_f, eps, entering, d


@jit_inline
def go_on(out, n_out, paths, i, u_roulette, scattered, origin, feature_albedo, stats, media,
          surface, clear):
    """After Russian roulette, path i's next ray from origin (`scattered`: direction,
    throughput, ray kind, BSDF density, caustic state, light-vertex factor, distance since the
    last scattering vertex: not 0 after a transparent surface, which is no bounce) as row n_out
    of `out`, with its stack of media (entered or left through `surface`: triangle, material,
    entering, facing geometric normal); returns the new count. With Transparent Glass (`clear`
    has a row per material), a transmission through a material it marks keeps the path
    see-through, as Cycles' LABEL_TRANSMIT_TRANSPARENT: a singular one always (Cycles' threshold
    is on the roughness, and a singular lobe has none)."""
    new_d, beta, ray_kind, pdf_prev, caustic, connect, mis_t = scattered
    peak = max3(beta)
    if not peak > 0.0:
        return n_out
    scattered_here = mis_t == 0.0       # else it passed a transparent surface: no bounce
    bounce = paths.bounce[i] + (1 if scattered_here else 0)
    if bounce >= RR_START:
        # Survival probability throughput / 0.1: in a closed room a path's remaining light
        # is large, and killing paths at throughput 0.5 (q = throughput) cost more
        # variance than it saved time (measured: 1.5x worse relMSE x time).
        q = min(peak / RR_THRESHOLD, 1.0)
        if u_roulette >= q:
            stats[RR_KILLED] += 1
            return n_out
        beta = mul(beta, 1.0 / q)
    set_ray(out, n_out, origin, new_d, FAR32)
    store(out.beta, n_out, beta)
    out.path[n_out] = paths.path[i]
    out.key[n_out] = paths.key[i]
    out.sample[n_out] = paths.sample[i]
    out.ray_kind[n_out] = ray_kind
    out.caustic[n_out] = caustic
    out.pdf_prev[n_out] = pdf_prev
    out.connect[n_out] = connect
    out.mis_t[n_out] = mis_t
    out.bounce[n_out] = bounce
    tri, mat, entering, ng_f = surface
    kinds = paths.kinds[i]
    out.kinds[n_out] = add_bounce(kinds, bounce_kind(ray_kind, dot(new_d, ng_f) < 0.0)) \
        if scattered_here else kinds
    out.see_through[n_out] = paths.see_through[i]
    out.mnee[n_out] = NO_CHAIN          # materials sets it where shadow caustics run
    out.light_scale[n_out] = 1.0        # materials sets it after a glass reflection it splits
    out.world_scale[n_out] = 1.0
    if scattered_here and not (clear.shape[0] > 0 and ray_kind == VISIBLE_TRANSMISSION
                               and (pdf_prev == 0.0 or clear[mat])):
        out.see_through[n_out] = 0
    if media.on:
        medium.carry(media, paths.medium, i, out.medium, n_out, tri, mat, entering,
                     dot(new_d, ng_f) < 0.0)
    if feature_albedo is not None:     # the render makes the denoising features
        out.feature_on[n_out] = paths.feature_on[i]
        for k in range(3):
            out.feature[n_out, k] = paths.feature[i, k]
    return n_out + 1


@jit
def shadow_rays(n, blocked, shadows, radiance, without, pass_sums, clamp):
    """Add the light of every shadow ray that nothing blocked (Embree: 0 where blocked),
    clamped (path_limits: direct for a light sample of the first hit), and when `without` has
    rows their light without light vertices to it; when pass_sums is not None, to the light passes
    too (light_passes.add_shadow); to its light's group where radiance has group columns
    (light_groups.py)."""
    tracking = without.shape[0] > 0
    light_passes = pass_sums is not None
    grouped = radiance.shape[1] > 3
    for j in range(n):
        if blocked[j] != 0:
            path = shadows.path[j]
            limit = clamp_limit(clamp, shadows.bounce[j] == 0 and shadows.pass_direct[j] != 0)
            contribution = clamp_light(row(shadows.contrib, j), limit)
            add_grouped(radiance, path, shadows.group[j] if grouped else -1, contribution)
            if tracking:
                add_light(without, path, clamp_light(row(shadows.without, j), limit))
            if light_passes:
                store(shadows.contrib, j, contribution)     # what add_shadow reads
                add_shadow(pass_sums, shadows, j)


@jit
def shadow_transparency(mesh, mats, tables, n, pending, prim, u, v, t, shadows, blocked,
                        lobes, regs):
    """One step of shadow rays through transparent surfaces, as Cycles' transparent shadows:
    each of the n shadow rays `pending` (rows of shadows) met the surface prim (Embree's closest
    hit at t, u, v): one that met nothing is free (blocked set to -1); one that met a shader
    program that may be transparent keeps the program's transparency there (its contribution
    scaled by it, the program run as for a shadow ray) and goes on from the far side; any
    other surface blocks it. Returns how many rays go on, moved to the front of `pending`."""
    left = 0
    for j in range(n):
        r = pending[j]
        if prim[j] < 0:
            blocked[r] = -1
            continue
        mat = mats.of_triangle[prim[j]]
        if mats.kind[mat] != PROGRAM or not mats.programs.flags[mat] & MAY_BE_TRANSPARENT:
            continue
        d = (np.float64(shadows.d32[r, 0]), np.float64(shadows.d32[r, 1]),
             np.float64(shadows.d32[r, 2]))
        b1, b2 = np.float64(u[j]), np.float64(v[j])
        p, ng, ns, eps = hit_point(mesh, prim[j], b1, b2)
        ng_f, ns_f, entering = facing(d, ng, ns)
        run(mats, mat, regs, (p, ng_f, ns_f, neg(d), entering, prim[j], b1, b2,
                              1 << LP_SHADOW, shadows.bounce[r], np.float64(t[j])),
            lobes, tables, mesh.corner_normals.shape[0] > 0)
        clear = total(regs, TOTAL_TRANSPARENCY)
        if not max3(clear) > 0.0:
            continue
        for k in range(3):
            shadows.contrib[r, k] *= clear[k]
            shadows.without[r, k] *= clear[k]
        o = (np.float64(shadows.o32[r, 0]), np.float64(shadows.o32[r, 1]),
             np.float64(shadows.o32[r, 2]))
        end = np.float64(shadows.tmax[r])
        start = offset_origin(p, ng, eps, d)
        for k in range(3):
            shadows.o32[r, k] = start[k]
        shadows.tmax[r] = end - dot((start[0] - o[0], start[1] - o[1], start[2] - o[2]), d)
        pending[left] = r
        left += 1
    return left


@jit
def splat(pixels, contributions, film):
    """Add each finite contribution to its pixel's row of the film; returns how many were not
    (NaN or Inf, left out)."""
    bad = 0
    for j in range(pixels.shape[0]):
        if not finite_row(contributions, j):
            bad += 1
            continue
        for k in range(3):
            film[pixels[j], k] += contributions[j, k]
    return bad


@jit
def pixel_of(pixels, row):
    """The image pixel of a pass's row of pixels: all pixels in order when `pixels` is empty,
    else those it lists (adaptive sampling's pixels that still sample)."""
    return row if pixels.shape[0] == 0 else pixels[row]


@jit
def film(radiance, n, start, in_pass, first_sample, pixels, total, total_sq, half):
    """Add the chunk's n path radiances to their pixels' sums and sums of squares (rows of
    (pixels, 3)), and those of class-A samples to `half` (when it has rows: adaptive sampling's
    second image); non-finite samples count as 0. Returns how many there were."""
    bad = 0
    with_half = half.shape[0] > 0
    for i in range(n):
        if not finite_row(radiance, i):
            bad += 1
            continue
        g = start + i
        row = g // in_pass
        pixel = pixel_of(pixels, row)
        class_a = with_half and is_class_a(first_sample + g - row * in_pass)
        for k in range(3):
            value = radiance[i, k]
            total[pixel, k] += value
            total_sq[pixel, k] += value * value
            if class_a:
                half[pixel, k] += value
    return bad


@jit
def film_features(albedo, normal, n, start, in_pass, pixels, albedo_sum, normal_sum):
    """Add the chunk's n paths' denoising features (rows of albedo and normal) to their pixels'
    sums; a path whose features hold a NaN or Inf adds nothing. Returns how many did."""
    bad = 0
    for i in range(n):
        if not (finite_row(albedo, i) and finite_row(normal, i)):
            bad += 1
            continue
        pixel = pixel_of(pixels, (start + i) // in_pass)
        for k in range(3):
            albedo_sum[pixel, k] += albedo[i, k]
            normal_sum[pixel, k] += normal[i, k]
    return bad


@jit
def film_alpha(transparent, n, start, in_pass, pixels, total, total_sq):
    """Add the chunk's n paths' uncovered shares (`transparent`, emitters') to their pixels'
    sums and sums of squares; a NaN or Inf adds nothing. Returns how many there were."""
    bad = 0
    for i in range(n):
        value = transparent[i]
        if not np.isfinite(value):
            bad += 1
            continue
        pixel = pixel_of(pixels, (start + i) // in_pass)
        total[pixel] += value
        total_sq[pixel] += value * value
    return bad


@jit
def clear(radiance, n):
    """Zero the first n rows."""
    for i in range(n):
        for k in range(3):
            radiance[i, k] = 0.0
