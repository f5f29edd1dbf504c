"""Blender's light objects as Cycles renders them: area, point, spot and sun lamps.

Facts and formulas from Cycles 5.0 (src/kernel/light/{area,point,spot,distant}.h and
scene/light.cpp), each held against a Cycles render (docs/lights.md):

- Every lamp emits a constant radiance (no cosine factor) and has no surface: rays that cross it
  add its light and go on, shadow rays pass it.
- Area: a one-sided rectangle or ellipse emitting along its local -Z. A spread below 180 degrees
  scales the radiance leaving at angle theta from the normal by max((tan a - tan theta) K, 0),
  a = spread / 2, K = 1 / (tan a - a) (3 / a^3 for a <= 0.05), which keeps the power; spread 0 is
  a collimated beam.
- Point and spot with radius r > 0: a sphere of radius r (soft falloff off) or, by default, a
  disk of radius r that faces the shading point (or the ray's origin), of radiance
  I / (pi r^2); radius 0 is a point of intensity I. A spot multiplies by
  smoothstep((z - cos(size / 2)) / ((1 - cos(size / 2)) blend)), z the cosine to its axis in the
  light's own (scaled) frame, so non-uniform scale makes the cone elliptical; rays hit a spot
  only on their way towards its centre.
- Sun with angle > 0: a disc of half-angle alpha = angle / 2 and radiance E / (pi sin^2 alpha),
  sampled uniformly in its cone; angle 0 is a direction.

The functions read the lamps' rows of the scene's light tables (lights.Lights). Each sampler
returns the light's value and its solid-angle density; a density of 0 marks a delta light, whose
value is then the irradiance it gives at normal incidence (zero where the light does not reach).
"""
from __future__ import annotations

import math

import numpy as np

from .jit import jit, jit_inline
from .sampling import (area_to_solid_angle, one_minus_cos_from_sin2, orthonormal_basis,
                       sample_cosine_hemisphere, sample_uniform_cone, sample_uniform_disk)
from .vec import add, dot, madd, mat_vec, mul, normalize, row, sub

# Per-lamp flags: which rays see the lamp, whether its light samples cast shadows, and whether
# BSDF-sampled rays find it (Cycles' "multiple importance" option; without it a lamp lights by
# light samples only and only camera rays see it).
VISIBLE_CAMERA, VISIBLE_DIFFUSE, VISIBLE_GLOSSY, VISIBLE_TRANSMISSION = 1, 2, 4, 8
CASTS_SHADOW, USES_MIS = 16, 32
ZERO = (0.0, 0.0, 0.0)


@jit
def seen_by(flags, ray_kind):
    """Whether a ray of this kind (a VISIBLE_* flag) sees a lamp with these flags: camera rays
    only need the lamp to be visible to the camera, other rays also need its MIS option."""
    if not flags & ray_kind:
        return False
    return ray_kind == VISIBLE_CAMERA or (flags & USES_MIS) != 0


# -- area lamps ---------------------------------------------------------------------------------

@jit_inline
def spread_attenuation(lights, lamp, cos_theta):
    """The spread's factor on the radiance leaving area lamp `lamp` at cos_theta to its normal."""
    tan_spread = lights.area_spread_tan[lamp]
    if tan_spread == np.inf:
        return 1.0
    if not cos_theta > 0.0:
        return 0.0
    tan_theta = math.sqrt(max(1.0 - cos_theta * cos_theta, 0.0)) / cos_theta
    if tan_spread == 0.0:
        return math.pi if tan_theta <= 1e-5 else 0.0
    return max((tan_spread - tan_theta) * lights.area_spread_norm[lamp], 0.0)


@jit_inline
def area_lamp_point(lights, lamp, u0, u1):
    """A uniform point on area lamp `lamp`."""
    if lights.area_ellipse[lamp]:
        x, y = sample_uniform_disk(u0, u1)
    else:
        x, y = 2.0 * u0 - 1.0, 2.0 * u1 - 1.0
    x *= lights.area_half[lamp, 0]
    y *= lights.area_half[lamp, 1]
    return madd(madd(row(lights.area_center, lamp), x, row(lights.area_ex, lamp)),
                y, row(lights.area_ey, lamp))


