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

from . import specular
from .adaptive import is_class_a
from .camera import camera_ray
from .geometry import FAR, hit_point, offset_origin
from .jit import jit
from .lights.area import area_lamp_hit, intersect_area_lamp
from .lights.codes import (AREA, CASTS_SHADOW, USES_MIS, VISIBLE_CAMERA, VISIBLE_DIFFUSE,
                           VISIBLE_GLOSSY, VISIBLE_TRANSMISSION, seen_by)
from .lights.dispatch import pick_light, sample_light
from .lights.point import intersect_point_lamp, point_lamp_hit
from .lights.sun import sun_hit
from .lights.triangles import pdf_triangle
from .lights.world import pdf_world, world_radiance
from .light_vertices import (camera_step_density, connection, direction_to,
                             light_vertex_density, triangle_density)
from .material_kinds import DIFFUSE, EMISSION, LAYERED, MIRROR, REFRACTION
from .lobes import (DIFFUSE_EVENT, P_METALLIC, P_ROUGHNESS, REFLECT_EVENT, SHADER_PRINCIPLED,
                    TRANSMIT_EVENT, bsdf_eval, bsdf_sample, setup_shader)
from .sampler import pixel_key, sample_pair
from .sampling import power_heuristic, power_heuristic3, sample_cosine_hemisphere
from .textures import METALLIC_SLOT, ROUGHNESS_SLOT, material_number, surface_colors
from .vec import dot, finite_row, max3, mul, neg, row, store, sub, vmul

STRATIFIED_BOUNCES = 2    # bounces whose light and BSDF samples are stratified (then random)
RR_START = 3              # Russian roulette from this bounce on ...
RR_THRESHOLD = 0.1        # ... for paths whose throughput has fallen below this
# Event counters (RenderResult.stats), by index.
STATS = ("tir", "tir_absorbed", "rejected", "transmissions", "reflections", "diffuse",
         "rr_killed", "depth_limited", "caustic_splats", "lens_samples", "dielectric_samples",
         "layered_hits", "light_vertex_connections", "light_vertex_rays")
(TIR_COUNT, TIR_ABSORBED_COUNT, REJECTED, TRANSMISSIONS, REFLECTIONS, DIFFUSE_HITS, RR_KILLED,
 DEPTH_LIMITED, CAUSTIC_SPLATS, LENS_SAMPLES, DIELECTRIC_SAMPLES, LAYERED_HITS,
 CONNECTIONS, VERTEX_RAYS) = range(len(STATS))
# Light sampling at a layered vertex serves all its lobes.
VISIBLE_ANY_BSDF = VISIBLE_DIFFUSE | VISIBLE_GLOSSY | VISIBLE_TRANSMISSION
FAR32 = np.float32(FAR)
# A camera path's place in the split of path space with the light tracer (light_tracer.py).
NO_CAUSTIC, FIRST_DIFFUSE, CAUSTIC = range(3)


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
    ray_kind: np.ndarray     # (n,) int64: the lights.codes VISIBLE_* flag of the event that made the ray
    pdf_prev: np.ndarray     # (n,) solid-angle density of the BSDF sample that made the ray, 0
    #                          after the camera and specular bounces (no light sample competes)
    caustic: np.ndarray      # (n,) int64: NO_CAUSTIC, or FIRST_DIFFUSE (the camera's first hit was
    #                          diffuse) then CAUSTIC (and every vertex since specular): the light
    #                          tracer's paths, whose emitters the path tracer then skips
    connect: np.ndarray      # (n,) after a diffuse vertex y1 that a light vertex could stand in
    #                          for: cos_g(y1, ray) / the density of the camera's step to y1 (the
    #                          light vertex's MIS density per unit of light_vertex_density), else 0


class Shadows(NamedTuple):
    """The shadow rays of one bounce."""
    path: np.ndarray         # (n,) int64
    o32: np.ndarray          # (n, 3) float32
    d32: np.ndarray          # (n, 3) float32
    tmax: np.ndarray         # (n,) float32 segment length
    contrib: np.ndarray      # (n, 3) radiance the path gets if the segment is free
    without: np.ndarray      # (n, 3) the same without light vertices (a pilot's, see emitters)


def new_paths(n: int) -> Paths:
    """Uninitialised path buffers for n paths."""
    return Paths(np.empty(n, np.int64), np.empty(n, np.uint64), np.empty(n, np.int64),
                 np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3), np.float32),
                 np.empty((n, 3), np.float32), np.empty(n, np.float32), np.empty((n, 3)),
                 np.empty(n, np.int64), np.empty(n), np.empty(n, np.int64), np.empty(n))


