"""Adaptive sampling: which pixels still need samples, by Cycles' error with a stopping rule that
keeps every pixel's mean unbiased.

Every STEP samples after a minimum, each sampling pixel's error is estimated from two images of
its own samples: I, the mean of all of them, and A, the mean of the "class A" half (a fixed half
of the sample indices, each half stratified on its own). Their difference is the error of a mean
of half as many samples, which is as large as the error of I itself, and it measures the error
the sampler actually makes: with stratified samples that is less than a per-sample variance says.
As in Cycles (kernel/film/adaptive_sampling.h; Dammertz et al. 2010, "A hierarchical automatic
stopping condition for Monte Carlo global illumination", section 2.1):

    error = (|I_r - A_r| + |I_g - A_g| + |I_b - A_b|) / (0.0001 + n(I_r + I_g + I_b)),
    n(x) = sqrt(x) below 1 (noise as the eye sees it in the dark), x above (over-exposed),

compared with 5 x the noise threshold (Cycles' own factor, so that the user's threshold means
what it means in Cycles), with Cycles' automatic minimum of samples.

The stopping rule differs from Cycles'. Cycles stops a pixel when its own error and its 8
neighbours' are below the threshold. A pixel's own error is low when its samples have not yet
met a rare bright path, so that rule stops pixels preferentially while their mean is low: on
cornell_spheres at threshold 0.01 it darkens the image by 0.2-0.4%, ten standard errors of the
validator's image-mean test (README, Adaptive sampling). Here a pixel stops on its neighbours'
evidence only: it goes on while any of its 8 neighbours' noise level (error x sqrt(samples) at
that neighbour's last check) predicts an error above the threshold at its own sample count. Its
stopping time is then independent of its own samples (the samples of different pixels are
independent), so its mean stays unbiased; noise varies smoothly enough over an image that the
neighbours' level is the pixel's own, and, as with Cycles' 3x3 dilation, no pixel stops beside a
noisy one. A pixel that stopped does not start again: every sampling pixel then has the same
sample indices, which keeps each pixel's samples stratified and the wavefront's pixel arithmetic
simple.

The light tracer's part of the image (integrator.py) counts in the error too: its own I and A
from the light paths of the first and the second half of every pass.
"""
from __future__ import annotations

import math

import numpy as np

from .jit import jit

STEP = 16                 # samples between checks (Cycles' adaptive_step)
CYCLES_SCALE = 5.0        # Cycles multiplies the user's threshold by this before comparing
EPSILON = 1e-4            # Cycles' guard in the error's denominator
CLASS_A_MASK = 0xAAAAAAAA


def auto_min_spp(threshold: float) -> int:
    """Cycles' automatic minimum samples for a noise threshold: 0.1 -> 32, 0.01 -> 64,
    0.001 -> 128 (scene/integrator.cpp, Integrator::get_adaptive_sampling)."""
    return max(4, math.ceil(16.0 / threshold ** 0.3))


@jit
def is_class_a(sample):
    """Whether sample index `sample` is in the half A: an odd count of set odd bits (Cycles'
    sample_is_class_A, after Christensen et al. 2018, section 10.2.1)."""
    x = sample & CLASS_A_MASK
    count = 0
    while x:
        x &= x - 1
        count += 1
    return count % 2 == 1


def class_a_count(n: int) -> int:
    """How many of the sample indices 0 .. n - 1 are in half A."""
    odd_bits = np.arange(n, dtype=np.int64) & CLASS_A_MASK
    parity = np.zeros(n, np.int64)
    for bit in range(1, 32, 2):
        parity ^= (odd_bits >> bit) & 1
    return int(parity.sum())


@jit
def normalisation(intensity):
    """The error's denominator's scale: sqrt below 1, linear above (see the module docstring)."""
    return math.sqrt(intensity) if intensity < 1.0 else intensity


@jit
def pixel_error(full, half):
    """Cycles' per-pixel error of a mean `full` from the mean `half` of half its samples (RGB)."""
    difference = abs(full[0] - half[0]) + abs(full[1] - half[1]) + abs(full[2] - half[2])
    intensity = max(full[0] + full[1] + full[2], 0.0)
    return difference / (EPSILON + normalisation(intensity))


@jit
def _errors(active, total, half, n, n_a, light, light_half, light_paths, light_paths_a, out):
    """pixel_error of each sampling pixel (rows of (pixels, 3) sums): camera samples over n (half
    A over n_a) plus, with light paths, the light tracer's splats over their counts."""
    with_light = light_paths > 0 and light_paths_a > 0 and light_paths_a < light_paths
    for j in range(active.shape[0]):
        p = active[j]
        full = (total[p, 0] / n, total[p, 1] / n, total[p, 2] / n)
        part = (half[p, 0] / n_a, half[p, 1] / n_a, half[p, 2] / n_a)
        if with_light:
            full = (full[0] + light[p, 0] / light_paths, full[1] + light[p, 1] / light_paths,
                    full[2] + light[p, 2] / light_paths)
            part = (part[0] + light_half[p, 0] / light_paths_a,
                    part[1] + light_half[p, 1] / light_paths_a,
                    part[2] + light_half[p, 2] / light_paths_a)
        out[j] = pixel_error(full, part)


def errors(active, total, half, n, light=None, light_half=None, light_paths=0, light_paths_a=0):
    """The error of each pixel in `active` (indices into (pixels, 3) sums), after n samples."""
    empty = np.zeros((0, 3))
    out = np.empty(active.shape[0])
    _errors(active, total, half, float(n), float(class_a_count(n)),
            empty if light is None else light, empty if light_half is None else light_half,
            float(light_paths), float(light_paths_a), out)
    return out


@jit
def _neighbour_max(level, width, height, out):
    """out[y, x] = the largest level among the 8 neighbours of (x, y) inside the image (its own
    when it has none: a one-pixel image)."""
    for y in range(height):
        for x in range(width):
            most = -1.0
            for dy in range(-1, 2):
                yy = y + dy
                if yy < 0 or yy >= height:
                    continue
                for dx in range(-1, 2):
                    xx = x + dx
                    if (dx != 0 or dy != 0) and 0 <= xx < width:
                        most = max(most, level[yy, xx])
            out[y, x] = level[y, x] if most < 0.0 else most


def still_sampling(active, error, n, threshold, level, width, height) -> np.ndarray:
    """The pixels of `active` that go on sampling after n samples, given their errors; `level`
    (one per pixel, kept between checks) holds each pixel's noise level, error x sqrt(n) at its
    last check. A pixel goes on while any neighbour's level predicts an error of at least
    CYCLES_SCALE x threshold at n samples. Returns sorted pixel indices."""
    level[active] = error * math.sqrt(n)
    near = np.empty((height, width))
    _neighbour_max(level.reshape(height, width), width, height, near)
    return active[near.ravel()[active] >= CYCLES_SCALE * threshold * math.sqrt(n)]
