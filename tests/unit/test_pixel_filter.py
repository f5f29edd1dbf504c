"""The pixel filters' table (tracer/pixel_filter.py): its samples follow Cycles' filter, the
density the light tracer splats with is the density of those samples, and a 1-pixel box is the
uniform offset Snell always used."""
from __future__ import annotations

import math

import numpy as np
import pytest

from support.stats import chi2_pvalue
from snell.tracer import pixel_filter
from snell.tracer.pixel_filter import make_filter

N = 200_000          # samples per chi-square test
BINS = 60
ALPHA = 1e-3         # each test's level: a correct table fails one run in a thousand
FILTERS = [("box", 1.0), ("box", 2.0), ("gaussian", 1.5), ("gaussian", 0.7),
           ("blackman_harris", 1.5), ("blackman_harris", 2.5)]


def samples(filt, n=N, seed=1):
    """n positions (offsets from the pixel's corner) drawn through the filter's table."""
    u = np.random.default_rng(seed).random(n)
    out = np.empty(n)
    pixel_filter.positions(filt, u, out)
    return out


def cycles_filter(kind, width):
    """Cycles' 1D filter as a density over offsets from the pixel's centre, from its written
    form (scene/film.cpp), independently of the table: (density, half support)."""
    if kind == "box":
        return (lambda v: 1.0 / width), width / 2
    if kind == "gaussian":
        # Cycles: v *= 6 / (3 width); exp(-2 v^2): sigma = width / 4, cut at 1.5 width.
        sigma, half = width / 4, 1.5 * width
        norm = math.erf(half / (sigma * math.sqrt(2)))
        return (lambda v: math.exp(-v * v / (2 * sigma * sigma)) / (sigma * math.sqrt(2 * math.pi))
                / norm), half
    # Blackman-Harris over [-width, width] (Cycles: width * 2, the window over it); the
    # coefficients' mean a0 normalises it.
    span = 2 * width

    def bh(v):
        a = 2 * math.pi * (v / span + 0.5)
        return (0.35875 - 0.48829 * math.cos(a) + 0.14128 * math.cos(2 * a)
                - 0.01168 * math.cos(3 * a)) / (0.35875 * span)
    return bh, width


def quantile_edges(kind, width, bins=BINS):
    """Bin edges (offsets from the pixel's corner) of equal probability under Cycles' filter.
    Equal-probability bins: the table resolves the filter in steps of 1/1022 of its mass, so
    its far tails (a step spread over a third of a pixel where the filter is nearly 0) are as
    coarse in Cycles as here, and a bin of fixed width there would test that coarseness."""
    f, half = cycles_filter(kind, width)
    x = np.linspace(-half, half, 40_001)
    pdf = np.array([f(v) for v in x])
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (pdf[1:] + pdf[:-1]) * np.diff(x))])
    cdf /= cdf[-1]
    edges = 0.5 + np.interp(np.linspace(0, 1, bins + 1), cdf, x)
    edges[0], edges[-1] = -np.inf, np.inf
    return edges


def chi2_against(kind, width, x):
    """The chi-square p-value of positions x against Cycles' filter (kind, width)."""
    observed, _ = np.histogram(x, quantile_edges(kind, width))
    return chi2_pvalue(observed, np.full(BINS, len(x) / BINS))


@pytest.mark.parametrize("kind,width", FILTERS)
def test_table_samples_follow_cycles_filter(kind, width):
    """The table's positions are distributed as Cycles' filter (chi-square, 60 bins of equal
    probability, 200k samples) within its support."""
    x = samples(make_filter(kind, width))
    _, half = cycles_filter(kind, width)
    assert 0.5 - half - 1e-9 <= x.min() and x.max() <= 0.5 + half + 1e-9
    assert chi2_against(kind, width, x) > ALPHA


@pytest.mark.parametrize("kind,width,other", [
    ("blackman_harris", 1.5, ("blackman_harris", 1.6)),     # width by 7%
    ("blackman_harris", 1.5, ("gaussian", 1.5 * 4 / 3.5)),  # type (similar spread)
    ("gaussian", 1.5, ("gaussian", 1.6)),
    ("blackman_harris", 1.5, ("box", 1.0)),
])
def test_chi_square_tells_filters_apart(kind, width, other):
    """The test above has power: a table of one filter fails against another's density."""
    assert chi2_against(*other, samples(make_filter(kind, width))) < ALPHA