def new_shadows(n: int) -> Shadows:
    """Uninitialised shadow-ray buffers for n rays."""
    return Shadows(np.empty(n, np.int64), np.empty((n, 3), np.float32),
                   np.empty((n, 3), np.float32), np.empty(n, np.float32), np.empty((n, 3)),
                   np.empty((n, 3)))


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
def add_light(radiance, path, beta, light, w):
    """radiance[path] += beta * light * w."""
    for k in range(3):
        radiance[path, k] += beta[k] * light[k] * w


@jit
def add_light_both(radiance, without, path, beta, light, w, w_without):
    """add_light with weight w and, when `without` has rows (a pilot), to the radiance without
    light vertices with w_without, their weight where no light vertex competes."""
    add_light(radiance, path, beta, light, w)
    if without.shape[0] > 0:
        add_light(without, path, beta, light, w_without)


@jit
def generate(cam, seed, start, in_pass, first_sample, pixels, bits, stratified, n, paths, stats):
    """Camera rays for the chunk's paths start .. start + n of a pass of in_pass samples per
    pixel (pixel = pixel_of(path // in_pass), sample = first_sample + path % in_pass)."""
    for i in range(n):
        g = start + i
        row = g // in_pass
        pixel = pixel_of(pixels, row)
        sample = first_sample + g - row * in_pass
        key = pixel_key(pixel, seed)
        u0, u1 = sample_pair(key, sample, 0, bits, stratified)
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


@jit
def emitters(lights, mats, next_event, caustics, depth, max_depth, m, paths, prim, t, radiance,
             without, active, stats):
    """Lamps, the world, suns and emissive triangles add their light; returns how many paths go
    on to scatter (their rows in `active`).

    `without` (when it has rows) gets the light the same paths would carry without light
    vertices: the path tracer's samples are the same, only the MIS weights of light that a light
    vertex could have found change. A pilot compares the two (pilot.py).

    Lamps have no surface, as in Cycles: a ray adds the light of every lamp it crosses before its
    hit (or escape) and goes on as if the lamp were not there. A lamp is seen by the rays its
    visibility flags allow (lights.codes.seen_by). With `caustics` (the light tracer runs), paths in the
    CAUSTIC state get no light from lamps, emissive triangles or suns: those paths are the light
    tracer's to count.
    """
    kept = 0
    for i in range(m):
        o, d = row(paths.o, i), row(paths.d, i)
        beta, path, kind = row(paths.beta, i), paths.path[i], paths.ray_kind[i]
        pdf_prev = paths.pdf_prev[i]
        t_surface = np.float64(t[i])     # Embree leaves a miss's t at the ray's length
        emitters_count = not (caustics and paths.caustic[i] == CAUSTIC)
        for lamp in range(lights.area_area.shape[0] if emitters_count else 0):
            if not seen_by(lights.area_flags[lamp], kind):
                continue
            t_lamp = intersect_area_lamp(lights, lamp, o, d)
            if 0.0 < t_lamp < t_surface:
                light, density = area_lamp_hit(lights, lamp, d, t_lamp)
                q = light_vertex_density(lights, AREA, lamp, lights.area_pmf[lamp])
                pdf_light = lights.area_pmf[lamp] * density
                add_light_both(radiance, without, path, beta, light,
                               mis_weight(next_event, pdf_prev, pdf_light, q * paths.connect[i]),
                               mis_weight(next_event, pdf_prev, pdf_light, 0.0))
        for lamp in range(lights.point_radius.shape[0] if emitters_count else 0):
            if not seen_by(lights.point_flags[lamp], kind):
                continue
            t_lamp = intersect_point_lamp(lights, lamp, o, d)
            if 0.0 < t_lamp < t_surface:
                light, density = point_lamp_hit(lights, lamp, o, d, t_lamp, pdf_prev)
                w = mis_weight(next_event, pdf_prev, lights.point_pmf[lamp] * density, 0.0)
                add_light_both(radiance, without, path, beta, light, w, w)
        if prim[i] < 0:
            if lights.has_world:
                w = mis_weight(next_event, pdf_prev, pdf_world(lights, d), 0.0)
                add_light_both(radiance, without, path, beta, world_radiance(lights, d), w, w)
            for sun in range(lights.sun_one_minus_cos.shape[0] if emitters_count else 0):
                # Cycles finds a sun's disc only with its MIS option, camera rays included.
                flags = lights.sun_flags[sun]
                if flags & kind and flags & USES_MIS:
                    light, density = sun_hit(lights, sun, d)
                    w = mis_weight(next_event, pdf_prev, lights.sun_pmf[sun] * density, 0.0)
                    add_light_both(radiance, without, path, beta, light, w, w)
            continue
        mat = mats.of_triangle[prim[i]]
        emission = row(mats.radiance, mat)
        if emitters_count and max3(emission) > 0.0:     # Emission, or a Principled BSDF's
            pdf_light = pdf_triangle(lights, prim[i], o, d, t_surface)
            add_light_both(radiance, without, path, beta, emission,
                           mis_weight(next_event, pdf_prev, pdf_light,
                                      triangle_density(lights, prim[i]) * paths.connect[i]),
                           mis_weight(next_event, pdf_prev, pdf_light, 0.0))
        if mats.kind[mat] == EMISSION:
            continue
        if depth == max_depth:
            stats[DEPTH_LIMITED] += 1     # the depth limit, not the scene, ends this path
            continue
        active[kept] = i
        kept += 1
    return kept


