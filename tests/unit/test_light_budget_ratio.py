"""The light-budget pilot's arithmetic (tracer/light_budget.py): the ratio of least error for the
rays, and the variances it reads from the pilot's replicas and halves, on synthetic pilots of
known variance."""
import math

import numpy as np
import pytest

from snell.tracer import light_budget
from snell.tracer.light_budget import EPS, LEAST, MOST, PILOT_SAMPLES, best_ratio


def test_best_ratio_minimises_error_times_rays():
    vc, cc, vl, cl = 3.0, 7.0, 0.2, 2.5
    r = best_ratio(vc, cc, vl, cl)
    assert r == pytest.approx(math.sqrt(vl * cc / (vc * cl)))
    cost = lambda x: (vc + vl / x) * (cc + x * cl)  # noqa: E731
    assert cost(r) < cost(0.9 * r) and cost(r) < cost(1.1 * r)


def test_best_ratio_stays_in_its_range():
    assert best_ratio(1.0, 1.0, 1e-9, 1.0) == LEAST
    assert best_ratio(1e-9, 1.0, 1.0, 1.0) == MOST
    assert best_ratio(1.0, 1.0, 0.0, 1.0) == LEAST      # no light reached the pixels
    assert best_ratio(0.0, 1.0, 1.0, 1.0) == MOST       # a noiseless camera image


def _pilot(rng, npix, step, mu, sigma, correlation, light_mean, tau, half):
    """Synthetic replicas (two samples of each pilot pixel, correlated within a replica) and
    light halves: the camera's samples N(mu, sigma^2), the light image's per-path variance
    tau^2 about light_mean."""
    pixels = np.arange(0, npix, step)
    replicas = []
    for _ in range(2):
        a = rng.standard_normal((npix, 3))
        b = correlation * a + math.sqrt(1 - correlation ** 2) * rng.standard_normal((npix, 3))
        replicas.append([mu + sigma * a, mu + sigma * b])
    halves = [half * light_mean + math.sqrt(half) * tau * rng.standard_normal((npix, 3))
              for _ in range(2)]
    return replicas, pixels, halves


def test_relative_variances_of_independent_samples():
    rng = np.random.default_rng(5)
    npix, step, mu, sigma, light_mean, tau, half = 8192, 2, 0.4, 0.3, 0.1, 0.5, 4096
    replicas, pixels, (a, b) = _pilot(rng, npix, step, mu, sigma, 0.0, light_mean, tau, half)
    vc, vl, alpha = light_budget.relative_variances(replicas, pixels, a, b, half, npix, spp=64)
    weight = 1.0 / ((mu + light_mean) ** 2 + EPS)
    # 4096 pilot pixels x 3 channels x 2 samples of a chi-square term of one degree: a
    # relative standard error of 1.3% (4 of them allowed); the light's 8192 x 3, 0.9%.
    assert vc == pytest.approx(3 * npix * sigma ** 2 * weight, rel=0.052)
    assert vl == pytest.approx(3 * tau ** 2 * weight, rel=0.036)
    assert alpha < 0.1                       # independent samples: no stratification gain


def test_relative_variances_see_stratification():
    # Anticorrelated samples (correlation c): the mean of two has variance (1 + c) / 2 of a
    # sample's, a gain 1 / (1 + c) = 2^alpha.
    rng = np.random.default_rng(6)
    npix, c = 8192, -0.25
    replicas, pixels, (a, b) = _pilot(rng, npix, 1, 0.5, 0.2, c, 0.0, 0.0, 16)
    vc, _, alpha = light_budget.relative_variances(replicas, pixels, a, b, 16, npix, spp=16)
    assert alpha == pytest.approx(math.log2(1 / (1 + c)), abs=0.05)
    one = 3 * npix * 0.2 ** 2 / (0.5 ** 2 + EPS)
    assert vc == pytest.approx(one * 16 ** -alpha, rel=0.1)


def test_pilot_pixels_follow_the_render():
    small = light_budget.pilot_pixels(128 * 128, 4)
    big = light_budget.pilot_pixels(128 * 128, 4096)
    per_pixel = 2 * PILOT_SAMPLES
    assert small.shape[0] * per_pixel <= 2 * light_budget.PILOT_LEAST
    assert big.shape[0] == 128 * 128                      # at most every pixel
    assert light_budget.pilot_pixels(1, 16).tolist() == [0]
