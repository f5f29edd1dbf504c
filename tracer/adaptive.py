"""Adaptive sampling: which pixels still need samples, by Cycles' error, with a stopping rule
that keeps every pixel's mean unbiased.

A pixel's samples come in two interleaved halves: sample indices in windows of STEP, the even
windows half 0 and the odd ones half 1 (aligned windows of a Sobol sequence are each well
stratified). Each half keeps its own sums and count, and the pixel's value is the mean of the two
halves' means. After a minimum, every time a window ends, the half that sampled it gets a new
error estimate from two images of its own samples: I, the mean of all of them, and A, the mean
of Cycles' "class A" samples among them (half of every window). Their difference is the error of
a mean of half as many samples, as large as the error of I itself, and it measures the error the
sampler actually makes: with stratified samples that is less than a per-sample variance says. As
in Cycles (kernel/film/adaptive_sampling.h; Dammertz et al. 2010, "A hierarchical automatic
stopping condition for Monte Carlo global illumination", section 2.1):

    error = (|I_r - A_r| + |I_g - A_g| + |I_b - A_b|) / (0.0001 + n(I_r + I_g + I_b)),
    n(x) = sqrt(x) below 1 (noise as the eye sees it in the dark), x above (over-exposed),

compared with 5 x the noise threshold (Cycles' own factor, so that the user's threshold means
what it means in Cycles), with Cycles' automatic minimum of samples.

The stopping rule differs from Cycles'. Cycles stops a pixel when its own error and its 8
neighbours' are below the threshold. A pixel's own error is low while its samples have not yet
met a rare bright path, so that rule stops pixels preferentially while their mean is low: on
cornell_spheres at threshold 0.01 it darkens the image by 0.2-0.4%, ten standard errors of the
validator's image-mean test (README, Adaptive sampling). Here each half of a pixel stops on
evidence other than its own samples: it goes on while the other half's noise level (error x
sqrt(samples) at
its last estimate), at the pixel or any of its 8 neighbours, predicts an error above the
threshold at this half's count, or the same half's level at any of the 8 neighbours does (their
samples are not this pixel's). A half's stopping time then depends on its own samples only
through other halves' stopping times, which move when their levels are re-estimated, not what
they estimate, so each half's mean, and the pixel's, stays unbiased to the validator's
precision (tested on the caustic room and both default scenes). The pixel's own noise counts,
which a rule on the neighbours alone missed: a noisy pixel among calm ones stopped early and its
neighbours sampled on around it (rings in the sample maps, 1.44x Cycles' error on cornell_dragon
at the same threshold and samples). The halves must be averaged with equal weights: a mean
pooled over both would weight a half by a count that its partner's samples decide. A half that
stopped does not start again, so every pixel sampling a window has the same sample indices.

The light tracer's part of the image (integrator.py) counts in the error too: its own I and A
from the light paths of the first and the second half of every pass, the same in both halves.
"""
from __future__ import annotations

import math

import numpy as np

from .jit import jit

STEP = 16                 # samples per window, and between estimates of a half (Cycles'
#                           adaptive_step)
CYCLES_SCALE = 5.0        # Cycles multiplies the user's threshold by this before comparing
EPSILON = 1e-4            # Cycles' guard in the error's denominator
CLASS_A_MASK = 0xAAAAAAAA


def auto_min_spp(threshold: float) -> int:
    """Cycles' automatic minimum samples for a noise threshold: 0.1 -> 32, 0.01 -> 64,
    0.001 -> 128 (scene/integrator.cpp, Integrator::get_adaptive_sampling)."""
    return max(4, math.ceil(16.0 / threshold ** 0.3))


