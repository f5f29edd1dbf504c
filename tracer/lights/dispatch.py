"""The one place that switches on a light's kind: pick a light, then its sample, density, hit
and emission from its kind's module (triangles, area, point, sun, world).

`sample_light` serves next-event estimation. What a BSDF-sampled ray finds (wavefront.emitters)
is here too: `lamp_crossed` for the lamps a ray crosses, `light_at_escape` for the world and suns
an escaped ray sees, `triangle_hit` for an emissive triangle it hits, each with the densities the
other strategies give the same light, for multiple importance sampling. The light tracer
(light_tracer.py: `starts_light_paths`, `light_seen`) and light vertices (light_vertices.py:
`light_vertex_density`) start their paths with the emission functions below.
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import jit_inline
from ..sampling import sample_cosine_hemisphere
from ..vec import madd, mul, neg, normalize, row, sub
from .area import (area_lamp_emitted, area_lamp_hit, area_lamp_point, emit_area_lamp,
                   intersect_area_lamp, sample_area_lamp)
from .codes import (AREA, CASTS_SHADOW, EMISSIVE_TRIANGLE, POINT, STARTS_LIGHT_VERTICES, SUN,
                    USES_MIS, ZERO, seen_by)
from .point import emit_point_lamp, intersect_point_lamp, point_lamp_hit, sample_point_lamp
from .sun import sample_sun, sun_hit
from .triangles import (emit_triangle, lift_off_triangle, pdf_triangle, triangle_light_point,
                        triangle_point)
from .world import environment_peak, pdf_world, sample_world, world_radiance

# The world starts light paths when its luminance's second moment over the sphere is at least
# this times its squared mean (world.environment_peak): below it the path tracer renders the
# world's caustics with less noise. Measured on a glass sphere over a floor (24x24, 512 spp,
# tests/render/test_caustics_world.py): the caustic region's variance x time of the path tracer
# over the hybrid's was 0.03 for a uniform world (peak 1), 0.23 for the test sky without its sun
# (1.6), 0.81 with a sun of peak 20 (2.7) and 17 with one of peak 200 (52).
WORLD_PEAK = 8.0


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


# -- what a BSDF-sampled ray finds (wavefront.emitters) -----------------------------------------

@jit_inline
def lamps_to_cross(lights):
    """How many lamps a ray may cross (area lamps, then point and spot lamps): lamp_crossed's
    range."""
    return lights.area_area.shape[0] + lights.point_radius.shape[0]


@jit_inline
def lamp_crossed(lights, lamp, o, d, t_surface, ray_kind, pdf_bsdf, connect, mis_t):
    """Whether the ray o + t d of kind ray_kind (a codes.VISIBLE_* flag), sampled with density
    pdf_bsdf, crosses lamp `lamp` (of lamps_to_cross) before t_surface, and what it gets there:
    (crossed, radiance, pick x density of next-event estimation, the light vertex's density:
    connect per unit of light_vertex_density, 0 for lamps that start no light vertices).
    mis_t: how far the ray went before o, unbent, since the vertex that sampled it (through
    transparent surfaces): the densities are that vertex's."""
    n_area = lights.area_area.shape[0]
    if lamp < n_area:
        if not seen_by(lights.area_flags[lamp], ray_kind):
            return False, ZERO, 0.0, 0.0
        t_lamp = intersect_area_lamp(lights, lamp, o, d)
        if not 0.0 < t_lamp < t_surface:
            return False, ZERO, 0.0, 0.0
        light, density = area_lamp_hit(lights, lamp, d, t_lamp + mis_t)
        q = light_vertex_density(lights, AREA, lamp, lights.area_pmf[lamp])
        return True, light, lights.area_pmf[lamp] * density, q * connect
    k = lamp - n_area
    if not seen_by(lights.point_flags[k], ray_kind):
        return False, ZERO, 0.0, 0.0
    t_lamp = intersect_point_lamp(lights, k, o, d)
    if not 0.0 < t_lamp < t_surface:
        return False, ZERO, 0.0, 0.0
    light, density = point_lamp_hit(lights, k, madd(o, -mis_t, d), d, t_lamp + mis_t, pdf_bsdf)
    return True, light, lights.point_pmf[k] * density, 0.0


@jit_inline
def crosses_a_lamp(lights, o, d, ray_kind):
    """Whether the ray o + t d of kind ray_kind crosses any lamp (lamp_crossed's, however far)."""
    for lamp in range(lamps_to_cross(lights)):
        if lamp_crossed(lights, lamp, o, d, np.inf, ray_kind, 0.0, 0.0, 0.0)[0]:
            return True
    return False


@jit_inline
def lights_at_escape(lights, world, lamps):
    """The lights a ray that escapes may see, as light_at_escape's range (first, end): the world
    (if it gives light) if `world`, then the suns if `lamps` (the light tracer's paths get
    neither, or the world only where the light tracer does not start paths on it)."""
    first = 0 if world or not lights.has_world else 1
    return first, (1 if lights.has_world else 0) + (lights.sun_one_minus_cos.shape[0] if lamps
                                                    else 0)


