"""How a render's samples are cut into passes: one scheduler per mode (fixed samples, batches,
adaptive sampling).

Renderer.render asks its scheduler for the next pass, has it traced and added to the result,
reports progress, and stops when the scheduler has no pass left. A scheduler owns the sums its
mode keeps beside the image (each batch's image, adaptive sampling's halves) and the order in
which passes are added to them: float sums depend on their order, and that order depends on the
seed and the sample count only, never on the threads.
"""
from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from . import adaptive, jit, light_groups, wavefront
from .image import as_float32
from .pilot import LightVertexPilot
from .result import RenderResult, Window

CHUNK = 1 << 13           # paths per chunk: measured best (8k-16k) for Python overhead vs cache
PASS_PATHS = 1 << 17      # aim for about this many paths per progressive pass
# A fixed-sample render's window holds up to this many passes' paths (one pass at least). On a
# cluster each window is a task and a reply of 72 bytes a pixel whatever its samples, which the
# client receives and adds one at a time: at 256x256 and 256 spp, 128 windows of one pass (4.5
# MiB each) against 32 of four made `--workers 2` 12% slower (docs/measurements.md, "Rendering
# on Dask workers").
WINDOW_PASSES = 4
# The light paths of one pool.map: a pass's light paths beyond this (a batch of a big render)
# are traced in segments of it, so that no pass holds more than LIGHT_SEGMENT / CHUNK Futures.
LIGHT_SEGMENT = CHUNK << 10
JOB_MULTIPLE = 4          # a pass's jobs come in multiples of this: 1, 2 or 4 threads end together
ALL_PIXELS = np.zeros(0, np.int64)   # a pass's pixels: every pixel, in order (wavefront.pixel_of)
NO_ROWS = np.zeros((0, 3))           # film: no class-A image


class Pass(NamedTuple):
    """The samples first .. first + samples of a pass, in every pixel that samples it."""
    first: int
    samples: int


