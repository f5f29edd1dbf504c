"""How many light paths the light tracer traces per camera path: a pilot of each kind measures
their noise and their rays, and the render takes the ratio of least error for its rays.

The image's relative variance after n camera samples a pixel, with r light paths per camera
path, is (Vc + Vl / r) / n, for n (cc + r cl) rays: Vc and cc a camera path's variance (summed
over the pixels, each divided by its squared mean, as relMSE weighs it) and rays, Vl and cl a
light path's. The product of the two is least at r = sqrt(Vl cc / (Vc cl)): the optimal
allocation of a budget between two estimators that are summed. On a lamp-lit room the light
paths carry little (Vl small), on a caustic seen through a tumbler's wall they carry most of the
noise and cost a seventh of a camera path's rays (r 0.5-0.9).

A camera path's variance comes from two replicas of one sample in each pilot pixel, with seeds
of their own: independent, where the stratified sampler's samples of one pixel are not. The
render's stratified samples converge faster than 1/n on a smooth image, so there Vc is an upper
bound and the ratio errs towards fewer light paths. The light paths' variance comes from the
difference of two halves. No pilot path enters the image, so the ratio does not depend on the
image's samples: the render stays unbiased. Its cost is rays, not seconds, so the ratio, and the
image, depend on the scene, settings and seed alone: a cluster's workers each choose the ratio
the local render does.
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from typing import NamedTuple

import numpy as np

from . import passes
from .counters import STATS
from .settings import LIGHT_PATHS_PER_CAMERA_PATH

# The ratios a pilot may choose: never fewer light paths than the fixed share, which holds the
# caustic region's error lowest on the lamp-lit rooms (settings.py); a pilot's camera variance
# is low where its few samples miss the fireflies a render meets, so a lower ratio would starve
# the caustics.
LEAST, MOST = LIGHT_PATHS_PER_CAMERA_PATH, 4.0
PILOT_SHARE = 0.005      # the pilot's camera paths, as a share of the render's
PILOT_LEAST = 4096       # ... and at least this many, for the variance sums
SEED_KEYS = (0x5EED_B0D6E7, 0x5EED_C1A55)   # the replicas' seeds: the render's xor these
MEAN_WIDTH = 9           # pilot pixels averaged for a pixel's mean
# The relative variance's floor under a pixel's squared mean, as the bench's relMSE has it
# (validation/metrics.py RELMSE_EPS): black pixels do not decide the ratio.
EPS = 1e-2


class Budget(NamedTuple):
    """A pilot's choice: light paths per camera path, and the figures it came from."""
    ratio: float
    camera_variance: float    # Vc: one camera sample a pixel, relative, summed over pixels
    light_variance: float     # Vl: one light path a pixel, likewise
    camera_rays: float        # cc: rays per camera path
    light_rays: float         # cl: rays per light path


def best_ratio(camera_variance: float, camera_rays: float, light_variance: float,
               light_rays: float) -> float:
    """Light paths per camera path of least (Vc + Vl / r) (cc + r cl), within [LEAST, MOST]."""
    if light_variance <= 0.0 or camera_rays <= 0.0:
        return LEAST
    if camera_variance <= 0.0 or light_rays <= 0.0:
        return MOST
    r = math.sqrt(light_variance * camera_rays / (camera_variance * light_rays))
    return min(MOST, max(LEAST, r))


