"""How far a path may go, which caustics it renders and how bright one sample may be: Cycles'
bounce limits of each kind (kernel/integrator/path_state.h, path_state_next), its caustics
switches and its sample clamping (kernel/film/light_passes.h, film_clamp_light).

Bounces. Cycles counts a path's diffuse reflections, glossy reflections (singular ones, a
mirror's or glass's, included) and transmissions (refraction and translucency) apart from its
total. After the scattering event that takes a count past its limit the path still adds what it
finds at the next surface, then ends there, as it does after its last bounce of all (limits:
Snell's `max_depth` and Cycles' limits of each kind, the kernel's max_*_bounce = setting + 1).
So a limit of L lets a path scatter L + 1 times that way, the last time towards a light.
A path's three counts are packed into one int64 (`kinds`, KIND_BITS bits each): a wavefront
step copies one number per path instead of a row of three (the row cost the materials stage
about 3% on a Cornell box: docs/measurements.md).

Caustics. Cycles' Light Paths > Caustics switches, off, drop a glossy reflection's or a
refraction's closures at a surface that a diffuse ray reached (kernel/svm/closure.h,
__CAUSTICS_TRICKS__: PATH_RAY_DIFFUSE, set by a diffuse reflection or translucency and kept
through transparent surfaces): a mirror there is black, glass keeps the other kind's share of
its Fresnel split, a Principled BSDF keeps its lower layers unattenuated by the dropped ones.
limits[5] holds the switched-off kinds (NO_REFLECTIVE_CAUSTICS, NO_REFRACTIVE_CAUSTICS bits).

Clamping. Each contribution to the image (a light sample that arrives, or light a path finds) is
scaled down so that the sum of its red, green and blue is at most 3 x the clamp (Cycles'
kernel_data.integrator.sample_clamp_* = setting x 3; 0 is off). Light is direct when it comes
from a light sample of the first hit or is found by the camera ray or the first bounce's ray
(film_clamp_light's `bounce` of 0 or below), indirect otherwise.
"""
from __future__ import annotations

import math

import numpy as np

from .jit import jit, jit_inline
from .lights.codes import VISIBLE_DIFFUSE, VISIBLE_TRANSMISSION

# The kinds of bounce, each a field of a packed count (kind_count).
DIFFUSE_BOUNCE, GLOSSY_BOUNCE, TRANSMISSION_BOUNCE = range(3)
KIND_BITS = 16          # Cycles' limits are at most 1024, a path's depth at most 1024 + 1024
KIND_MASK = (1 << KIND_BITS) - 1
NO_BOUNCES = 0          # the packed counts of a path that has not scattered
# Cycles' caustics switches that are off (bounce_limits' caustics_off, limits[5]).
NO_REFLECTIVE_CAUSTICS, NO_REFRACTIVE_CAUSTICS = 1, 2
NO_CLAMP = math.inf


def bounce_limits(max_depth: int, transparent: int, diffuse: int, glossy: int,
                  transmission: int, caustics_off: int = 0) -> tuple:
    """The limits the wavefront's stages read: (max depth, transparent bounces, then each
    kind's as Cycles' setting, then the caustics switched off: caustics_bits)."""
    return (np.int64(max_depth), np.int64(transparent), np.int64(diffuse), np.int64(glossy),
            np.int64(transmission), np.int64(caustics_off))


def caustics_bits(reflective: bool, refractive: bool) -> int:
    """bounce_limits' caustics_off from Cycles' two caustics switches."""
    return (0 if reflective else NO_REFLECTIVE_CAUSTICS) | (0 if refractive else
                                                           NO_REFRACTIVE_CAUSTICS)


@jit_inline
def dropped_at(limits, ray_kind):
    """The caustics bits (NO_*_CAUSTICS) whose lobes a hit reached by a ray of ray_kind (a
    lights.codes VISIBLE_* flag) drops: the switched-off ones after a diffuse ray, else none."""
    return limits[5] if ray_kind == VISIBLE_DIFFUSE else np.int64(0)


@jit_inline
def drops(drop, transmits):
    """Whether a hit dropping the caustics bits `drop` drops a refraction (transmits) or a
    glossy reflection (not)."""
    return (drop & (NO_REFRACTIVE_CAUSTICS if transmits else NO_REFLECTIVE_CAUSTICS)) != 0


def clamp_limits(direct: float, indirect: float) -> tuple:
    """The stages' clamp (direct, indirect) from Cycles' two settings (0: off)."""
    return (3.0 * direct if direct > 0.0 else NO_CLAMP,
            3.0 * indirect if indirect > 0.0 else NO_CLAMP)


@jit_inline
def bounce_kind(ray_kind, through):
    """The count a scattering event that made a ray of ray_kind (a lights.codes VISIBLE_* flag)
    adds to, as Cycles' labels: a transmission ray's (glass, a rough refraction) and a diffuse
    ray's that left through the surface (`through`: translucency) to transmission, other
    diffuse rays to diffuse, the rest (a mirror's, glass's and rough reflections) to glossy."""
    if ray_kind == VISIBLE_TRANSMISSION or (ray_kind == VISIBLE_DIFFUSE and through):
        return TRANSMISSION_BOUNCE
    return DIFFUSE_BOUNCE if ray_kind == VISIBLE_DIFFUSE else GLOSSY_BOUNCE


@jit_inline
def kind_count(kinds, kind):
    """The count of bounces of this kind in packed counts `kinds`."""
    return (kinds >> (KIND_BITS * kind)) & KIND_MASK


@jit_inline
def add_bounce(kinds, kind):
    """Packed counts `kinds` with one more bounce of this kind."""
    return kinds + (np.int64(1) << (KIND_BITS * kind))


def packed(diffuse: int, glossy: int, transmission: int) -> int:
    """The packed counts of these bounces of each kind."""
    return diffuse | glossy << KIND_BITS | transmission << 2 * KIND_BITS


@jit_inline
def within_limits(kinds, limits):
    """Whether packed counts (diffuse, glossy, transmission) are each within its limit
    (bounce_limits)."""
    return (kind_count(kinds, DIFFUSE_BOUNCE) <= limits[2]
            and kind_count(kinds, GLOSSY_BOUNCE) <= limits[3]
            and kind_count(kinds, TRANSMISSION_BOUNCE) <= limits[4])


@jit_inline
def past_last_bounce(bounce, kinds, limits):
    """Whether a path of `bounce` bounces, `kinds` of them (packed counts), scatters no more:
    the total or one kind's count past its limit (`limits`, bounce_limits)."""
    return bounce >= limits[0] or not within_limits(kinds, limits)


@jit_inline
def clamp_limit(clamp, direct):
    """The clamp (clamp_limits) of direct or indirect light."""
    return clamp[0] if direct else clamp[1]


@jit
def clamp_light(value, limit):
    """value, scaled down so that |r| + |g| + |b| is at most limit."""
    total = abs(value[0]) + abs(value[1]) + abs(value[2])
    if total > limit:
        s = limit / total
        return (value[0] * s, value[1] * s, value[2] * s)
    return value
