"""The one place that switches on a light's kind: pick a light, then its sample, density, hit
and emission from its kind's module (triangles, area, point, sun, world).

`sample_light` serves next-event estimation; a light's `*_hit` function (area.py, point.py,
sun.py; pdf_triangle, pdf_world) and the pick probability give the density of the same light
found by a BSDF-sampled ray, for multiple importance sampling. The light tracer (light_tracer.py)
and light vertices (light_vertices.py) start their paths with the emission functions below.
"""
from __future__ import annotations

import numpy as np

from ..jit import jit_inline
from ..sampling import sample_cosine_hemisphere
from ..vec import mul, neg, normalize, row, sub
from .area import (area_lamp_emitted, area_lamp_hit, area_lamp_point, emit_area_lamp,
                   sample_area_lamp)
from .codes import AREA, CASTS_SHADOW, EMISSIVE_TRIANGLE, POINT, SUN, USES_MIS, ZERO
from .point import emit_point_lamp, sample_point_lamp
from .sun import sample_sun
from .triangles import (emit_triangle, lift_off_triangle, pdf_triangle, triangle_light_point,
                        triangle_point)
from .world import sample_world


@jit_inline
def pick_light(lights, u):
    """The light of the distribution that u in [0, 1) picks: (kind, row, probability)."""
    cdf = lights.cdf
    k = min(np.searchsorted(cdf, u * cdf[-1], side="right"), cdf.shape[0] - 1)
    return lights.kind[k], lights.index[k], lights.pmf[k]


@jit_inline
def sample_light(lights, mesh, p, n, vertex_kind, u_pick, u0, u1):
    """Sample one light for next-event estimation at p (shading normal n) of a vertex whose
    scattering is of vertex_kind (a codes.VISIBLE_* flag): u_pick picks the light, (u0, u1) the
    point on it.

    Returns (unit direction to the light, the point to aim the shadow ray at, whether the light
    is at infinity, radiance / pdf, pdf in solid angle for MIS (0 for delta lights and lamps
    without MIS), the light's codes.* flags: its visibility to each kind of ray, and whether it
    casts shadows). A zero weight means no light: lamps that no kind in vertex_kind sees give
    none.
    """
    kind, i, pmf = pick_light(lights, u_pick)
    flags = CASTS_SHADOW | USES_MIS | vertex_kind
    wi, infinite = ZERO, False
    if kind == EMISSIVE_TRIANGLE:
        point, density = triangle_light_point(lights, i, p, u0, u1)
        value = row(lights.tri_radiance, i) if density > 0.0 else ZERO
    elif kind == AREA:
        flags = lights.area_flags[i]
        point, value, density = sample_area_lamp(lights, i, p, u0, u1)
    elif kind == POINT:
        flags = lights.point_flags[i]
        point, value, density = sample_point_lamp(lights, i, p, n, u0, u1)
    elif kind == SUN:
        flags = lights.sun_flags[i]
        wi, value, density = sample_sun(lights, i, u0, u1)
        point, infinite = p, True
    else:
        wi, value, density = sample_world(lights, u0, u1)
        point, infinite = p, True
    if not flags & vertex_kind:
        return (0.0, 0.0, 1.0), p, True, ZERO, 0.0, 0
    if not infinite:
        wi = normalize(sub(point, p))
    if kind == EMISSIVE_TRIANGLE and density > 0.0:
        # Lift the light point off its triangle towards the shading point, as hit points are
        # lifted: a shadow ray that ends on the triangle's plane can hit the light itself
        # (grazing rays to a lamp just under a ceiling did, darkening the ceiling).
        point = lift_off_triangle(lights, mesh, i, point, row(lights.tri_normal, i),
                                  mul(wi, -1.0))
    if density == 0.0:             # a delta light: value is the irradiance
        return wi, point, infinite, mul(value, 1.0 / pmf), 0.0, flags
    pdf = pmf * density
    if not pdf > 0.0:
        return (0.0, 0.0, 1.0), p, True, ZERO, 0.0, 0
    mis_pdf = pdf if flags & USES_MIS else 0.0
    return wi, point, infinite, mul(value, 1.0 / pdf), mis_pdf, flags


# -- emission -----------------------------------------------------------------------------------

@jit_inline
def emission_anchor(lights, kind, i, u0, u1):
    """Where the light tracer aims a path of light i (an emissive triangle, area lamp, or point
    or spot lamp of radius > 0) from, and the margin its aim needs: (a point uniform on the
    triangle or area lamp, 0), or (the point lamp's centre, its radius: emit_point_lamp then
    picks the line across the direction)."""
    if kind == EMISSIVE_TRIANGLE:
        return triangle_point(lights, i, u0, u1), 0.0
    if kind == AREA:
        return area_lamp_point(lights, i, u0, u1), 0.0
    return row(lights.point_pos, i), lights.point_radius[i]


@jit_inline
def emit_along(lights, mesh, kind, i, y, w, density, u0, u1):
    """A light path of light i (as for emission_anchor) from anchor y along w, drawn with
    solid-angle density `density`: (origin, radiance x measure / density, pick excluded)."""
    if kind == EMISSIVE_TRIANGLE:
        return emit_triangle(lights, mesh, i, y, w, density)
    if kind == AREA:
        return emit_area_lamp(lights, i, y, w, density)
    return emit_point_lamp(lights, i, w, density, u0, u1)


@jit_inline
def light_vertex_ray(lights, mesh, kind, i, u_side, u0, u1, v0, v1):
    """A ray leaving emissive triangle or area lamp i in a cosine-weighted direction (a
    triangle's face picked by u_side, (u0, u1) the point, (v0, v1) the direction): (origin,
    the normal of the face it leaves, direction, radiance along it, the emitter's id: the mesh
    triangle, or -1 - the area lamp)."""
    if kind == EMISSIVE_TRIANGLE:
        y = triangle_point(lights, i, u0, u1)
        normal = row(lights.tri_normal, i)
        if u_side >= 0.5:
            normal = neg(normal)
        w, _ = sample_cosine_hemisphere(normal, v0, v1)
        y = lift_off_triangle(lights, mesh, i, y, normal, w)
        return y, normal, w, row(lights.tri_radiance, i), lights.tri_prim[i]
    y = area_lamp_point(lights, i, u0, u1)
    normal = row(lights.area_emit, i)
    w, _ = sample_cosine_hemisphere(normal, v0, v1)
    return y, normal, w, area_lamp_emitted(lights, i, w), -1 - i


@jit_inline
def emitter_density(lights, emitter, p, w, dist):
    """The solid-angle density with which next-event estimation at p picks the point at
    distance dist along w on `emitter` (a mesh triangle, or -1 - an area lamp)."""
    if emitter >= 0:
        return pdf_triangle(lights, emitter, p, w, dist)
    k = -1 - emitter
    return lights.area_pmf[k] * area_lamp_hit(lights, k, w, dist)[1]