def first_check(least: int) -> int:
    """The samples after which the first estimate is made: the minimum rounded up to whole
    windows, and at least one window of each half."""
    return max(2 * STEP, -(-least // STEP) * STEP)


def samples_to_error(total, total_sq, n, mean, error):
    """The samples each pixel needs for Cycles' error of its mean to fall to `error`, from n
    samples' sums and sums of squares (rows of (pixels, 3)) and the pixel's value `mean`."""
    out = np.empty(total.shape[0])
    _samples_to_error(total, total_sq, float(n), mean, float(error), out)
    return out


@jit
def _samples_to_error(total, total_sq, n, mean, error, out):
    for p in range(total.shape[0]):
        spread = 0.0
        for k in range(3):
            variance = max(total_sq[p, k] - total[p, k] * total[p, k] / n, 0.0) / (n - 1.0)
            spread += math.sqrt(variance)
        # For a mean of m samples |I - A| per channel is half-normal, of mean
        # sqrt(2 / pi) sqrt(variance / m): the error pixel_error finds, on average.
        intensity = max(mean[p, 0] + mean[p, 1] + mean[p, 2], 0.0)
        needed = math.sqrt(2.0 / math.pi) * spread / ((EPSILON + normalisation(intensity)) * error)
        out[p] = needed * needed


def predicted_samples(total, total_sq, n, mean, threshold, least, most, width, height):
    """The samples adaptive sampling is predicted to give each pixel, (height, width), from n
    samples' sums (as for samples_to_error): enough for the error at the pixel and its 8
    neighbours to reach the threshold (Halves.check keeps a pixel while a neighbour is noisy),
    between least and most."""
    needed = samples_to_error(total, total_sq, n, mean, CYCLES_SCALE * threshold)
    around = np.empty((height, width))
    _dilate(needed.reshape(height, width), width, height, True, around)
    return np.clip(around, least, most)


def half_of(sample: int) -> int:
    """Which half (0 or 1) sample index `sample` belongs to."""
    return (sample // STEP) & 1


@jit
def is_class_a(sample):
    """Whether sample index `sample` is in Cycles' class A: an odd count of set odd bits
    (Cycles' sample_is_class_A, after Christensen et al. 2018, section 10.2.1); half of every
    aligned group of 4 indices, so half of every window."""
    x = sample & CLASS_A_MASK
    count = 0
    while x:
        x &= x - 1
        count += 1
    return count % 2 == 1


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
    """pixel_error of each sampling pixel (rows of (pixels, 3) sums): camera samples over n (class
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


def errors(active, total, class_a, n, light=None, light_half=None, light_paths=0, light_paths_a=0):
    """The error of each pixel in `active` (indices into (pixels, 3) sums of n samples of whole
    windows, and of their class-A half)."""
    empty = np.zeros((0, 3))
    out = np.empty(active.shape[0])
    _errors(active, total, class_a, float(n), float(n // 2),
            empty if light is None else light, empty if light_half is None else light_half,
            float(light_paths), float(light_paths_a), out)
    return out


@jit
def _dilate(level, width, height, centre, out):
    """out[y, x] = the largest level in the 3x3 block around (x, y), inside the image, (x, y)
    itself included if `centre` (0 where nothing is)."""
    for y in range(height):
        for x in range(width):
            most = 0.0
            for yy in range(max(y - 1, 0), min(y + 2, height)):
                for xx in range(max(x - 1, 0), min(x + 2, width)):
                    if centre or yy != y or xx != x:
                        most = max(most, level[yy, xx])
            out[y, x] = most


class Halves:
    """The two halves of every pixel's samples: their sums, counts and noise levels, and which
    pixels each half still samples. Rows of (pixels, 3), pixel = y * width + x."""

    def __init__(self, width: int, height: int, threshold: float, least: int):
        npix = width * height
        self.width, self.height, self.threshold = width, height, threshold
        self.first = first_check(least)
        self.sum = np.zeros((2, npix, 3))
        self.sum_sq = np.zeros((2, npix, 3))
        self.class_a = np.zeros((2, npix, 3))
        self.count = np.zeros((2, npix), np.int32)
        self.level = np.zeros((2, npix))     # error x sqrt(samples) at the half's last estimate
        self.active = [np.arange(npix, dtype=np.int64), np.arange(npix, dtype=np.int64)]
        self.samples = [0, 0]                # samples of each half in every pixel still in it
        self._union = None                   # union(), until a check changes the halves

    def pixels(self, sample: int) -> np.ndarray:
        """The pixels that take sample index `sample` (sorted)."""
        return self.active[half_of(sample)]

    def film(self, sample: int):
        """(sums, sums of squares, class-A sums) that sample index `sample` adds to."""
        h = half_of(sample)
        return self.sum[h], self.sum_sq[h], self.class_a[h]

    def add(self, sample: int, n: int):
        """Count n samples from index `sample` (inside one window) in the pixels that took them."""
        h = half_of(sample)
        self.count[h, self.active[h]] += n
        self.samples[h] += n

    def union(self) -> np.ndarray:
        """The pixels either half still samples (sorted; the same array until a check)."""
        if self._union is None:
            either = np.zeros(self.count.shape[1], bool)
            either[self.active[0]] = True
            either[self.active[1]] = True
            self._union = np.flatnonzero(either)
        return self._union

    @property
    def converged(self) -> bool:
        """Whether both halves have stopped in every pixel."""
        return self.active[0].size == 0 and self.active[1].size == 0

    def check(self, done: int, light=()):
        """After `done` samples (a window's end from the first check on): estimate the error of
        the half (both, at the first check) that just sampled, then keep in each half the pixels
        where the other half's level at or around the pixel, or this half's at its neighbours,
        predicts an error of at least CYCLES_SCALE x threshold at this half's count. `light`: the
        light tracer's (sums, class-A sums, paths, class-A paths) for errors()."""
        if done < self.first or done % STEP:
            return
        for h in ((0, 1) if done == self.first else (half_of(done - 1),)):
            if self.active[h].size:
                n = self.samples[h]
                error = errors(self.active[h], self.sum[h], self.class_a[h], n, *light)
                self.level[h, self.active[h]] = error * math.sqrt(n)
        # Each half's levels around each pixel, with the pixel's own (for its other half) and
        # without (for the same half: its neighbours' samples are not its own).
        near = np.empty((2, 2, self.height, self.width))
        for h in (0, 1):
            for centre in (0, 1):
                _dilate(self.level[h].reshape(self.height, self.width), self.width, self.height,
                        centre == 1, near[h, centre])
        for h in (0, 1):
            n = self.samples[h]
            if self.active[h].size and n:
                around = np.maximum(near[1 - h, 1], near[h, 0]).ravel()[self.active[h]]
                self.active[h] = self.active[h][around >= CYCLES_SCALE * self.threshold
                                                * math.sqrt(n)]
        self._union = None

    def mean(self, rows: slice) -> np.ndarray:
        """The camera samples' image of the pixels in `rows` (a slice of pixel indices): the
        mean of the halves' means (a half without samples left out), (pixels, 3)."""
        count = self.count[:, rows, None].astype(np.float64)
        means = self.sum[:, rows] / np.maximum(count, 1.0)
        weights = (count > 0).astype(np.float64)
        return (means * weights).sum(axis=0) / np.maximum(weights.sum(axis=0), 1.0)

    def variance_of_mean(self) -> tuple[np.ndarray, int]:
        """Each pixel's variance of mean(), (pixels, 3), from each half's samples (count - 1
        degrees of freedom), and the least degrees of freedom of any pixel's half."""
        n = np.maximum(self.count, 2)[..., None].astype(np.float64)
        spread = np.maximum(self.sum_sq - self.sum * self.sum / n, 0.0) / (n - 1)
        weights = (self.count > 0)[..., None].astype(np.float64)
        halves = np.maximum(weights.sum(axis=0), 1.0)
        return (weights * spread / n).sum(axis=0) / (halves * halves), int(self.count.min()) - 1
