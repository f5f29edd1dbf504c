"""Warps from uniform numbers to directions and points, with their densities.

Directions are unit vectors (tuples, see vec.py); each sampler's density is in solid angle unless
it says otherwise. Used by the BSDFs, the lights and the camera.
"""
from __future__ import annotations

import math

from .jit import jit
from .vec import add, dot, mul, sub


@jit
def orthonormal_basis(n):
    """Two unit tangents completing the unit normal n (Duff et al. 2017, branchless)."""
    sign = 1.0 if n[2] >= 0.0 else -1.0
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    return ((1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]),
            (b, sign + n[1] * n[1] * a, -n[1]))


@jit
def sample_cosine_hemisphere(n, u0, u1):
    """A cosine-weighted direction around the unit normal n and its density (cos / pi)."""
    r = math.sqrt(u0)
    phi = 2.0 * math.pi * u1
    z = math.sqrt(max(0.0, 1.0 - u0))
    t, s = orthonormal_basis(n)
    return add(add(mul(t, r * math.cos(phi)), mul(s, r * math.sin(phi))), mul(n, z)), z / math.pi


@jit
def sample_uniform_sphere(u0, u1):
    """A uniform direction on the unit sphere (density 1 / 4 pi)."""
    z = 1.0 - 2.0 * u0
    r = math.sqrt(max(0.0, 1.0 - z * z))
    phi = 2.0 * math.pi * u1
    return (r * math.cos(phi), r * math.sin(phi), z)


@jit
def sample_uniform_disk(u0, u1):
    """A uniform point (x, y) on the unit disk (concentric mapping, so strata stay compact)."""
    a = 2.0 * u0 - 1.0
    b = 2.0 * u1 - 1.0
    if a == 0.0 and b == 0.0:
        return 0.0, 0.0
    if abs(a) > abs(b):
        r, theta = a, (math.pi / 4.0) * (b / a)
    else:
        r, theta = b, math.pi / 2.0 - (math.pi / 4.0) * (a / b)
    return r * math.cos(theta), r * math.sin(theta)


@jit
def sample_regular_polygon(u0, u1, blades, rotation):
    """A uniform point (x, y) in a regular polygon inscribed in the unit circle,
    as Cycles' aperture."""
    corner = math.floor(u0 * blades)
    s = math.sqrt(u0 * blades - corner)
    v = u1 * s
    a = 1.0 - s
    half = math.pi / blades
    px, py = (a + v) * math.cos(half), (a - v) * math.sin(half)
    rot = rotation + corner * 2.0 * math.pi / blades
    c, sn = math.cos(rot), math.sin(rot)
    return c * px - sn * py, sn * px + c * py


@jit
def power_heuristic(a, b):
    """MIS weight of strategy a against b (both densities in solid angle)."""
    return power_heuristic3(a, b, 0.0)


@jit
def power_heuristic3(a, b, c):
    """MIS weight of strategy a against b and c (densities in one measure)."""
    a2, rest = a * a, b * b + c * c
    return a2 / (a2 + rest) if a2 + rest > 0.0 else 0.0


@jit
def one_minus_cos_from_sin2(sin2):
    """1 - cos(x) for an angle x in [0, pi/2] given sin(x)^2, without cancellation."""
    return sin2 / (1.0 + math.sqrt(max(1.0 - sin2, 0.0)))


@jit
def sample_uniform_cone(axis, one_minus_cos, u0, u1):
    """A direction uniform in the cone of unit axis `axis` and half-angle x, given 1 - cos(x),
    and its density 1 / (2 pi (1 - cos x))."""
    v = u0 * one_minus_cos
    cos_t = 1.0 - v
    sin_t = math.sqrt(max(v * (2.0 - v), 0.0))
    phi = 2.0 * math.pi * u1
    t, s = orthonormal_basis(axis)
    d = add(add(mul(t, sin_t * math.cos(phi)), mul(s, sin_t * math.sin(phi))), mul(axis, cos_t))
    return d, 1.0 / (2.0 * math.pi * one_minus_cos)


@jit
def area_to_solid_angle(point, q, normal, area, two_sided):
    """Solid-angle density at q of uniform points on an emitter of this area and normal."""
    to = sub(point, q)
    d2 = dot(to, to)
    cos_l = -dot(to, normal) / math.sqrt(d2)
    cos_l = abs(cos_l) if two_sided else max(cos_l, 0.0)
    return d2 / (area * cos_l) if cos_l > 0.0 else 0.0