@jit
def materials(lights, mesh, mats, tables, fresnel_model, next_event, bits, stratified, depth,
              n_active, active, paths, prim, u, v, out, shadows, radiance, without, lobes, params,
              stats, lv, last_connection):
    """Sample every kept hit: a light sample at diffuse and layered vertices (queued as a shadow
    ray), and up to bounce last_connection (-1: never) the connection to the path's light vertex
    in `lv` (light_vertices.py; another shadow ray); then the BSDF; after Russian roulette the
    surviving paths' next rays go into `out`. `lobes` is scratch for a layered hit's lobes
    (lobes.py), `tables` its albedo tables, `params` for a textured Principled BSDF's parameters;
    `without` as for emitters.

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
        color, trans_color = surface_colors(mats, mat, tri, np.float64(u[i]), np.float64(v[i]))
        key, sample = paths.key[i], paths.sample[i]
        u_pick, u_roulette = sample_pair(key, sample, 2 + 3 * depth, bits, strat)
        u0, u1 = sample_pair(key, sample, 4 + 3 * depth, bits, strat)
        beta = row(paths.beta, i)
        path = paths.path[i]
        connects = depth <= last_connection and lv.found[path]
        connect = 0.0
        if kind == DIFFUSE:
            stats[DIFFUSE_HITS] += 1
            albedo = color
            # A light vertex could stand in for this vertex if the camera path sampled it from a
            # vertex that connects (light_vertices.py): that strategy's MIS density needs the
            # density of the step here.
            step = 0.0
            if depth - 1 <= last_connection and paths.pdf_prev[i] > 0.0:
                step = camera_step_density(paths.pdf_prev[i], row(paths.o, i), p, ng, d)
            if can_sample_lights:
                l0, l1 = sample_pair(key, sample, 3 + 3 * depth, bits, strat)
                wi, target, infinite, weight, pdf_light, flags = sample_light(
                    lights, mesh, p, ns_f, VISIBLE_DIFFUSE, u_pick, l0, l1)
                cos = dot(wi, ns_f)
                # As in Cycles, the shading normal alone decides: a light below the geometric
                # surface but above the shading normal's horizon lights the point if the shadow
                # ray, which starts on the surface's far side, gets through (on a closed smooth
                # mesh it does only for lamps that cast no shadow). BSDF samples below the
                # geometric surface carry nothing (below), also as in Cycles.
                if cos > 0.0 and max3(weight) > 0.0:
                    p_vertex = 0.0
                    cos_g = dot(wi, ng_f)
                    if step > 0.0 and cos_g > 0.0:
                        kind_l, k_l, pmf_l = pick_light(lights, u_pick)
                        p_vertex = light_vertex_density(lights, kind_l, k_l, pmf_l) * cos_g / step
                    w, w_without = 1.0, 1.0
                    if pdf_light > 0.0:
                        w = power_heuristic3(pdf_light, cos / math.pi, p_vertex)
                        w_without = power_heuristic3(pdf_light, cos / math.pi, 0.0)
                    light = mul(vmul(vmul(beta, albedo), weight), cos / math.pi)
                    n_shadow = deliver_light(shadows, n_shadow, radiance, without, path,
                                             mul(light, w), mul(light, w_without), flags,
                                             offset_origin(p, ng_f, eps, wi), wi, target,
                                             infinite)
            if connects:
                wl, d2 = direction_to(lv, path, p)
                cos = dot(wl, ns_f)
                if cos > 0.0 and dot(wl, ng_f) > 0.0:
                    n_shadow = connect_light_vertex(shadows, n_shadow, lv, path, beta, p, ng_f,
                                                    eps, wl, d2, mul(albedo, cos / math.pi),
                                                    cos / math.pi, stats)
            wi, pdf = sample_cosine_hemisphere(ns_f, u0, u1)
            # Shading normals can point a sample into the surface: it carries nothing.
            beta = (0.0, 0.0, 0.0) if dot(wi, ng_f) <= 0.0 else vmul(beta, albedo)
            if step > 0.0:
                connect = dot(wi, ng_f) / step
            new_d, ray_kind, pdf_prev = wi, VISIBLE_DIFFUSE, pdf
            caustic = FIRST_DIFFUSE if depth == 0 else NO_CAUSTIC
        elif kind == LAYERED:
            stats[LAYERED_HITS] += 1
            view = neg(d)
            n = specular.valid_reflection_normal(ng_f, view, ns_f) if has_normals else ns_f
            roughness, shader_params = mats.roughness[mat], mats.principled[mat]
            if mats.textured[mat]:
                roughness, shader_params = textured_params(mats, mat, tri, np.float64(u[i]),
                                                           np.float64(v[i]), params)
            count = setup_shader(lobes, tables, mats.shader[mat], color, trans_color,
                                 mats.ior[mat], roughness, mats.distribution[mat], shader_params,
                                 n, ns_f, view, entering)
            if can_sample_lights:
                l0, l1 = sample_pair(key, sample, 3 + 3 * depth, bits, strat)
                wl, target, infinite, weight, pdf_light, flags = sample_light(
                    lights, mesh, p, ns_f, VISIBLE_ANY_BSDF, u_pick, l0, l1)
                if max3(weight) > 0.0:
                    f, pdf_bsdf = bsdf_eval(lobes, count, view, wl, lit_events(flags))
                    if max3(f) > 0.0:
                        w = power_heuristic(pdf_light, pdf_bsdf) if pdf_light > 0.0 else 1.0
                        light = mul(vmul(vmul(beta, f), weight), w)
                        n_shadow = deliver_light(shadows, n_shadow, radiance, without, path,
                                                 light, light, flags,
                                                 offset_origin(p, ng_f, eps, wl), wl, target,
                                                 infinite)
            if connects:
                wl, d2 = direction_to(lv, path, p)
                f, pdf_bsdf = bsdf_eval(lobes, count, view, wl, lit_events(VISIBLE_ANY_BSDF))
                if max3(f) > 0.0:
                    n_shadow = connect_light_vertex(shadows, n_shadow, lv, path, beta, p, ng_f,
                                                    eps, wl, d2, f, pdf_bsdf, stats)
            new_d, factor, pdf_prev, event, valid = bsdf_sample(lobes, count, ng_f, view, u_pick,
                                                                u0, u1)
            beta = vmul(beta, factor) if valid else (0.0, 0.0, 0.0)
            ray_kind = VISIBLE_DIFFUSE if event == DIFFUSE_EVENT else \
                VISIBLE_TRANSMISSION if event == TRANSMIT_EVENT else VISIBLE_GLOSSY
            # The light tracer ends its paths on layered surfaces, so the path tracer counts
            # every path through them.
            caustic = NO_CAUSTIC
        else:
            n = ns_f
            if has_normals and kind != REFRACTION:
                n = specular.valid_reflection_normal(ng_f, neg(d), ns_f)
            new_d, weight, event, valid = specular.sample_specular(
                kind, d, ng_f, n, entering, color, trans_color, mats.ior[mat], fresnel_model, u0)
            count_specular(stats, event, valid)
            if kind != MIRROR:
                stats[DIELECTRIC_SAMPLES] += 1
            beta = vmul(beta, weight) if valid else (0.0, 0.0, 0.0)
            ray_kind = VISIBLE_TRANSMISSION if event == specular.TRANSMITTED else VISIBLE_GLOSSY
            pdf_prev = 0.0
            caustic = CAUSTIC if paths.caustic[i] != NO_CAUSTIC else NO_CAUSTIC
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
        out.ray_kind[n_out] = ray_kind
        out.caustic[n_out] = caustic
        out.pdf_prev[n_out] = pdf_prev
        out.connect[n_out] = connect
        n_out += 1
    return n_out, n_shadow


@jit
def textured_params(mats, mat, tri, b1, b2, params):
    """(roughness, Principled parameters) of a textured layered material at a hit: its
    roughness texture's value, and for a Principled BSDF its parameters copied into the scratch
    row `params` with the roughness and metallic textures' values."""
    roughness = material_number(mats, mat, ROUGHNESS_SLOT, tri, b1, b2, mats.roughness[mat])
    if mats.shader[mat] != SHADER_PRINCIPLED:
        return roughness, mats.principled[mat]
    for k in range(params.shape[0]):
        params[k] = mats.principled[mat, k]
    params[P_ROUGHNESS] = material_number(mats, mat, ROUGHNESS_SLOT, tri, b1, b2,
                                          mats.principled[mat, P_ROUGHNESS])
    params[P_METALLIC] = material_number(mats, mat, METALLIC_SLOT, tri, b1, b2,
                                         mats.principled[mat, P_METALLIC])
    return roughness, params