def pilot_pixels(npix: int, spp: int) -> np.ndarray:
    """The image indices the camera pilot samples: every k-th pixel, k from the render's size."""
    replicas = len(SEED_KEYS)
    paths = min(npix * replicas, max(PILOT_LEAST, int(PILOT_SHARE * npix * spp)))
    step = max(1, npix * replicas // paths)
    return np.arange(0, npix, step, dtype=np.int64)


def relative_variances(first, second, pixels, light_a, light_b, half: int,
                       npix: int) -> tuple[float, float]:
    """(Vc, Vl) from the camera pilot's two replicas ((npix, 3) images of one sample in each of
    `pixels`, every k-th pixel from 0) and the light pilot's two halves' films ((npix, 3),
    `half` light paths each)."""
    a, b = first[pixels], second[pixels]
    # Each pilot pixel stands for the k pixels from it on; its mean (the weights' denominator)
    # is its camera mean and their light, averaged over MEAN_WIDTH neighbours: a pixel's own
    # samples would weigh a firefly by itself and cancel it. (Their median counts every
    # firefly in a dark pixel in full, 10 to 10^5 times the render's error, which leaves out
    # its largest terms; the mean counts a little less than the render's error.)
    step = int(pixels[1] - pixels[0]) if pixels.shape[0] > 1 else npix
    light = np.add.reduceat((light_a + light_b) / (2 * half), pixels, axis=0) / step
    m = _box((a + b) / 2 + light)
    weight = 1.0 / (m * m + EPS)
    # Independent samples a, b: a sample's variance is E[(a - b)^2] / 2.
    camera = float(((a - b) ** 2 / 2 * weight).sum()) * npix / pixels.shape[0]
    # A light path's variance in pixel p is E[(x - y)^2] half / 2 with x, y the halves' images
    # (films / half): (A - B)^2 / (2 half) in the films.
    per_path = (light_a - light_b) ** 2 / (2 * half)
    nearest = np.minimum(np.arange(npix) // step, pixels.shape[0] - 1)
    return camera, float((per_path * weight[nearest]).sum()) / npix


def _box(x: np.ndarray) -> np.ndarray:
    """Rows of x averaged over MEAN_WIDTH neighbours (fewer at the ends)."""
    n, reach = x.shape[0], MEAN_WIDTH // 2
    running = np.concatenate([np.zeros((1, x.shape[1])), np.cumsum(x, axis=0)])
    rows = np.arange(n)
    lo, hi = np.maximum(rows - reach, 0), np.minimum(rows + reach + 1, n)
    return (running[hi] - running[lo]) / (hi - lo)[:, None]


def measure(renderer) -> Budget:
    """Run the pilot of a Renderer whose light tracer splits the paths with its camera."""
    replicas = [renderer.with_seed(renderer.seed ^ key) for key in SEED_KEYS]
    npix = renderer.camera.width * renderer.camera.height
    pixels = pilot_pixels(npix, max(1, renderer.settings.spp))
    geometry = renderer.geometry

    def counted(fn):
        before = geometry.thread_rays()
        out = fn()
        return out, geometry.thread_rays() - before

    images = [np.zeros((npix, 3)) for _ in replicas]
    squares = np.zeros((npix, 3))            # trace_chunk's; the replicas give the variance
    rows = pixels.shape[0]
    # Light paths in each half: half a camera path's, as the light variance is summed over
    # every pixel and the camera's over the pilot's (a light path often costs more rays).
    half = max(1, rows // 2)
    light_a, light_b = np.zeros((npix, 3)), np.zeros((npix, 3))
    camera_rays = light_rays = 0
    with ThreadPoolExecutor(max_workers=renderer.threads) as pool:
        for replica, image in zip(replicas, images):      # sample 0 of a one-sample sequence
            for _, rays in pool.map(
                    lambda job, r=replica, im=image: counted(lambda: r.trace_chunk(
                        job[0], job[1], 1, 0, pixels, 1, im, squares, passes.NO_ROWS)),
                    passes.jobs(0, rows, 1)):
                camera_rays += rays
        for film, (begin, end) in ((light_a, (0, half)), (light_b, (half, 2 * half))):
            jobs = passes.jobs(begin, end, 1)
            splats = []
            for splat, rays in pool.map(
                    lambda job: counted(lambda: replicas[0].trace_light_chunk(0, job[0], job[1])),
                    jobs):
                splats.append(splat)
                light_rays += rays
            passes.add_splats(jobs, splats, 0, film, None, np.zeros(len(STATS), np.int64))
    vc, vl = relative_variances(*images, pixels, light_a, light_b, half, npix)
    cc, cl = camera_rays / (len(replicas) * rows), light_rays / (2 * half)
    return Budget(best_ratio(vc, cc, vl, cl), vc, vl, cc, cl)
