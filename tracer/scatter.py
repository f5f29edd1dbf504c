"""What the materials stage does at a hit, by surface kind: DIFFUSE (Lambert) and LAYERED (the
rough and Principled lobes of lobes.py) in one function, PROGRAM (the lobes a shader program
builds) and the smooth specular kinds (mirror, glass, refraction; specular.py).

Each takes the hit (`hit`: point, geometric normal, both normals facing the incoming ray, the
self-intersection offset), the path's sampler (`rng`: key, sample, bits, stratified; `u`: the
bounce's light pick and BSDF pair) and state, and returns the next ray's direction, throughput,
visibility kind (a lights.codes VISIBLE_* flag), BSDF density (0 after a specular bounce: no
light sample competes), place in the split with the light tracer, light-vertex factor (see
wavefront.Paths.connect) and the new shadow-ray count. Diffuse and layered vertices share the
light-sampling and light-vertex steps of direct_light.py.
"""
from __future__ import annotations

import math

from . import specular
from .counters import (DIELECTRIC_SAMPLES, DIFFUSE_HITS, LAYERED_HITS, REFLECTIONS, REJECTED,
                       TIR_ABSORBED_COUNT, TIR_COUNT, TRANSMISSIONS)
from .direct_light import VISIBLE_ANY_BSDF, connect_to_light_vertex, sample_direct_light
from .jit import jit, jit_inline
from .light_tracer import CAUSTIC, FIRST_DIFFUSE, NO_CAUSTIC
from .light_vertices import camera_step_density
from .lights.codes import VISIBLE_DIFFUSE, VISIBLE_GLOSSY, VISIBLE_TRANSMISSION
from .lobes import DIFFUSE_EVENT, TRANSMIT_EVENT, TRANSPARENT_EVENT, bsdf_sample
from .material_kinds import DIFFUSE, GLASS, LAYERED, MIRROR
from .path_limits import drops
from .receivers import lambert_sampled, layered_lobes
from .shader.closures import TOTAL_TRANSPARENCY
from .shader.inputs import DROP_SHIFT, ray_flags
from .shader.program import run, total
from .sampling import sample_cosine_hemisphere
from .vec import dot, neg, sub, vmul