@jit
def lit_events(flags):
    """The lobe events (lobes.py bit mask) a light of these lights.codes flags lights."""
    events = 0
    if flags & VISIBLE_DIFFUSE:
        events |= 1 << DIFFUSE_EVENT
    if flags & VISIBLE_GLOSSY:
        events |= 1 << REFLECT_EVENT
    if flags & VISIBLE_TRANSMISSION:
        events |= 1 << TRANSMIT_EVENT
    return events


@jit
def deliver_light(shadows, n_shadow, radiance, without, path, light, light_without, flags,
                  origin, wi, target, infinite):
    """A light sample's contribution (light_without: its share without light vertices, for
    `without` as in emitters): behind a shadow ray from origin (queued as ray n_shadow), or
    added at once for a lamp that casts no shadow (lights.codes flags). Returns the new shadow-ray
    count."""
    if flags & CASTS_SHADOW:
        store(shadows.contrib, n_shadow, light)
        store(shadows.without, n_shadow, light_without)
        queue_shadow(shadows, n_shadow, path, origin, wi, target, infinite)
        return n_shadow + 1
    add_light(radiance, path, light, (1.0, 1.0, 1.0), 1.0)
    if without.shape[0] > 0:
        add_light(without, path, light_without, (1.0, 1.0, 1.0), 1.0)
    return n_shadow