@jit_inline
def sample_area_lamp(lights, lamp, p, u0, u1):
    """A point on area lamp `lamp` seen from p: (point, radiance towards p, solid-angle density;
    density 0 with the irradiance at normal incidence for a collimated (spread 0) lamp)."""
    emit = row(lights.area_emit, lamp)
    radiance = row(lights.area_radiance, lamp)
    if lights.area_spread_tan[lamp] == 0.0:
        # A collimated beam reaches p only from the foot of the perpendicular, if it is on the
        # lamp: irradiance pi L at normal incidence (Cycles: the power over the area).
        center = row(lights.area_center, lamp)
        height = dot(emit, sub(p, center))
        foot = madd(p, -height, emit)
        if height > 0.0 and inside_area_lamp(lights, lamp, sub(foot, center)):
            return foot, mul(radiance, math.pi), 0.0
        return p, ZERO, 0.0
    point = area_lamp_point(lights, lamp, u0, u1)
    density = area_to_solid_angle(point, p, emit, lights.area_area[lamp], False)
    if density == 0.0:             # p is behind the lamp
        return point, ZERO, 0.0
    to_p = normalize(sub(p, point))
    att = spread_attenuation(lights, lamp, dot(to_p, emit))
    return point, mul(radiance, att), density


@jit_inline
def inside_area_lamp(lights, lamp, q):
    """Whether q (relative to the lamp's centre, in its plane) lies on area lamp `lamp`."""
    a = dot(row(lights.area_ex, lamp), q) / lights.area_half[lamp, 0]
    b = dot(row(lights.area_ey, lamp), q) / lights.area_half[lamp, 1]
    if lights.area_ellipse[lamp]:
        return a * a + b * b <= 1.0
    return abs(a) <= 1.0 and abs(b) <= 1.0


@jit_inline
def intersect_area_lamp(lights, lamp, o, d):
    """Distance along o + t d at which the ray crosses area lamp `lamp` from its front, or -1."""
    emit = row(lights.area_emit, lamp)
    denom = dot(emit, d)
    if not denom < 0.0:            # the ray must travel against the emission direction
        return -1.0
    center = row(lights.area_center, lamp)
    t = dot(emit, sub(center, o)) / denom
    if not t > 0.0:
        return -1.0
    return t if inside_area_lamp(lights, lamp, sub(madd(o, t, d), center)) else -1.0


@jit_inline
def area_lamp_hit(lights, lamp, d, t):
    """(radiance, solid-angle density of sample_area_lamp) where the ray direction d crossed
    area lamp `lamp` at distance t."""
    emit = row(lights.area_emit, lamp)
    cos_l = -dot(d, emit)
    if not cos_l > 0.0:
        return ZERO, 0.0
    att = spread_attenuation(lights, lamp, cos_l)
    return mul(row(lights.area_radiance, lamp), att), t * t / (lights.area_area[lamp] * cos_l)


# -- point and spot lamps -----------------------------------------------------------------------

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
    radiance = mul(intensity, 1.0 / (math.pi * r * r))
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
    radiance = mul(row(lights.point_intensity, lamp), 1.0 / (math.pi * r * r))
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


# -- suns ---------------------------------------------------------------------------------------

@jit_inline
def sample_sun(lights, sun, u0, u1):
    """A direction to sun `sun`: (direction, radiance, solid-angle density; density 0 with the
    irradiance for a sun of angle 0)."""
    towards = mul(row(lights.sun_dir, sun), -1.0)
    one_minus_cos = lights.sun_one_minus_cos[sun]
    if one_minus_cos == 0.0:
        return towards, row(lights.sun_irradiance, sun), 0.0
    wi, density = sample_uniform_cone(towards, one_minus_cos, u0, u1)
    return wi, row(lights.sun_radiance, sun), density


@jit_inline
def sun_hit(lights, sun, d):
    """(radiance, solid-angle density of sample_sun) for an escaped ray of direction d; no light
    outside the sun's disc or from a sun of angle 0."""
    one_minus_cos = lights.sun_one_minus_cos[sun]
    if one_minus_cos == 0.0 or -dot(d, row(lights.sun_dir, sun)) < 1.0 - one_minus_cos:
        return ZERO, 0.0
    return row(lights.sun_radiance, sun), 1.0 / (2.0 * math.pi * one_minus_cos)
