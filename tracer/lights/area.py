"""Blender's area lamps as Cycles renders them (src/kernel/light/area.h, scene/light.cpp).

An area lamp is a one-sided rectangle or ellipse emitting a constant radiance (no cosine factor)
along its local -Z, and has no surface: rays that cross it add its light and go on, shadow rays
pass it. A spread below 180 degrees scales the radiance leaving at angle theta from the normal
by max((tan a - tan theta) K, 0), a = spread / 2, K = 1 / (tan a - a) (3 / a^3 for a <= 0.05),
which keeps the power; spread 0 is a collimated beam. Each fact is held against a Cycles render
(docs/lights.md). The functions read the lamps' rows of the light tables (tables.Lights).
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import jit_inline
from ..sampling import area_to_solid_angle, sample_uniform_disk
from ..vec import dot, madd, mul, normalize, row, sub
from .codes import ZERO


def spread_constants(spread: float) -> tuple[float, float]:
    """(tan(spread / 2), K) of an area lamp's spread in radians (Cycles' scene/light.cpp)."""
    half = 0.5 * max(spread, 0.0)
    if spread >= math.pi * (1.0 - 1e-6):     # 180 degrees (Blender stores pi in float32)
        return math.inf, 1.0
    tan_half = math.tan(half)
    if half <= 0.0:
        return 0.0, math.inf
    # K = 1 / (tan a - a), from integrating cos x (1 - tan x / tan a) sin x over [0, a]; its
    # third-order Taylor form where tan a - a cancels.
    return tan_half, (1.0 / (tan_half - half) if half > 0.05 else 3.0 / half ** 3)


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


# -- emission (the light tracer and light vertices) ---------------------------------------------

@jit_inline
def area_lamp_emitted(lights, lamp, w):
    """The radiance leaving area lamp `lamp` in the unit direction w (zero behind it)."""
    return mul(row(lights.area_radiance, lamp),
               spread_attenuation(lights, lamp, dot(w, row(lights.area_emit, lamp))))


@jit_inline
def emit_area_lamp(lights, lamp, y, w, density):
    """A light path leaving point y of area lamp `lamp` along w, drawn with solid-angle density
    `density` (its point uniform in area): (origin, radiance x cos x area / density)."""
    cos_y = dot(w, row(lights.area_emit, lamp))
    if not cos_y > 0.0:
        return y, ZERO
    att = spread_attenuation(lights, lamp, cos_y)
    return y, mul(row(lights.area_radiance, lamp), att * cos_y * lights.area_area[lamp] / density)