@jit
def connect_light_vertex(shadows, n_shadow, lv, path, beta, p, ng_f, eps, w, d2, f_cos, pdf,
                         stats):
    """Queue the connection of a camera vertex p (throughput beta, BSDF x cosine f_cos and
    density pdf towards its light vertex along w, at squared distance d2) as shadow ray
    n_shadow; returns the new shadow-ray count."""
    light = connection(lv, path, w, d2, f_cos, pdf)
    if not max3(light) > 0.0:
        return n_shadow
    store(shadows.contrib, n_shadow, vmul(beta, light))
    store(shadows.without, n_shadow, (0.0, 0.0, 0.0))
    queue_shadow(shadows, n_shadow, path, offset_origin(p, ng_f, eps, w), w,
                 row(lv.point, path), False)
    stats[CONNECTIONS] += 1
    return n_shadow + 1


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
    if event == specular.TIR:
        stats[TIR_COUNT] += 1
    elif event == specular.TIR_ABSORBED:
        stats[TIR_ABSORBED_COUNT] += 1
        return
    elif event == specular.TRANSMITTED:
        stats[TRANSMISSIONS] += 1
    else:
        stats[REFLECTIONS] += 1
    if not valid:
        stats[REJECTED] += 1


@jit
def shadow_rays(n, blocked, shadows, radiance, without):
    """Add the light of every shadow ray that nothing blocked (Embree: 0 where blocked), and
    when `without` has rows their light without light vertices to it."""
    tracking = without.shape[0] > 0
    for j in range(n):
        if blocked[j] != 0:
            for k in range(3):
                radiance[shadows.path[j], k] += shadows.contrib[j, k]
                if tracking:
                    without[shadows.path[j], k] += shadows.without[j, k]


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
def clear(radiance, n):
    """Zero the first n rows."""
    for i in range(n):
        for k in range(3):
            radiance[i, k] = 0.0
