"""Blender's sun lamps as Cycles renders them (src/kernel/light/distant.h).

A sun with angle > 0 is a disc of half-angle alpha = angle / 2 and radiance E / (pi sin^2 alpha),
sampled uniformly in its cone; angle 0 is a direction, whose samplers return density 0 and the
irradiance E at normal incidence. The functions read the suns' rows of the light tables
(tables.Lights).
"""
from __future__ import annotations

import math

from ..jit import jit_inline
from ..sampling import orthonormal_basis, sample_uniform_cone, sample_uniform_disk
from ..vec import add, dot, madd, mul, row, sub
from .codes import ZERO


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


# -- emission (the light tracer) ----------------------------------------------------------------

@jit_inline
def emit_sun(lights, sun, aim_center, aim_radius, scene_center, scene_radius, u_pick, u_point,
             u_dir):
    """A light path from sun `sun` (angle > 0) through one of the spheres (aim_center,
    aim_radius), starting outside the scene's bounding sphere: a direction in the sun's cone,
    then a line through a disk across one sphere (u_pick picks it in proportion to its area).
    Returns (origin, direction, radiance / (density of the direction x density of the line in
    area across it: every disk it crosses))."""
    travel = row(lights.sun_dir, sun)
    w, cone_density = sample_uniform_cone(travel, lights.sun_one_minus_cos[sun], u_dir[0], u_dir[1])
    total = 0.0
    for k in range(aim_radius.shape[0]):
        total += aim_radius[k] ** 2
    target = u_pick * total
    chosen = aim_radius.shape[0] - 1
    for k in range(aim_radius.shape[0]):
        if target < aim_radius[k] ** 2:
            chosen = k
            break
        target -= aim_radius[k] ** 2
    x, y2 = sample_uniform_disk(u_point[0], u_point[1])
    t_axis, s_axis = orthonormal_basis(w)
    r = aim_radius[chosen]
    q = add(row(aim_center, chosen), add(mul(t_axis, x * r), mul(s_axis, y2 * r)))
    area_density = 0.0
    for k in range(aim_radius.shape[0]):
        off = sub(q, row(aim_center, k))
        along = dot(off, w)
        miss2 = dot(off, off) - along * along
        if miss2 <= aim_radius[k] ** 2:
            area_density += 1.0 / (math.pi * total)
    far = dot(sub(q, scene_center), w) + scene_radius
    radiance = row(lights.sun_radiance, sun)
    return madd(q, -far, w), w, mul(radiance, 1.0 / (cone_density * area_density))
