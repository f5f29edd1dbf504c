"""Light reaching a diffuse or layered vertex directly: the shared step that samples a light
(next-event estimation), the shared step that connects to the path's light vertex, and the
shadow rays both queue.

Both steps evaluate the surface through evaluate_surface, the one switch on the surface kind:
Lambert for DIFFUSE, the hit's lobes (lobes.py) for LAYERED. The light sample is weighted by the
power heuristic against BSDF sampling and, at a vertex a light vertex could stand in for,
against the light vertex (light_vertices.py).
"""
from __future__ import annotations

import math

from .counters import CONNECTIONS
from .geometry import FAR, offset_origin
from .jit import jit, jit_inline
from .light_groups import add_grouped, emitter_group, light_group
from .light_vertices import connection, direction_to
from .lights.codes import CASTS_SHADOW, VISIBLE_DIFFUSE, VISIBLE_GLOSSY, VISIBLE_TRANSMISSION
from .lights.dispatch import light_vertex_density, pick_light, sample_light
from .lobes import DIFFUSE_EVENT, REFLECT_EVENT, TRANSMIT_EVENT, bsdf_eval
from .material_kinds import DIFFUSE
from .path_limits import clamp_light
from .sampler import sample_pair
from .sampling import power_heuristic3
from .vec import dot, max3, mul, row, store, sub, vmul

# Light sampling at a layered vertex serves all its lobes.
VISIBLE_ANY_BSDF = VISIBLE_DIFFUSE | VISIBLE_GLOSSY | VISIBLE_TRANSMISSION


@jit_inline
def evaluate_surface(kind, albedo, lobes, count, view, ns_f, ng_f, w, events, shading_only):
    """The surface's BSDF x cosine towards w as (colour, scale: f |cos| = colour x scale),
    its density of sampling w, and whether w gets light. DIFFUSE: Lambert of this albedo on the
    shading normal; with shading_only False w must also be above the geometric surface.
    LAYERED: the hit's `count` lobes seen from view, for the lobe events `events`."""
    if kind == DIFFUSE:
        cos = dot(w, ns_f)
        valid = cos > 0.0 and (shading_only or dot(w, ng_f) > 0.0)
        return albedo, cos / math.pi, cos / math.pi, valid
    f, pdf = bsdf_eval(lobes, count, view, w, events)
    return f, 1.0, pdf, max3(f) > 0.0


@jit_inline
def sample_direct_light(lights, mesh, key, sample, dimension, bits, strat, u_pick, vertex_kind,
                        p, ng_f, ns_f, eps, beta, step, kind, albedo, lobes, count, view,
                        shadows, n_shadow, radiance, without, path, limit):
    """Next-event estimation at p (a vertex of this surface kind, scattering rays of
    vertex_kind): sample a light (u_pick, and the sampler's pair `dimension`), evaluate the
    surface towards it, weight it by MIS and queue its shadow ray (deliver_light). step > 0: the
    density of the camera's step to p when a light vertex could stand in for p (a third
    strategy). `limit`: the clamp of direct light at this vertex (path_limits). Returns the new
    shadow-ray count."""
    l0, l1 = sample_pair(key, sample, dimension, bits, strat)
    wi, target, infinite, weight, pdf_light, flags = sample_light(
        lights, mesh, p, ns_f, vertex_kind, u_pick, l0, l1)
    if not max3(weight) > 0.0:
        return n_shadow
    # As in Cycles, the shading normal alone decides: a light below the geometric surface but
    # above the shading normal's horizon lights the point if the shadow ray, which starts on
    # the surface's far side, gets through (on a closed smooth mesh it does only for lamps that
    # cast no shadow). BSDF samples below the geometric surface carry nothing, also as in Cycles.
    color, scale, pdf, valid = evaluate_surface(kind, albedo, lobes, count, view, ns_f, ng_f, wi,
                                                lit_events(flags), True)
    if not valid:
        return n_shadow
    p_vertex = 0.0
    cos_g = dot(wi, ng_f)
    # The light sample_light picked, asked again only where needed: its light-vertex density,
    # and its light group when the render makes them (radiance rows wider than Combined's).
    grouped = radiance.shape[1] > 3
    group = -1
    if (step > 0.0 and cos_g > 0.0) or grouped:
        kind_l, k_l, pmf_l = pick_light(lights, u_pick)
        if step > 0.0 and cos_g > 0.0:
            p_vertex = light_vertex_density(lights, kind_l, k_l, pmf_l) * cos_g / step
        if grouped:
            group = light_group(lights, kind_l, k_l)
    w, w_without = 1.0, 1.0
    if pdf_light > 0.0:
        w = power_heuristic3(pdf_light, pdf, p_vertex)
        w_without = power_heuristic3(pdf_light, pdf, 0.0)
    light = mul(vmul(vmul(beta, color), weight), scale)
    return deliver_light(shadows, n_shadow, radiance, without, path, mul(light, w),
                         mul(light, w_without), flags, offset_origin(p, ng_f, eps, wi), wi,
                         target, infinite, limit, group)


