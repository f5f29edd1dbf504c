"""Blender's point and spot lamps as Cycles renders them (src/kernel/light/{point,spot}.h).

With radius r > 0 a point lamp is a sphere of radius r (soft falloff off) or, by default, a disk
of radius r that faces the shading point (or the ray's origin), of radiance I / (pi r^2); radius
0 is a point of intensity I (a delta lamp: no ray finds it, and only the light tracer renders its
light through mirrors and glass). A spot multiplies by smoothstep((z - cos(size / 2)) / ((1 -
cos(size / 2)) blend)), z the cosine to its axis in the light's own (scaled) frame, so
non-uniform scale makes the cone elliptical; rays hit a spot only on their way towards its
centre. Like every lamp it has no surface: rays that cross it add its light and go on. The
functions read the lamps' rows of the light tables (tables.Lights).
"""
from __future__ import annotations

import math

from ..jit import jit_inline
from ..sampling import (one_minus_cos_from_sin2, orthonormal_basis, sample_cosine_hemisphere,
                        sample_uniform_cone, sample_uniform_disk)
from ..vec import add, dot, madd, mat_vec, mul, normalize, row, sub
from .codes import ZERO


@jit_inline
def point_lamp_radiance(lights, lamp):
    """The radiance I / (pi r^2) of point or spot lamp `lamp`'s sphere or disk (radius r > 0)."""
    r = lights.point_radius[lamp]
    return mul(row(lights.point_intensity, lamp), 1.0 / (math.pi * r * r))


@jit_inline
def spot_attenuation(lights, lamp, w):
    """The spot cone's factor for light leaving lamp `lamp` in the unit direction w (1 for point
    lamps)."""
    if not lights.point_spot[lamp]:
        return 1.0
    m = lights.point_inverse[lamp]
    local = normalize(mat_vec(m, w))
    x = (-local[2] - lights.point_cos_half[lamp]) * lights.point_smooth[lamp]
    if not x > 0.0:              # also NaN: blend 0 exactly on the cone's edge
        return 0.0
    if x >= 1.0:
        return 1.0
    return x * x * (3.0 - 2.0 * x)


@jit_inline
def sample_point_lamp(lights, lamp, p, n, u0, u1):
    """A point on point or spot lamp `lamp` seen from p (shading normal n): (point, radiance
    towards p, solid-angle density; density 0 with I / d^2 for radius 0)."""
    c = row(lights.point_pos, lamp)
    r = lights.point_radius[lamp]
    intensity = row(lights.point_intensity, lamp)
    to_p = sub(p, c)
    d2 = dot(to_p, to_p)
    d = math.sqrt(d2)
    light_n = mul(to_p, 1.0 / d)
    if r == 0.0:
        att = spot_attenuation(lights, lamp, light_n)
        return c, mul(intensity, att / d2), 0.0
    radiance = point_lamp_radiance(lights, lamp)
    if not lights.point_sphere[lamp]:
        # The disk of radius r facing p, sampled uniformly in area.
        x, y = sample_uniform_disk(u0, u1)
        t_axis, s_axis = orthonormal_basis(light_n)
        point = add(c, add(mul(t_axis, x * r), mul(s_axis, y * r)))
        to_light = sub(point, p)
        dist2 = dot(to_light, to_light)
        wi = mul(to_light, 1.0 / math.sqrt(dist2))
        cos_l = -dot(light_n, wi)
        if not cos_l > 0.0:
            return point, ZERO, 0.0
        att = spot_attenuation(lights, lamp, mul(wi, -1.0))
        return point, mul(radiance, att), dist2 / (math.pi * r * r * cos_l)
    if d2 > r * r:
        # Outside the sphere: directions uniform in the cone it subtends.
        one_minus_cos = one_minus_cos_from_sin2(r * r / d2)
        wi, density = sample_uniform_cone(mul(light_n, -1.0), one_minus_cos, u0, u1)
        cos_t = -dot(wi, light_n)
        t = d * cos_t - math.sqrt(max(r * r - d2 + d2 * cos_t * cos_t, 0.0))
        att = spot_attenuation(lights, lamp, mul(wi, -1.0))
    else:
        # Inside: every direction meets the sphere; cosine-weighted about the normal. No cone.
        wi, density = sample_cosine_hemisphere(n, u0, u1)
        cos_t = -dot(wi, light_n)
        t = d * cos_t + math.sqrt(max(r * r - d2 + d2 * cos_t * cos_t, 0.0))
        att = 1.0
    # Snap the point onto the sphere (a small radius loses precision along the ray).
    point = madd(c, r, normalize(sub(madd(p, t, wi), c)))
    return point, mul(radiance, att), density