def jobs(begin: int, end: int, unit: int) -> list:
    """(start, count) jobs covering begin .. end in whole units (a pixel's samples in a pass),
    at most CHUNK paths each, of equal size give or take a unit, and as many as the next multiple
    of JOB_MULTIPLE (the units allowing): adaptive sampling's small passes then keep every thread
    busy. The split depends on the counts alone, so the image does not depend on the threads.

    A unit of more than CHUNK paths cannot be a job (the chunk buffers hold CHUNK paths, and the
    compiled stages have no bounds checks): split the pass first (sub_passes)."""
    if unit > CHUNK:
        raise ValueError(f"jobs: a pixel's {unit} samples exceed a chunk of {CHUNK} paths")
    units = (end - begin) // unit
    if units <= 0:
        return []
    count = -(-units // max(1, CHUNK // unit))
    count = min(units, -(-count // JOB_MULTIPLE) * JOB_MULTIPLE)
    bounds = [begin + i * units // count * unit for i in range(count + 1)]
    return [(a, b - a) for a, b in zip(bounds, bounds[1:])]


def samples_per_pass(rows: int) -> int:
    """Samples per pixel in a progressive pass over `rows` pixels: enough paths to fill the
    threads' chunks, a chunk's worth at most."""
    return max(1, min(PASS_PATHS // rows, CHUNK))


def sub_passes(step: Pass, rows: int) -> list[Pass]:
    """A pass over `rows` pixels cut into passes of at most samples_per_pass(rows) samples, traced
    one after the other. Jobs hold whole pixels' samples and at most CHUNK paths, so a pass of
    more samples per pixel than a chunk holds (a batch of a render of 2^17 spp and more) must be
    cut; each pixel's samples are still added in sample order, so the sums are those of the
    uncut pass. A progressive pass (samples_per_pass) is its own only sub-pass."""
    most = samples_per_pass(rows)
    if step.samples <= most:
        return [step]
    end = step.first + step.samples
    return [Pass(first, min(most, end - first)) for first in range(step.first, end, most)]


def light_segments(n_light: int, n_a: int):
    """A light pass's paths 0 .. n_light, as (begin, end) segments of at most LIGHT_SEGMENT
    paths, none straddling n_a (adaptive sampling's half A), made as they are traced one after
    the other, so the jobs in flight stay few. A pass of at most LIGHT_SEGMENT paths keeps its
    two halves whole."""
    for begin, end in ((0, n_a), (n_a, n_light)):
        for a in range(begin, end, LIGHT_SEGMENT):
            yield a, min(a + LIGHT_SEGMENT, end)


def light_count(per_camera_path: float, rows: int, samples: int, share: float = 1.0) -> int:
    """The light paths of a pass of `samples` camera samples in `rows` pixels, `share` the
    light tracer's energy on the pixels still sampling (adaptive sampling)."""
    return max(2, int(round(per_camera_path * rows * samples * share)))


def add_splats(jobs: list, splats, n_a: int, film, film_a, counters, groups=None) -> int:
    """Add light chunks' splats (Renderer.trace_light_chunk's, one per job, in job order) to
    film, and those of half A's jobs (starting before n_a) to film_a if not None, the light
    groups' to groups if not None (rows of (pixels, 3 x groups)); count the light paths that
    reached the camera. Returns how many splats were NaN or Inf (left out)."""
    bad = 0
    for (first, _), (pixels, contributions, reached, grouped) in zip(jobs, splats):
        bad += wavefront.splat(pixels, contributions, film)
        if film_a is not None and first < n_a:
            wavefront.splat(pixels, contributions, film_a)
        if groups is not None and grouped is not None:
            light_groups.splat_groups(*grouped, groups)
        counters[wavefront.CAUSTIC_SPLATS] += reached      # light paths, not splats
    return bad


class FixedWindows(Sequence):
    """The windows of a fixed-sample render of `pixels` pixels and `spp` samples, of
    samples_per_window samples each, made on demand (an 8192 x 8192 render of 2^24 spp has 2^24
    windows of one sample: a list of them would take gigabytes)."""

    def __init__(self, pixels: int, spp: int, every_pass: bool = False):
        self.step = samples_per_pass(pixels) if every_pass else samples_per_window(pixels)
        self.spp = spp
        self.count = -(-spp // self.step)

    def __len__(self) -> int:
        return self.count

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(self.count))]
        if k < 0:
            k += self.count
        if not 0 <= k < self.count:
            raise IndexError("window index out of range")
        first = k * self.step
        return Window(k, first, min(first + self.step, self.spp))


def samples_per_window(pixels: int) -> int:
    """Samples per pixel in a window of a fixed-sample render of `pixels` pixels: whole passes
    (samples_per_pass), as many as WINDOW_PASSES passes' paths hold, one at least."""
    step = samples_per_pass(pixels)
    return step * max(1, WINDOW_PASSES * PASS_PATHS // (pixels * step))


def fixed_windows(pixels: int, spp: int, every_pass: bool = False) -> FixedWindows:
    """The windows of a fixed-sample render of `pixels` pixels, in the order they are added
    (with every_pass, of one pass each)."""
    return FixedWindows(pixels, spp, every_pass)


def adaptive_settings(settings) -> tuple[float, int]:
    """(noise threshold, 0 when adaptive sampling is off (as with batches), least samples) of a
    render's settings."""
    threshold = 0.0 if settings.batches else settings.noise_threshold
    least = settings.min_spp
    if threshold > 0.0 and least <= 0:
        least = adaptive.auto_min_spp(threshold)
    if threshold > 0.0 and adaptive.first_check(least) >= settings.spp:
        threshold = 0.0                  # no error estimate before the last sample
    return threshold, least


def scheduler(renderer, result: RenderResult, settings, every_pass: bool = False):
    """The scheduler of a render's settings: batches, adaptive sampling or fixed samples (with
    every_pass, in windows of one pass). renderer: a Renderer, or anything with its pass
    interface (camera_pass, light_pass, light_count, trace_window, ray_count and the flags the
    schedulers read: farm/remote.py)."""
    threshold, least = adaptive_settings(settings)
    if settings.batches:
        return BatchPasses(renderer, result, settings.batches)
    if threshold > 0.0:
        return AdaptivePasses(renderer, result, threshold, least)
    return FixedPasses(renderer, result, every_pass)


def drive(renderer, scheduler, pool, progress, stop, time_limit: float) -> RenderResult:
    """Trace the scheduler's passes until it has none left, the render converged, `stop` was set,
    progress returned False or time_limit seconds (0: none) passed; returns its result."""
    result = scheduler.result
    embree_before, rays_before = renderer.embree_time, renderer.ray_count
    start, compiled_before = time.perf_counter(), jit.compile_seconds()

    def took():
        # A kernel's first compile (the scene's first shader program, say) is no render time.
        result.compile_s = jit.compile_seconds() - compiled_before
        return time.perf_counter() - start - result.compile_s

    while (step := scheduler.next()) is not None:
        if not scheduler.trace(pool, step, stop):
            result.cancelled = True
            break
        result.time_s = took()
        result.embree_time_s = renderer.embree_time - embree_before
        result.rays = renderer.ray_count - rays_before
        if progress is not None and progress(result, scheduler.k, scheduler.estimate()) is False:
            result.cancelled = scheduler.unfinished()
            break
        if scheduler.converged:
            break                 # every pixel has converged
        if time_limit > 0.0 and took() >= time_limit:
            result.time_limited = True    # a whole image of the passes done
            break
    result.time_s = took()
    return result


class _Passes:
    """What every scheduler shares: the renderer, the result, the sampler's resolution, the
    event counters, and the passes traced so far (k, which keys each pass's light paths)."""

    def __init__(self, renderer, result: RenderResult):
        self.renderer, self.result = renderer, result
        self.spp = result.spp_budget
        self.bits = max(1, (self.spp - 1).bit_length())   # sample indices run over [0, 2^bits)
        self.npix = result.width * result.height
        self.traces_light = renderer.caustics is not None
        self.counters = np.zeros(len(wavefront.STATS), np.int64)
        self.k = 0
        self.converged = False
        self.extra = result.extra_rows()

    def estimate(self) -> int:
        """The passes the render is expected to take (progress)."""
        raise NotImplementedError

    def unfinished(self) -> bool:
        """Whether stopping now leaves the render short of its samples."""
        return self.result.spp < self.spp and not self.converged

    def _light_film(self):
        """The light tracer's image sums in the result and one pass's buffer
        (rows of (pixels, 3))."""
        r = self.result
        r.light_sum = np.zeros((r.height, r.width, 3))
        return np.zeros((self.npix, 3))

    def _count(self):
        """Put the event counters in the result."""
        self.result.stats = dict(zip(wavefront.STATS, self.counters.tolist()))
        self.k += 1


class FixedPasses(_Passes):
    """Fixed samples in every pixel: the render's windows (Renderer.windows), each added to the
    result in window order as a distributed render merges them (RenderResult.add)."""

    def __init__(self, renderer, result, every_pass: bool = False):
        super().__init__(renderer, result)
        self.windows = fixed_windows(self.npix, self.spp, every_pass)
        self.film = (result.sum.reshape(-1, 3), result.sum_sq.reshape(-1, 3))
        self.pass_light = self._light_film() if self.traces_light else None
        # A window of several passes is summed from zero in a film of its own and added whole,
        # as a cluster's client adds a worker's window: merged pass by pass, its sums would
        # differ in the last bits. Only small images have such windows (a few MB each).
        self.window_film = None
        if self.windows.step > samples_per_pass(self.npix):
            self.window_film = (np.empty((self.npix, 3)), np.empty((self.npix, 3)))

    def next(self) -> Window | None:
        return self.windows[self.k] if self.k < len(self.windows) else None

    def trace(self, pool, window: Window, stop) -> bool:
        # A window of one pass is merged into the result chunk by chunk, not kept whole: a big
        # render holds no third and fourth image of sums.
        merge = self.window_film is None
        film = self.film if merge else self.window_film
        if not merge:
            for rows in film:
                rows[:] = 0.0
        sums = self.renderer.trace_window(pool, window, self.bits, ALL_PIXELS, film, merge,
                                          self.pass_light, stop, self.extra)
        if sums is None:
            return False
        self.result.add(sums)
        self.k += 1
        return True

    def estimate(self) -> int:
        return len(self.windows)


class BatchPasses(_Passes):
    """K passes of equal samples (give or take one), each pass's image kept as a batch for
    variances from independent batches (RenderResult.variance_and_dof)."""

    def __init__(self, renderer, result, batches: int):
        super().__init__(renderer, result)
        h, w = result.height, result.width
        self.passes = max(1, min(batches, self.spp))
        result.batch_sum, result.batch_sq = np.zeros((h, w, 3)), np.zeros((h, w, 3))
        self.pass_sum = np.zeros((self.npix, 3))
        if self.traces_light:
            self.pass_light = self._light_film()
            result.light_batch_sum, result.light_batch_sq = np.zeros((h, w, 3)), np.zeros((h, w, 3))

    def next(self) -> Pass | None:
        if self.result.spp >= self.spp:
            return None
        return Pass(self.result.spp,
                    self.spp // self.passes + (1 if self.k < self.spp % self.passes else 0))

    def trace(self, pool, step: Pass, stop) -> bool:
        renderer, result = self.renderer, self.result
        h, w = result.height, result.width
        self.pass_sum[:] = 0.0
        result.nan_count += renderer.camera_pass(
            pool, step, ALL_PIXELS, self.bits,
            (self.pass_sum, result.sum_sq.reshape(-1, 3), NO_ROWS),
            self.counters, stop, extra=self.extra)
        if stop is not None and stop.is_set():
            return False
        image = self.pass_sum / step.samples
        if self.traces_light:
            n_light = renderer.light_count(self.npix, step.samples)
            result.nan_count += renderer.light_pass(pool, self.k, n_light, n_light,
                                                     self.pass_light, None, self.counters,
                                                     (None if self.extra is None
                                                      else self.extra.group_light))
            result.light_sum.reshape(-1, 3)[:] += self.pass_light
            result.light_paths += n_light
            light_image = self.pass_light / n_light
            _add_batch(result.light_batch_sum, result.light_batch_sq, light_image)
            if renderer.split:
                image += light_image
                result.light_batch_images.append(as_float32(light_image.reshape(h, w, 3)))
        result.sum.reshape(-1, 3)[:] += self.pass_sum
        _add_batch(result.batch_sum, result.batch_sq, image)
        result.batch_images.append(as_float32(image.reshape(h, w, 3)))
        result.batches += 1
        result.spp += step.samples
        self._count()
        return True

    def estimate(self) -> int:
        return self.passes


class AdaptivePasses(_Passes):
    """Adaptive sampling (tracer/adaptive.py): passes inside one window of adaptive.STEP samples,
    over the pixels whose half of the samples still samples it, the light tracer's paths in
    proportion to its light on those pixels; the light-vertex pilot, where it runs, decides at
    the first error estimate whether the rest of the render connects to light vertices."""

    def __init__(self, renderer, result, threshold: float, least: int):
        super().__init__(renderer, result)
        h, w = result.height, result.width
        result.sample_count = np.zeros((h, w), np.int32)
        self.halves = result.halves = adaptive.Halves(w, h, threshold, least)
        if self.traces_light:
            self.pass_light = self._light_film()
            self.light_half, self.pass_light_a = np.zeros((self.npix, 3)), np.zeros((self.npix, 3))
            result.light_pass_sq = np.zeros((h, w, 3))
        self.vertices = renderer.light_vertices
        self.pilot = (LightVertexPilot(self.npix)
                      if renderer.light_vertices and renderer.light_vertex_pilot else None)
        self.light_share = 1.0
        self.union = None                       # the pixels either half samples
        self.sampling = ALL_PIXELS
        self.samples = 0                        # the last pass's samples per pixel

    def next(self) -> Pass | None:
        result, spp = self.result, self.spp
        while result.spp < spp:
            done = result.spp
            # A pass stays inside one window, whose half's pixels take its samples.
            window_end = min(spp, (done // adaptive.STEP + 1) * adaptive.STEP)
            self.sampling = self.halves.pixels(done)
            if self.sampling.size == 0:
                result.spp = window_end         # this half has stopped everywhere
                continue
            return Pass(done, min(samples_per_pass(self.sampling.shape[0]), spp - done,
                                  window_end - done))
        return None

    def trace(self, pool, step: Pass, stop) -> bool:
        renderer, result, halves = self.renderer, self.result, self.halves
        pilot = self.pilot
        rays_then = renderer.ray_count
        result.nan_count += renderer.camera_pass(
            pool, step, self.sampling, self.bits, halves.film(step.first), self.counters, stop,
            self.vertices, None if pilot is None else pilot.sums, extra=self.extra)
        if pilot is not None:
            pilot.rays += renderer.ray_count - rays_then
        if stop is not None and stop.is_set():
            return False
        if self.traces_light:
            self._trace_light(pool, step)
        result.spp += step.samples
        self.samples = step.samples
        total, total_sq = result.sum.reshape(-1, 3), result.sum_sq.reshape(-1, 3)
        halves.add(step.first, step.samples)
        np.add(halves.count[0], halves.count[1], out=result.sample_count.reshape(-1))
        np.add(halves.sum[0], halves.sum[1], out=total)
        np.add(halves.sum_sq[0], halves.sum_sq[1], out=total_sq)
        if pilot is not None and result.spp == halves.first:
            light = (result.light_sum.reshape(-1, 3) / result.light_paths
                     if renderer.split else 0.0)
            self.vertices, why = pilot.choose(total, total_sq, result.spp, light, halves,
                                              self.spp, self.counters)
            result.stages["light vertices"] = (self.vertices, why)
            self.pilot = None
        if result.spp < self.spp:
            self._check()
        self._count()
        self.converged = self.sampling.shape[0] == 0 and self.sampling is not ALL_PIXELS
        return True

    def _trace_light(self, pool, step: Pass):
        """The light tracer's pass: its paths' first half is half A of its error estimate."""
        renderer, result = self.renderer, self.result
        n_light = renderer.light_count(self.npix, step.samples, self.light_share)
        n_a = n_light // 2
        result.nan_count += renderer.light_pass(pool, self.k, n_light, n_a, self.pass_light,
                                                 self.pass_light_a, self.counters,
                                                 (None if self.extra is None
                                                  else self.extra.group_light))
        result.light_sum.reshape(-1, 3)[:] += self.pass_light
        result.light_paths += n_light
        self.light_half += self.pass_light_a
        result.light_paths_a += n_a
        result.light_pass_sq.reshape(-1, 3)[:] += self.pass_light * self.pass_light / n_light
        result.light_passes += 1

    def _check(self):
        """Estimate the errors where a window ended, and follow the pixels still sampling."""
        result, halves = self.result, self.halves
        halves.check(result.spp, (result.light_sum.reshape(-1, 3), self.light_half,
                                  result.light_paths, result.light_paths_a)
                     if self.renderer.split else ())
        if halves.union() is not self.union:      # a check changed the halves
            self.union = halves.union()
            result.active_share = self.union.shape[0] / self.npix
            if self.traces_light:
                self.light_share = _share_on(self.pass_light, self.union)
        self.sampling = self.union

    def estimate(self) -> int:
        if self.converged:
            return self.k
        return self.k + math.ceil((self.spp - self.result.spp) / max(self.samples, 1))


def _share_on(light, pixels) -> float:
    """The share of a light image's energy (rows of (pixels, 3)) on the given pixels."""
    whole = float(light.sum())
    return float(light[pixels].sum()) / whole if whole > 0.0 else 1.0


def _add_batch(total, total_sq, image):
    """Add one batch image, (pixels, 3) rows, to (H, W, 3) sums of batches and of their squares."""
    total.reshape(-1, 3)[:] += image
    total_sq.reshape(-1, 3)[:] += image * image
