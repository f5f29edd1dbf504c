"""The light-budget pilot's arithmetic (tracer/light_budget.py): the ratio of least error for the
rays, and the variances it reads from the pilot's replicas and halves, on synthetic pilots of
known variance."""
import math

import numpy as np
import pytest

from snell.tracer import light_budget
from snell.tracer.light_budget import EPS, LEAST, MOST, best_ratio


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


def _pilot(rng, npix, step, mu, sigma, light_mean, tau, half):
    """Synthetic replicas (one sample of each pilot pixel each) and light halves: the camera's
    samples N(mu, sigma^2), the light image's per-path variance tau^2 about light_mean."""
    pixels = np.arange(0, npix, step)
    first, second = (mu + sigma * rng.standard_normal((npix, 3)) for _ in range(2))
    halves = [half * light_mean + math.sqrt(half) * tau * rng.standard_normal((npix, 3))
              for _ in range(2)]
    return first, second, pixels, halves


def test_relative_variances():
    rng = np.random.default_rng(5)
    # The weights come from means of 9 noisy pixels: 1 / m^2 is then high by about 3 var(m) /
    # m^2 (0.2% here, 6% at sigma 0.3).
    npix, step, mu, sigma, light_mean, tau, half = 8192, 2, 0.4, 0.1, 0.1, 0.5, 4096
    first, second, pixels, (a, b) = _pilot(rng, npix, step, mu, sigma, light_mean, tau, half)
    vc, vl = light_budget.relative_variances(first, second, pixels, a, b, half, npix)
    weight = 1.0 / ((mu + light_mean) ** 2 + EPS)
    # 4096 pilot pixels x 3 channels of a chi-square term of one degree: a relative standard
    # error of 1.3% (4 of them allowed); the light's 8192 x 3, 0.9%.
    assert vc == pytest.approx(3 * npix * sigma ** 2 * weight, rel=0.052)
    assert vl == pytest.approx(3 * tau ** 2 * weight, rel=0.036)


def test_a_firefly_is_weighed_by_its_neighbours_mean():
    """A pixel's weight is its neighbours' mean, not its own samples': one sample of 1000 in a
    grey image counts its whole square."""
    npix = 64
    first, second = np.full((npix, 3), 0.5), np.full((npix, 3), 0.5)
    first[30] = 1000.0
    zero = np.zeros((npix, 3))
    vc, _ = light_budget.relative_variances(first, second, np.arange(npix), zero, zero, 1, npix)
    neighbours = (8 * 0.5 + (1000.0 + 0.5) / 2) / 9
    assert vc == pytest.approx(3 * (999.5 ** 2 / 2) / (neighbours ** 2 + EPS), rel=1e-6)


def test_pilot_pixels_follow_the_render():
    small = light_budget.pilot_pixels(128 * 128, 4)
    big = light_budget.pilot_pixels(128 * 128, 4096)
    assert small.shape[0] * len(light_budget.SEED_KEYS) <= 2 * light_budget.PILOT_LEAST
    assert big.shape[0] == 128 * 128                      # at most every pixel
    assert light_budget.pilot_pixels(1, 16).tolist() == [0]