@jit_inline
def scatter_lit(kind, lights, mesh, mats, tables, can_sample_lights, has_normals, rng, depth, u,
                beta, path, ray, hit, entering, surface, color, trans_color, connection, lv, lobes,
                params, shadows, n_shadow, radiance, without, stats, clamp_direct, drop):
    """A DIFFUSE (Lambert) or LAYERED (rough or Principled: its lobes, lobes.setup_shader)
    vertex: a light sample and the light-vertex connection evaluated on its surface, then a
    cosine-weighted sample (diffuse) or a sample of one lobe. `ray`: the origin, direction and
    BSDF density of the ray that hit; `surface`: the material, triangle and barycentrics (for
    textures); `connection`: (the last bounce that connects to light vertices, whether this
    one does); `clamp_direct` the clamp of its light samples and `drop` the caustics its lobes
    drop (path_limits.dropped_at: a Lambert surface has none to drop). Returns the lobe
    count too (a layered hit's lobes stay in `lobes` for the
    denoising features). One function for both kinds, so that a kernel holds one copy of the
    light-sampling steps (each copy is compiled anew into every kernel that inlines it)."""
    key, sample, bits, strat = rng
    u_pick, u0, u1 = u
    o, d, pdf_in = ray
    p, ng, ng_f, ns_f, eps = hit
    mat, tri, b1, b2 = surface
    last_connection, connects = connection
    view = neg(d)
    count = 0
    step = 0.0
    vertex_kind = VISIBLE_ANY_BSDF
    if kind == DIFFUSE:
        stats[DIFFUSE_HITS] += 1
        vertex_kind = VISIBLE_DIFFUSE
        # A light vertex could stand in for this vertex if the camera path sampled it from a
        # vertex that connects (light_vertices.py): that strategy's MIS density needs the
        # density of the step here.
        if depth - 1 <= last_connection and pdf_in > 0.0:
            step = camera_step_density(pdf_in, o, p, ng, d)
    else:
        stats[LAYERED_HITS] += 1
        count = layered_lobes(mats, tables, has_normals, surface, color, trans_color, ng_f, ns_f,
                              view, entering, params, lobes, drop)
    if can_sample_lights:
        n_shadow = sample_direct_light(lights, mesh, key, sample, 3 + 3 * depth, bits, strat,
                                       u_pick, vertex_kind, p, ng_f, ns_f, eps, beta, step,
                                       kind, color, lobes, count, view, shadows, n_shadow,
                                       radiance, without, path, clamp_direct)
    if connects:
        n_shadow = connect_to_light_vertex(lights, shadows, n_shadow, lv, path, beta, p, ng_f,
                                           ns_f, eps, kind, color, lobes, count, view, stats)
    if kind == DIFFUSE:
        wi, pdf = sample_cosine_hemisphere(ns_f, u0, u1)
        # Shading normals can point a sample into the surface: it carries nothing.
        beta = (0.0, 0.0, 0.0) if dot(wi, ng_f) <= 0.0 else vmul(beta, color)
        connect = 0.0
        if step > 0.0:
            connect = dot(wi, ng_f) / step
        caustic = FIRST_DIFFUSE if depth == 0 else NO_CAUSTIC
        return wi, beta, VISIBLE_DIFFUSE, pdf, caustic, connect, n_shadow, count
    new_d, factor, pdf_prev, event, valid = bsdf_sample(lobes, count, ng_f, view, u_pick, u0, u1)
    beta = vmul(beta, factor) if valid else (0.0, 0.0, 0.0)
    ray_kind = VISIBLE_DIFFUSE if event == DIFFUSE_EVENT else \
        VISIBLE_TRANSMISSION if event == TRANSMIT_EVENT else VISIBLE_GLOSSY
    return (new_d, beta, ray_kind, pdf_prev, lobe_split(mats, mat, depth, event, new_d, ng_f),
            0.0, n_shadow, count)


@jit_inline
def scatter_program(lights, mesh, mats, tables, can_sample_lights, has_normals, rng, depth,
                    bounces, u, beta, path, ray, hit, entering, surface, connects, lv, lobes, regs,
                    shadows, n_shadow, radiance, without, stats):
    """A vertex on a shader program's material (shader/program.py): the program builds the
    hit's lobes, which serve the light sample, the light-vertex connection and the BSDF sample
    as a layered vertex's do. `ray`: (origin, direction, kind and BSDF density of the ray that
    hit, the distance it went since its last scattering vertex). A Transparent sample lets the
    path go on unbent as the same ray: its kind and density stay, and the distance grows.
    bounces: (the path's bounces, whether they are spent, the clamp of the vertex's light
    samples, the caustics its closures drop: path_limits.dropped_at, passed to them in the
    hit's flags from bit inputs.DROP_SHIFT): a path past its last bounce only passes through the
    surface's transparency, as
    Cycles' PATH_RAY_TERMINATE_AFTER_TRANSPARENT paths do (their shader keeps no closure but
    Transparent).
    Returns scatter_lit's results, then the new distance since the last scattering vertex."""
    key, sample, bits, strat = rng
    u_pick, u0, u1 = u
    p, _, ng_f, ns_f, eps = hit
    mat, tri, b1, b2 = surface
    o, d, kind_in, pdf_in, mis_t = ray
    stats[LAYERED_HITS] += 1
    view = neg(d)
    segment = sub(p, o)
    length = math.sqrt(dot(segment, segment))
    bounce, spent, clamp_direct, drop = bounces
    count = run(mats, mat, regs, (p, ng_f, ns_f, view, entering, tri, b1, b2,
                                  ray_flags(kind_in, pdf_in) | drop << DROP_SHIFT, bounce,
                                  length),
                lobes, tables, has_normals)
    if spent:
        clear = total(regs, TOTAL_TRANSPARENCY)
        return d, vmul(beta, clear), kind_in, pdf_in, NO_CAUSTIC, 0.0, n_shadow, 0, mis_t + length
    if can_sample_lights:
        n_shadow = sample_direct_light(lights, mesh, key, sample, 3 + 3 * depth, bits, strat,
                                       u_pick, VISIBLE_ANY_BSDF, p, ng_f, ns_f, eps, beta, 0.0,
                                       LAYERED, mats.color[mat], lobes, count, view, shadows,
                                       n_shadow, radiance, without, path, clamp_direct)
    if connects:
        n_shadow = connect_to_light_vertex(lights, shadows, n_shadow, lv, path, beta, p, ng_f,
                                           ns_f, eps, LAYERED, mats.color[mat], lobes, count,
                                           view, stats)
    new_d, factor, pdf_prev, event, valid = bsdf_sample(lobes, count, ng_f, view, u_pick, u0, u1)
    beta = vmul(beta, factor) if valid else (0.0, 0.0, 0.0)
    if event == TRANSPARENT_EVENT:
        return new_d, beta, kind_in, pdf_in, NO_CAUSTIC, 0.0, n_shadow, count, mis_t + length
    ray_kind = VISIBLE_DIFFUSE if event == DIFFUSE_EVENT else \
        VISIBLE_TRANSMISSION if event == TRANSMIT_EVENT else VISIBLE_GLOSSY
    return (new_d, beta, ray_kind, pdf_prev, lobe_split(mats, mat, depth, event, new_d, ng_f),
            0.0, n_shadow, count, 0.0)


