"""Cycles' pixel filters (Box, Gaussian, Blackman-Harris) by filter importance sampling.

A camera sample's position in its pixel is drawn from the filter, one axis at a time (the 2D
filter is the product of two 1D ones), through a table that inverts the 1D filter's cumulative
distribution, as Cycles' film builds it (scene/film.cpp, util/math_cdf.h, FILTER_TABLE_SIZE):

- the filter over [0, W/2] with W = width (Box: 1), 3 width (Gaussian: exp(-2 (6 v / W)^2),
  so sigma = width / 4) or 2 width (Blackman-Harris, the window spanning [-width, width]);
- its CDF from a running sum of f at FILTER_TABLE_SIZE - 1 points 0 .. W/2, normalised;
- the symmetric inverse: entry half +- i, for u = i / half, is 0.5 (1 +- y), y the CDF's
  position of u (Cycles' upper-bound search and interpolation) scaled to [0, W].

Cycles' table has one more entry, which its symmetric inversion never writes (it stays 0); its
lookup then sends 1 sample in 1023 towards the pixel's corner. Snell's table is the 1023 entries
the inversion writes. Every sample still lands in its own pixel with weight 1, so a pixel is the
average of independent samples and the validator's statistics stay honest.

The Box filter is sampled exactly (u scaled about the pixel's centre, the table's distribution
without its rounding), so a 1-pixel box renders the same samples as before filters existed. The
light tracer, which reaches the image at a raster point rather than from a pixel, adds a
splat to every pixel whose filter reaches the point, weighted by the density the pixel's camera
samples have there (density, spread): the same pixel integral the camera samples estimate.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .jit import jit, jit_inline

FILTER_TABLE_SIZE = 1024          # Cycles' kernel/types.h
KINDS = ("box", "gaussian", "blackman_harris")   # settings.pixel_filter's values


class PixelFilter(NamedTuple):
    """A pixel filter for compiled code: positions in the pixel (0..1 is the pixel itself)."""
    box: bool               # the Box filter: sampled exactly, `table` unused
    width: float            # the Box's width
    table: np.ndarray       # (FILTER_TABLE_SIZE - 1,) float64: the inverse CDF, increasing
    reach: float            # positions lie within 0.5 +- reach
    unit_box: bool          # a 1-pixel box: a sample's position is its pixel's (no spreading)


def filter_function(kind: str, width: float):
    """(f(v), W): the 1D filter Cycles tabulates for a filter and width, and the span W its
    table covers (offsets from the pixel's centre within +- W / 2)."""
    if kind == "box":
        return (lambda v: np.ones_like(v)), width
    if kind == "gaussian":
        span = 3.0 * width
        return (lambda v: np.exp(-2.0 * (v * 6.0 / span) ** 2)), span
    if kind == "blackman_harris":
        span = 2.0 * width
        def blackman_harris(v):
            a = 2.0 * math.pi * (v / span + 0.5)
            return 0.35875 - 0.48829 * np.cos(a) + 0.14128 * np.cos(2 * a) - 0.01168 * np.cos(3 * a)
        return blackman_harris, span
    raise ValueError(f"pixel filter {kind!r}: expected one of {', '.join(KINDS)}")


def filter_table(kind: str, width: float) -> np.ndarray:
    """The inverse CDF of a filter, Cycles' symmetric table (positions in the pixel, increasing)."""
    f, span = filter_function(kind, width)
    n = FILTER_TABLE_SIZE
    x = (0.5 * span) * np.arange(n - 1) / (n - 2)
    cdf = np.concatenate([[0.0], np.cumsum(np.abs(f(x)))])
    cdf /= cdf[-1]
    cdf[-1] = 1.0
    half = (n - 1) // 2
    u = np.arange(half + 1) / half
    index = np.searchsorted(cdf, u, side="right")      # Cycles' upper_bound: first entry > u
    inside = index < n - 1
    safe = np.minimum(index, n - 2)
    t = np.where(inside, (u - cdf[safe]) / (cdf[safe + 1] - cdf[safe]), 0.0)
    index = np.where(inside, index, n - 1)
    y = (index + t) / (n - 1) * span
    table = np.empty(2 * half + 1)
    table[half:] = 0.5 * (1.0 + y)
    table[:half + 1] = 0.5 * (1.0 - y[::-1])
    return table


def make_filter(kind: str = "box", width: float = 1.0) -> PixelFilter:
    """The PixelFilter of a pixel_filter setting and its filter_width."""
    if not (width > 0.0 and math.isfinite(width)):
        raise ValueError(f"filter width {width!r}: expected a number above 0")
    box = kind == "box"
    table = np.array([0.5 - 0.5 * width, 0.5 + 0.5 * width]) if box else filter_table(kind, width)
    reach = max(0.5 - table[0], table[-1] - 0.5)
    return PixelFilter(box, float(width), table, float(reach), box and width == 1.0)


@jit_inline
def position(filt, u):
    """A position in the pixel along one axis for a uniform u in [0, 1): the filter's sample."""
    if filt.box:
        return u * filt.width + 0.5 * (1.0 - filt.width)   # exactly u for a 1-pixel box
    table = filt.table
    last = table.shape[0] - 1
    x = min(max(u, 0.0), 1.0) * last
    i = min(int(x), last)
    j = min(i + 1, last)
    t = x - i
    return (1.0 - t) * table[i] + t * table[j]


@jit_inline
def density(filt, p):
    """The density of position's samples at position p (1 / pixel; 0 outside the filter)."""
    table = filt.table
    last = table.shape[0] - 1
    if not (table[0] <= p < table[last]):
        return 0.0
    if filt.box:
        return 1.0 / filt.width
    lo, hi = 0, last          # table[lo] <= p < table[hi]: each segment holds 1 / last of samples
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if table[mid] <= p:
            lo = mid
        else:
            hi = mid
    return 1.0 / (last * (table[hi] - table[lo]))


@jit
def positions(filt, u, out):
    """position for each u (tests: the table's samples)."""
    for i in range(u.shape[0]):
        out[i] = position(filt, u[i])


@jit
def densities(filt, p, out):
    """density at each p (tests)."""
    for i in range(p.shape[0]):
        out[i] = density(filt, p[i])


@jit
def _pixel_span(filt, r, size):
    """The first and last pixel (clamped to 0 .. size - 1) whose filter reaches raster r."""
    first = max(int(math.ceil(r - filt.table[filt.table.shape[0] - 1])), 0)
    last = min(int(math.floor(r - filt.table[0])), size - 1)
    return first, last


@jit
def spread_count(filt, width, height, raster):
    """How many splats spread makes of the raster points (n, 2)."""
    count = 0
    for j in range(raster.shape[0]):
        x0, x1 = _pixel_span(filt, raster[j, 0], width)
        y0, y1 = _pixel_span(filt, raster[j, 1], height)
        count += max(x1 - x0 + 1, 0) * max(y1 - y0 + 1, 0)
    return count


@jit
def spread(filt, width, height, raster, contrib, pixels, out):
    """Splat contributions at raster points (n, 2) (x, y from the bottom) on every image pixel
    whose filter reaches them, weighted by its camera samples' density there, into pixels and
    out (rows: spread_count's; compiled code does not allocate), a point's splats in row-major
    order."""
    k = 0
    for j in range(raster.shape[0]):
        rx, ry = raster[j, 0], raster[j, 1]
        x0, x1 = _pixel_span(filt, rx, width)
        y0, y1 = _pixel_span(filt, ry, height)
        for yr in range(y1, y0 - 1, -1):            # image rows top first
            wy = density(filt, ry - yr)
            for xc in range(x0, x1 + 1):
                w = wy * density(filt, rx - xc)
                pixels[k] = (height - 1 - yr) * width + xc
                for c in range(3):
                    out[k, c] = contrib[j, c] * w
                k += 1


def spread_splats(filt, width, height, raster, contrib):
    """(pixels, contributions) of spread for raster points (n, 2) and their contributions (n, 3)."""
    raster = np.ascontiguousarray(raster, np.float64)
    count = spread_count(filt, width, height, raster)
    pixels, out = np.empty(count, np.int64), np.empty((count, 3))
    spread(filt, width, height, raster, np.ascontiguousarray(contrib, np.float64), pixels, out)
    return pixels, out
