"""Blender's sun lamps as Cycles renders them (src/kernel/light/distant.h).

A sun with angle > 0 is a disc of half-angle alpha = angle / 2 and radiance E / (pi sin^2 alpha),
sampled uniformly in its cone; angle 0 is a direction, whose samplers return density 0 and the
irradiance E at normal incidence (a delta light: no ray finds it, and only the light tracer renders
its light through mirrors and glass). The functions read the suns' rows of the light tables
(tables.Lights).
"""
from __future__ import annotations

import math

from ..jit import jit_inline
from ..sampling import sample_uniform_cone
from ..vec import dot, mul, row
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
def sun_emission(lights, sun, u0, u1):
    """The direction a light path from sun `sun` travels: (direction, radiance, its density in
    solid angle). A disc (angle > 0): uniform in its cone, with the disc's radiance. A sun of
    angle 0 emits along one direction: its radiance is E delta(w - w_sun) (E the irradiance at
    normal incidence, delta in solid angle) and the direction is drawn with probability one, so
    the pair (E, 1) stands for radiance / density, as the disc's L / (1 / (2 pi (1 - cos a)))
    tends to L pi sin^2 a = E when the angle a goes to 0."""
    travel = row(lights.sun_dir, sun)
    one_minus_cos = lights.sun_one_minus_cos[sun]
    if one_minus_cos == 0.0:
        return travel, row(lights.sun_irradiance, sun), 1.0
    w, cone_density = sample_uniform_cone(travel, one_minus_cos, u0, u1)
    return w, row(lights.sun_radiance, sun), cone_density
