"""Emissive triangles as lights: points sampled in the solid angle they subtend, near them.

Emissive triangles are sampled as Cycles samples them: uniformly in the solid angle they subtend
(Arvo 1995) when the shading point is near them (SOLID_ANGLE_RANGE), uniformly in area
otherwise. Area sampling of a lamp 1 cm under a ceiling gives the ceiling's points next to it
weights that grow as 1 / distance^2: fireflies that solid-angle sampling does not have.
The functions read the light triangles' rows of the scene's light tables (tables.Lights).
"""
from __future__ import annotations

import math

from ..geometry import hit_offset, offset_origin
from ..jit import jit, jit_inline
from ..sampling import area_to_solid_angle
from ..vec import cross, dot, madd, mul, normalize, row, sub

# Emissive triangles are sampled in solid angle from points closer to their plane than this
# times their longest edge, in area from farther away. Cycles makes the same kind of distance
# test. Measured on the dragon scene at 16 spp: the same relMSE as with 1.0 or 2.0 (0.0252 vs
# 0.0250) in less time, where area sampling everywhere gave 0.0326.
SOLID_ANGLE_RANGE = 0.25


# -- spherical triangles ------------------------------------------------------------------------

@jit
def spherical_triangle(a, b, c):
    """Cosines of the sides (b c, a c, a b), |a . (b x c)| and the solid angle (Van Oosterom and
    Strackee 1983) of the spherical triangle with unit corners a, b, c."""
    cos_a, cos_b, cos_c = dot(b, c), dot(a, c), dot(a, b)
    mixed = abs(dot(a, cross(b, c)))
    return cos_a, cos_b, cos_c, mixed, 2.0 * math.atan2(mixed, 1.0 + cos_a + cos_b + cos_c)


@jit
def solid_angle(a, b, c):
    """Solid angle of the spherical triangle with unit corners a, b, c."""
    return spherical_triangle(a, b, c)[4]


@jit
def inverse_sine(cos):
    """1 / sin of an angle in [0, pi] given its cosine, 0 where the sine vanishes."""
    sin2 = 1.0 - cos * cos
    return 1.0 / math.sqrt(sin2) if sin2 > 0.0 else 0.0


@jit
def sample_spherical_triangle(a, b, c, u0, u1):
    """A direction uniform in solid angle over the spherical triangle with unit corners a, b, c:
    (direction, solid angle).

    Arvo's method in the form Cycles uses: u0 chooses the sub-triangle a, b, c' of area
    u0 x the solid angle, u1 a point on the arc from b to c'.
    """
    cos_a, cos_b, cos_c, mixed, omega = spherical_triangle(a, b, c)
    sub_area = u0 * omega
    sin_sub, cos_sub = math.sin(sub_area), math.cos(sub_area)
    # cos and sin of the angle at a, both without their common factor sin(b) sin(c).
    cos_alpha, sin_alpha = cos_a - cos_b * cos_c, mixed
    sin2_bc = max((1.0 - cos_b * cos_b) * (1.0 - cos_c * cos_c), 1e-300)
    temp = (cos_c - 1.0) * (cos_sub * cos_alpha + sin_sub * sin_alpha) * cos_alpha / sin2_bc
    q = (cos_sub - cos_c + temp) / (1.0 - cos_sub * cos_c + temp)
    # 0 / 0 only for triangles seen edge-on (no solid angle, so no weight): any q will do.
    q = min(max(q, -1.0), 1.0) if math.isfinite(q) else 1.0
    # a is orthogonal to the unit vector along c - cos_b a, and c_sub - cos_bc b has length
    # sin(arc b c_sub): both unit vectors come from cosines, without a normalisation.
    c_sub = madd(mul(a, q), math.sqrt(1.0 - q * q) * inverse_sine(cos_b), madd(c, -cos_b, a))
    cos_bc = dot(c_sub, b)
    z = 1.0 - u1 * (1.0 - cos_bc)
    scale = math.sqrt(max(1.0 - z * z, 0.0)) * inverse_sine(cos_bc)
    return madd(mul(b, z), scale, madd(c_sub, -cos_bc, b)), omega