@jit_inline
def intersect_point_lamp(lights, lamp, o, d):
    """Distance along o + t d to point or spot lamp `lamp` (its sphere, or its disk facing o), or
    -1; spots only on the ray's way towards their centre; radius 0 is never hit."""
    r = lights.point_radius[lamp]
    if r == 0.0:
        return -1.0
    c = row(lights.point_pos, lamp)
    to_c = sub(c, o)
    along = dot(to_c, d)
    if lights.point_spot[lamp] and not along > 0.0:
        return -1.0
    d2 = dot(to_c, to_c)
    if lights.point_sphere[lamp]:
        if d2 > r * r and along < 0.0:
            return -1.0
        # Distance from the centre to the ray's closest point, without cancellation.
        closest = sub(to_c, mul(d, along))
        miss2 = dot(closest, closest)
        if miss2 > r * r:
            return -1.0
        half = math.sqrt(r * r - miss2)
        t = along - half if d2 > r * r else along + half
        return t if t > 0.0 else -1.0
    # The disk through c facing o: the ray meets its plane at t = |c - o|^2 / (c - o) . d.
    if not along > 0.0:
        return -1.0
    t = d2 / along
    q = sub(madd(o, t, d), c)
    return t if dot(q, q) <= r * r else -1.0


@jit_inline
def point_lamp_hit(lights, lamp, o, d, t, pdf_bsdf):
    """(radiance, solid-angle density of sample_point_lamp) where the ray o + t d met point or
    spot lamp `lamp`. Inside a sphere lamp the light sample is cosine-weighted about the shading
    normal, the same lobe a diffuse vertex samples: its density is the BSDF's, pdf_bsdf."""
    c = row(lights.point_pos, lamp)
    r = lights.point_radius[lamp]
    radiance = point_lamp_radiance(lights, lamp)
    from_c = sub(o, c)
    d2 = dot(from_c, from_c)
    if lights.point_sphere[lamp]:
        if d2 <= r * r:
            return radiance, pdf_bsdf
        att = spot_attenuation(lights, lamp, mul(d, -1.0))
        return mul(radiance, att), 1.0 / (2.0 * math.pi * one_minus_cos_from_sin2(r * r / d2))
    disk_n = mul(from_c, 1.0 / math.sqrt(d2))
    cos_l = -dot(disk_n, d)
    att = spot_attenuation(lights, lamp, mul(d, -1.0))
    return mul(radiance, att), t * t / (math.pi * r * r * cos_l)


# -- emission (the light tracer) ----------------------------------------------------------------

@jit_inline
def emit_point_lamp(lights, lamp, w, density, u0, u1):
    """A light path of direction w (drawn from the centre with solid-angle density `density`)
    leaving point or spot lamp `lamp` on a line through the disk of radius r across w ((u0, u1)
    picks the point): (origin, radiance x area / density). It starts where the light leaves: the
    disk's centre plane, or the sphere's far side.

    Radius 0 is a delta lamp: its radiance is I(w) delta(y - c) (delta in area, I(w) = I x the
    spot factor), so the point is c with probability one and the path carries I(w) / density,
    the limit of the disk's (I(w) / (pi r^2)) pi r^2 / density; over directions it carries the
    lamp's power, the integral of I(w)."""
    c = row(lights.point_pos, lamp)
    r = lights.point_radius[lamp]
    if r == 0.0:
        att = spot_attenuation(lights, lamp, w)
        return c, mul(row(lights.point_intensity, lamp), att / density)
    x, y2 = sample_uniform_disk(u0, u1)
    t_axis, s_axis = orthonormal_basis(w)
    q = add(c, add(mul(t_axis, x * r), mul(s_axis, y2 * r)))
    att = spot_attenuation(lights, lamp, w)
    rho2 = (x * x + y2 * y2) * r * r
    origin = q if not lights.point_sphere[lamp] else madd(q, math.sqrt(max(r * r - rho2, 0.0)), w)
    radiance = mul(row(lights.point_intensity, lamp), att / (math.pi * r * r))
    return origin, mul(radiance, math.pi * r * r / density)