def test_table_facts():
    """Cycles' spans: Box +- width / 2, Gaussian +- 1.5 width (sigma = width / 4),
    Blackman-Harris +- width; the tables are symmetric about the pixel's centre."""
    for kind, width, half in [("box", 1.5, 0.75), ("gaussian", 2.0, 3.0),
                              ("blackman_harris", 1.5, 1.5)]:
        filt = make_filter(kind, width)
        assert filt.reach == pytest.approx(half)
        assert np.allclose(filt.table + filt.table[::-1], 1.0)
        assert np.all(np.diff(filt.table) >= 0)
    assert make_filter("gaussian", 1.5).table.shape == (pixel_filter.FILTER_TABLE_SIZE - 1,)
    x = samples(make_filter("gaussian", 2.0))
    assert np.std(x) == pytest.approx(0.5, rel=0.01)          # sigma = width / 4


def test_one_pixel_box_is_the_uniform_offset():
    """A 1-pixel box gives back u itself (the samples Snell used before filters) and splats on
    the pixel the point lands in, weight 1."""
    u = np.random.default_rng(3).random(1000)
    out = np.empty_like(u)
    box = make_filter("box", 1.0)
    pixel_filter.positions(box, u, out)
    assert np.array_equal(out, u) and box.unit_box
    assert not make_filter("box", 1.5).unit_box
    pixels, contrib = pixel_filter.spread_splats(box, 4, 3, np.array([[2.3, 0.7]]),
                                                 np.array([[1.0, 2.0, 3.0]]))
    assert pixels.tolist() == [2 * 4 + 2] and contrib.tolist() == [[1.0, 2.0, 3.0]]


@pytest.mark.parametrize("kind,width", FILTERS)
def test_density_is_the_density_of_the_samples(kind, width):
    """What the light tracer splats with (density) integrates to 1 and its bins' integrals are
    the samples' distribution (chi-square): camera samples and splats estimate one filter."""
    filt = make_filter(kind, width)
    edges = np.linspace(0.5 - filt.reach, 0.5 + filt.reach, BINS + 1)
    fine = np.linspace(edges[0], edges[-1], BINS * 2000 + 1)
    d = np.empty_like(fine)
    pixel_filter.densities(filt, fine, d)
    mid = 0.5 * (d[1:] + d[:-1]) * np.diff(fine)               # trapezoids: 2000 per bin
    assert mid.sum() == pytest.approx(1.0, abs=2e-3)
    expected = N * mid.reshape(BINS, -1).sum(axis=1)
    observed, _ = np.histogram(samples(filt, seed=7), edges)
    assert chi2_pvalue(observed, expected) > ALPHA


def test_density_power():
    """A density of another width would fail the same chi-square."""
    filt, wrong = make_filter("blackman_harris", 1.5), make_filter("blackman_harris", 1.65)
    edges = np.linspace(0.5 - wrong.reach, 0.5 + wrong.reach, BINS + 1)
    fine = np.linspace(edges[0], edges[-1], BINS * 2000 + 1)
    d = np.empty_like(fine)
    pixel_filter.densities(wrong, fine, d)
    expected = N * (0.5 * (d[1:] + d[:-1]) * np.diff(fine)).reshape(BINS, -1).sum(axis=1)
    observed, _ = np.histogram(samples(filt, seed=7), edges)
    assert chi2_pvalue(observed, expected) < ALPHA


@pytest.mark.parametrize("kind,width", [("blackman_harris", 1.5), ("gaussian", 1.0),
                                        ("box", 1.3)])
def test_spread_keeps_the_light_on_average(kind, width):
    """A splat's weights over the pixels it reaches average 1 over points in a pixel (the filter
    integrates to 1), and reach exactly the pixels whose filter covers the point."""
    filt = make_filter(kind, width)
    rng = np.random.default_rng(5)
    raster = 10.0 + rng.random((4000, 2))            # inside pixel (10, 10) of a 24 x 24 image
    pixels, contrib = pixel_filter.spread_splats(filt, 24, 24, raster, np.ones((4000, 3)))
    assert contrib[:, 0].sum() / 4000 == pytest.approx(1.0, abs=0.02)
    cols, rows = pixels % 24, 23 - pixels // 24
    reach = math.ceil(filt.reach - 0.5)
    assert cols.min() >= 10 - reach and cols.max() <= 10 + reach
    assert rows.min() >= 10 - reach and rows.max() <= 10 + reach


def test_bad_filter_named():
    with pytest.raises(ValueError, match="pixel filter 'lanczos'"):
        make_filter("lanczos", 1.0)
    with pytest.raises(ValueError, match="filter width"):
        make_filter("gaussian", 0.0)