@jit_inline
def lobe_split(mats, mat, depth, event, wo, ng_f):
    """A layered or program vertex's place in the split with the light tracer: FIRST_DIFFUSE
    where the camera's first hit, on a surface light paths end on, sampled wo from a Lambert
    lobe (receivers.py: the light tracer carries that share of its paths through mirrors and
    glass to a light)."""
    if depth == 0 and mats.receives[mat] and lambert_sampled(event, wo, ng_f):
        return FIRST_DIFFUSE
    return NO_CAUSTIC


@jit_inline
def scatter_specular(kind, has_normals, fresnel_model, u0, beta, caustic_in, d, ng_f, ns_f,
                     entering, color, trans_color, ior, stats, drop):
    """A mirror, smooth glass or refraction-only vertex (specular.sample_specular): no light
    sample can compete, so the next ray has BSDF density 0. A sample of a kind of caustics the
    hit drops (path_limits.dropped_at) carries nothing: glass keeps the other kind's share, as
    Cycles' glass with that tint 0. Last, glass's reflectance F where it chose between
    reflection and refraction by it, else 0 (the Fresnel split: wavefront.split_fresnel)."""
    new_d, weight, event, valid, f = specular.sample_at_hit(
        kind, d, ng_f, ns_f, entering, has_normals, color, trans_color, ior, fresnel_model, u0)
    count_specular(stats, event, valid)
    if drop != 0 and drops(drop, event == specular.TRANSMITTED):
        valid = False
    if kind != MIRROR:
        stats[DIELECTRIC_SAMPLES] += 1
    beta = vmul(beta, weight) if valid else (0.0, 0.0, 0.0)
    ray_kind = VISIBLE_TRANSMISSION if event == specular.TRANSMITTED else VISIBLE_GLOSSY
    caustic = CAUSTIC if caustic_in != NO_CAUSTIC else NO_CAUSTIC
    chose = kind == GLASS and (event == specular.REFLECTED or event == specular.TRANSMITTED)
    return new_d, beta, ray_kind, 0.0, caustic, 0.0, f if chose else 0.0


@jit_inline
def glass_mirror(has_normals, fresnel_model, beta, d, ng_f, ns_f, entering, color, ior, drop):
    """The mirror reflection a smooth glass hit did not take (it refracted): its direction and
    throughput beta x colour, zero where Cycles rejects the reflection or the hit drops
    reflective caustics (the Fresnel split: wavefront.split_fresnel)."""
    new_d, weight, _, valid, _ = specular.sample_at_hit(
        GLASS, d, ng_f, ns_f, entering, has_normals, color, color, ior, fresnel_model, 0.0)
    if not valid or drop != 0 and drops(drop, False):
        return new_d, (0.0, 0.0, 0.0)
    return new_d, vmul(beta, weight)


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