# -- emissive triangles -------------------------------------------------------------------------

@jit_inline
def uniform_triangle_point(corners, u0, u1):
    """A point uniform in area on the triangle of rows corners (3, 3)."""
    su = math.sqrt(u0)
    b2 = u1 * su
    v0 = row(corners, 0)
    return madd(madd(v0, su - b2, sub(row(corners, 1), v0)), b2, sub(row(corners, 2), v0))


@jit_inline
def near_triangle(lights, light, plane):
    """Whether a point at signed distance `plane` from light triangle `light` samples it in
    solid angle (else in area)."""
    return lights.tri_edge2[light] * SOLID_ANGLE_RANGE ** 2 > plane * plane


@jit_inline
def triangle_light_point(lights, light, q, u0, u1):
    """A point on light triangle `light` sampled from the shading point q: (point, solid-angle
    density of that point, selection excluded)."""
    v = lights.tri_corners[light]
    v0, v1, v2 = row(v, 0), row(v, 1), row(v, 2)
    normal = row(lights.tri_normal, light)
    plane = dot(normal, sub(v0, q))                       # signed distance to the plane
    if near_triangle(lights, light, plane):
        direction, omega = sample_spherical_triangle(
            normalize(sub(v0, q)), normalize(sub(v1, q)), normalize(sub(v2, q)), u0, u1)
        t = plane / dot(normal, direction)                # where it meets the plane
        if omega > 0.0 and math.isfinite(t) and t > 0.0:
            return madd(q, t, direction), 1.0 / omega
        return v0, 0.0     # seen edge-on: no light, and the point stays finite (a corner)
    point = uniform_triangle_point(v, u0, u1)
    return point, area_to_solid_angle(point, q, normal, lights.tri_area[light], True)


@jit_inline
def pdf_triangle(lights, prim, o, d, t):
    """Solid-angle density with which sample_light would have chosen the point o + t d on mesh
    triangle prim (0 for emitters of no power)."""
    if lights.tri_prim.shape[0] == 0:
        return 0.0
    light = lights.light_of_prim[prim]
    v = lights.tri_corners[light]
    normal = row(lights.tri_normal, light)
    v0 = row(v, 0)
    if near_triangle(lights, light, dot(normal, sub(v0, o))):
        omega = solid_angle(normalize(sub(v0, o)), normalize(sub(row(v, 1), o)),
                            normalize(sub(row(v, 2), o)))
        density = 1.0 / omega if omega > 0.0 else 0.0
    else:
        density = area_to_solid_angle(madd(o, t, d), o, normal, lights.tri_area[light], True)
    return lights.tri_pmf[prim] * density


# -- emission (the light tracer and light vertices) ---------------------------------------------

@jit_inline
def triangle_point(lights, light, u0, u1):
    """A point uniform in area on light triangle `light`."""
    return uniform_triangle_point(lights.tri_corners[light], u0, u1)


@jit_inline
def lift_off_triangle(lights, mesh, light, y, normal, w):
    """Point y of light triangle `light` lifted off it (as hit points are: Embree reports hits
    at t = 0) to the side of normal that the direction w leaves by."""
    return offset_origin(y, normal, hit_offset(mesh, lights.tri_prim[light], y), w)


@jit_inline
def emit_triangle(lights, mesh, light, y, w, density):
    """A light path leaving point y of light triangle `light` (either face) along w, drawn with
    solid-angle density `density` (its point uniform in area): (origin, radiance x |cos| x area
    / density)."""
    normal = row(lights.tri_normal, light)
    cos_y = abs(dot(w, normal))
    y = lift_off_triangle(lights, mesh, light, y, normal, w)
    return y, mul(row(lights.tri_radiance, light), cos_y * lights.tri_area[light] / density)