@jit_inline
def light_at_escape(lights, k, d, ray_kind):
    """What an escaped ray of direction d and kind ray_kind gets from light k (of
    lights_at_escape): (found, radiance, pick x density of next-event estimation)."""
    if lights.has_world:
        if k == 0:
            return True, world_radiance(lights, d), pdf_world(lights, d)
        k -= 1
    # Cycles finds a sun's disc only with its MIS option, camera rays included.
    flags = lights.sun_flags[k]
    if not (flags & ray_kind and flags & USES_MIS):
        return False, ZERO, 0.0
    light, density = sun_hit(lights, k, d)
    return True, light, lights.sun_pmf[k] * density


@jit_inline
def triangle_hit(lights, prim, o, d, t, connect):
    """The densities of the other strategies for the emissive mesh triangle prim that the ray
    o + t d hit: (next-event estimation's, the light vertex's: connect per unit of
    light_vertex_density)."""
    return pdf_triangle(lights, prim, o, d, t), triangle_density(lights, prim) * connect


# -- light vertices and the light tracer ----------------------------------------------------------

@jit_inline
def light_vertex_density(lights, kind, i, pmf):
    """q of light i of this kind (a codes kind) picked with probability pmf: the density of the
    light vertex's point on it (per area) times that of its direction (per cosine); 0 for the
    lights that start no light vertices (light_vertices.py)."""
    if kind == EMISSIVE_TRIANGLE:
        return pmf / lights.tri_area[i] * (0.5 / math.pi)      # cosine-weighted, either face
    if kind == AREA and lights.area_flags[i] & STARTS_LIGHT_VERTICES == STARTS_LIGHT_VERTICES \
            and lights.area_spread_tan[i] > 0.0:
        return pmf / lights.area_area[i] / math.pi
    return 0.0


@jit_inline
def triangle_density(lights, prim):
    """light_vertex_density of mesh triangle prim (0 where it is no light)."""
    if lights.tri_prim.shape[0] == 0 or lights.tri_pmf[prim] == 0.0:
        return 0.0
    return light_vertex_density(lights, EMISSIVE_TRIANGLE, lights.light_of_prim[prim],
                                lights.tri_pmf[prim])


def starts_light_paths(t, kind, i, centers, radii, pure) -> bool:
    """Whether the light tracer starts paths on light i of this kind (t: the Lights tables): a
    light whose light reaches mirrors and glass for the path tracer's BSDF-sampled rays (Cycles'
    MIS option), and for an area lamp one facing a specular object's bounding sphere (centers,
    radii) unless pure. Delta lamps (point and spot lamps of radius 0, suns of angle 0, area
    lamps of spread 0) start them too: no ray finds them, so the light tracer is the only
    technique that renders their light through mirrors and glass (with the MIS option off a
    lamp is not seen by glossy and transmission rays at all, delta or not, so it starts none).
    So does the world, which every kind of ray sees, if it gives light and, unless pure, its
    light is concentrated enough that camera paths find it through glass on rare paths only
    (world.environment_peak at least WORLD_PEAK)."""
    if kind == AREA:
        flags, ok = t.area_flags[i], True
        # A one-sided lamp with every specular object behind its plane lights none of them.
        ok &= pure or bool(np.any((centers - t.area_center[i]) @ t.area_emit[i] > -radii))
    elif kind == POINT:
        flags, ok = t.point_flags[i], True
    elif kind == SUN:
        flags, ok = t.sun_flags[i], True
    elif kind == EMISSIVE_TRIANGLE:
        flags, ok = USES_MIS, True
    else:                          # the world, which every kind of ray sees
        peak = environment_peak(t.env) if t.has_env else 1.0
        flags, ok = USES_MIS, bool(t.has_world) and (pure or peak >= WORLD_PEAK)
    return bool(ok and flags & USES_MIS)


def delta_lamp(t, kind, i) -> bool:
    """Whether light i of this kind (t: the Lights tables) is a delta lamp, which no ray finds:
    a point or spot lamp of radius 0, a sun of angle 0, an area lamp of spread 0."""
    return bool((kind == POINT and t.point_radius[i] == 0.0)
                or (kind == SUN and t.sun_one_minus_cos[i] == 0.0)
                or (kind == AREA and t.area_spread_tan[i] == 0.0))


@jit_inline
def light_seen(lights, kind, i, s1, w, ray_kind):
    """Whether the path tracer's ray of kind ray_kind from s1 back along a light path that left
    light i (a light starts_light_paths accepts) along w would find the light: its visibility to
    that kind of ray and, for point and spot lamps, the lamp's own shape seen from s1."""
    if kind == AREA:
        return (lights.area_flags[i] & ray_kind) != 0
    if kind == SUN:
        return (lights.sun_flags[i] & ray_kind) != 0
    if kind == POINT:
        if not lights.point_flags[i] & ray_kind:
            return False
        if lights.point_radius[i] == 0.0:
            return True            # a delta lamp: no shape; the light tracer alone renders it
        return intersect_point_lamp(lights, i, s1, neg(w)) > 0.0
    return True


# -- emission -----------------------------------------------------------------------------------

@jit_inline
def emission_anchor(lights, kind, i, u0, u1):
    """Where the light tracer aims a path of light i (an emissive triangle, area lamp, or point
    or spot lamp) from, and the margin its aim needs: (a point uniform on the
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