@jit_inline
def connect_to_light_vertex(lights, shadows, n_shadow, lv, path, beta, p, ng_f, ns_f, eps, kind,
                            albedo, lobes, count, view, stats):
    """Connect vertex p of this surface kind to its path's light vertex (light_vertices.py):
    evaluate the surface towards it and queue the shadow ray. Returns the new shadow-ray
    count."""
    wl, d2 = direction_to(lv, path, p)
    color, scale, pdf, valid = evaluate_surface(kind, albedo, lobes, count, view, ns_f, ng_f, wl,
                                                lit_events(VISIBLE_ANY_BSDF), False)
    if not valid:
        return n_shadow
    # The group here, where the lights' tables are inlined: passed to a call that is not, they
    # would be copied array by array.
    return connect_light_vertex(shadows, n_shadow, lv, path, beta, p, ng_f, eps, wl, d2,
                                mul(color, scale), pdf, stats,
                                emitter_group(lights, lv.lamp[path]))


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
def add_light(radiance, path, contribution):
    """radiance[path] += contribution."""
    for k in range(3):
        radiance[path, k] += contribution[k]


@jit
def deliver_light(shadows, n_shadow, radiance, without, path, light, light_without, flags,
                  origin, wi, target, infinite, limit, group):
    """A light sample's contribution (light_without: its share without light vertices, for
    `without` as in wavefront.emitters): behind a shadow ray from origin (queued as ray
    n_shadow), or added at once, clamped to `limit` (path_limits), for a lamp that casts no
    shadow (lights.codes flags); `group` is the light's light group (light_groups.py). Returns
    the new shadow-ray count."""
    if flags & CASTS_SHADOW:
        store(shadows.contrib, n_shadow, light)
        store(shadows.without, n_shadow, light_without)
        shadows.pass_direct[n_shadow] = 1     # direct light, if cast from the first hit
        if radiance.shape[1] > 3:             # the render makes light groups
            shadows.group[n_shadow] = group
        queue_shadow(shadows, n_shadow, path, origin, wi, target, infinite)
        return n_shadow + 1
    add_grouped(radiance, path, group, clamp_light(light, limit))
    if without.shape[0] > 0:
        add_light(without, path, clamp_light(light_without, limit))
    return n_shadow


@jit
def connect_light_vertex(shadows, n_shadow, lv, path, beta, p, ng_f, eps, w, d2, f_cos, pdf,
                         stats, group):
    """Queue the connection of a camera vertex p (throughput beta, BSDF x cosine f_cos and
    density pdf towards its light vertex along w, at squared distance d2; `group` its emitter's
    light group) as shadow ray n_shadow; returns the new shadow-ray count."""
    light = connection(lv, path, w, d2, f_cos, pdf)
    if not max3(light) > 0.0:
        return n_shadow
    store(shadows.contrib, n_shadow, vmul(beta, light))
    store(shadows.without, n_shadow, (0.0, 0.0, 0.0))
    shadows.pass_direct[n_shadow] = 0     # light that bounced at least once more: indirect
    shadows.group[n_shadow] = group
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
