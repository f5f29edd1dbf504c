"""The statistics harness the tests share, after Mitsuba 3's src/python/python/chi2.py.

- sidak(alpha, n): the per-test level that keeps a family of n independent tests at alpha.
- z_bound(n_tests): the two-sided normal quantile for a Sidak-corrected 1% family-wise error.
- chi2_pvalue(observed, expected): Pearson's chi-square goodness of fit, cells with expected
  count below 5 pooled (Mitsuba's rule), as the p-value.
- SphereGrid, integrate_bins: the bins over the sphere a sampled direction falls in, and the
  probability of each bin integrated from a density (adaptive Gauss-Legendre), for chi2_pvalue.
- renders_agree(scene, a, b), estimators_agree(scene, ...): per-pixel and whole-image z-tests
  between two unbiased estimators of one image (two renders' settings; NEE+MIS against BSDF
  sampling).
- region_z(image, variance, reference, ref_variance, region): z of two independent images'
  means over a region (the caustic region of the delta-lamp tests).

Binomial intervals (exact, Clopper-Pearson) are the package's own: snell.validation.false_alarms
(tests/validation/test_false_alarms.py holds them).
"""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

from snell.tracer.sampling import orthonormal_basis


def region_z(image, variance, reference, ref_variance, region):
    """z of the difference of two images' means over region (independent estimates)."""
    n = region.sum()
    diff = (image[region].sum() - reference[region].sum()) / n
    var = (variance[region].sum() + ref_variance[region].sum()) / n ** 2
    return diff / math.sqrt(var)


def sidak(alpha, n):
    """The per-test level that keeps n independent tests at family-wise error alpha."""
    return 1 - (1 - alpha) ** (1 / n)


def z_bound(n_tests):
    """Two-sided normal quantile for a Sidak-corrected 1% family-wise error over n_tests."""
    alpha = 1 - (1 - 0.01) ** (1 / n_tests)
    return stats.norm.isf(alpha / 2)


def chi2_pvalue(observed, expected):
    """Mitsuba-style: pool cells with expected < 5, then the chi-square survival function."""
    order = np.argsort(expected)
    obs, exp = observed[order].astype(float), expected[order]
    pooled_o, pooled_e, acc_o, acc_e = [], [], 0.0, 0.0
    for o, e in zip(obs, exp):
        acc_o += o
        acc_e += e
        if acc_e >= 5:
            pooled_o.append(acc_o)
            pooled_e.append(acc_e)
            acc_o = acc_e = 0.0
    if acc_e > 0:
        pooled_o[-1] += acc_o
        pooled_e[-1] += acc_e
    pooled_o, pooled_e = np.array(pooled_o), np.array(pooled_e)
    chi2 = np.sum((pooled_o - pooled_e) ** 2 / pooled_e)
    return stats.chi2.sf(chi2, len(pooled_o) - 1)


class SphereGrid:
    """Bins over the whole sphere in (w, phi) about a pole `axis`: cos(angle to the axis) =
    1 - 2 w^k, phi the azimuth about it. k = 1 is a uniform grid in (cos theta, phi); a larger k
    packs the bins towards the pole, for the narrow lobes centred there."""

    def __init__(self, axis, k, nw=40, nphi=80):
        self.axis = np.array(axis)
        self.t, self.s = (np.array(v) for v in orthonormal_basis(tuple(axis)))
        self.k, self.nw, self.nphi = k, nw, nphi

    def coordinates(self, d):
        """(w, phi) of unit directions d (n, 3)."""
        c = np.clip(d @ self.axis, -1.0, 1.0)
        w = np.clip((1.0 - c) / 2.0, 0.0, 1.0) ** (1.0 / self.k)
        return w, np.mod(np.arctan2(d @ self.s, d @ self.t), 2 * np.pi)

    def directions(self, w, phi):
        """Unit directions at (w, phi) and the Jacobian d(solid angle) / dw dphi."""
        c = 1.0 - 2.0 * w ** self.k
        r = np.sqrt(np.maximum(1.0 - c * c, 0.0))
        d = (np.multiply.outer(r * np.cos(phi), self.t) + np.multiply.outer(r * np.sin(phi), self.s)
             + np.multiply.outer(c, self.axis))
        return d, 2.0 * self.k * w ** (self.k - 1.0)

    def histogram(self, d):
        """Sample counts per bin (nw, nphi)."""
        w, phi = self.coordinates(d)
        counts, _, _ = np.histogram2d(w, phi, bins=[self.nw, self.nphi],
                                      range=[[0, 1], [0, 2 * np.pi]])
        return counts


GAUSS_X, GAUSS_W = np.polynomial.legendre.leggauss(4)


def _integrate_rects(pdf, grid, w0, w1, p0, p1):
    """4 x 4 Gauss-Legendre integral of pdf over the rectangles [w0, w1] x [p0, p1] of (w, phi)."""
    w = 0.5 * (w0 + w1)[:, None, None] + 0.5 * (w1 - w0)[:, None, None] * GAUSS_X[:, None]
    phi = 0.5 * (p0 + p1)[:, None, None] + 0.5 * (p1 - p0)[:, None, None] * GAUSS_X
    d, jacobian = grid.directions(*np.broadcast_arrays(w, phi))
    values = pdf(d).reshape(len(w0), 4, 4) * jacobian
    return 0.25 * (w1 - w0) * (p1 - p0) * np.einsum("nij,i,j->n", values, GAUSS_W, GAUSS_W)


def integrate_bins(pdf, grid, tolerance=1e-7, max_depth=6):
    """The probability of every bin: Gauss-Legendre on each bin, split into quarters where the
    quarters' sum disagrees with the whole by more than `tolerance` (the density has kinks and
    jumps: the horizon, total internal reflection)."""
    iw, ip = np.meshgrid(np.arange(grid.nw), np.arange(grid.nphi), indexing="ij")
    dw, dp = 1.0 / grid.nw, 2 * np.pi / grid.nphi
    owner = (iw * grid.nphi + ip).ravel()
    w0, p0 = iw.ravel() * dw, ip.ravel() * dp
    w1, p1 = w0 + dw, p0 + dp
    whole = _integrate_rects(pdf, grid, w0, w1, p0, p1)
    total = np.zeros(grid.nw * grid.nphi)
    for depth in range(max_depth + 1):
        mw, mp = 0.5 * (w0 + w1), 0.5 * (p0 + p1)
        quarters = [(w0, mw, p0, mp), (mw, w1, p0, mp), (w0, mw, mp, p1), (mw, w1, mp, p1)]
        parts = [_integrate_rects(pdf, grid, *q) for q in quarters]
        refined = sum(parts)
        settled = (np.abs(refined - whole) <= tolerance) | (depth == max_depth)
        np.add.at(total, owner[settled], refined[settled])
        keep = ~settled
        owner = np.tile(owner[keep], 4)
        w0, w1, p0, p1 = (np.concatenate([q[j][keep] for q in quarters]) for j in range(4))
        whole = np.concatenate([part[keep] for part in parts])
        tolerance /= 4.0
        if not len(owner):
            break
    return total.reshape(grid.nw, grid.nphi)


def estimators_agree(scene, spp_mis, spp_bsdf, region=None, light_vertices=None):
    """Per-pixel and whole-image z-tests between NEE+MIS and BSDF-only renders of one scene."""
    vertices = {} if light_vertices is None else {"light_vertices": light_vertices}
    renders_agree(scene, {"spp": spp_mis, **vertices}, {"next_event": False, "spp": spp_bsdf},
                  region)


def renders_agree(scene, settings_a, settings_b, region=None):
    """Per-pixel and whole-image z-tests between two renders of one scene by unbiased
    estimators (settings_a, settings_b: each one's render settings over the scene's)."""
    from snell.tracer.integrator import Renderer
    a = Renderer(scene, scene.settings(**settings_a)).render()
    b = Renderer(scene, scene.settings(**settings_b)).render()
    ma, mb = a.mean().astype(np.float64), b.mean().astype(np.float64)
    va, vb = a.variance_of_mean(), b.variance_of_mean()
    if region is not None:
        ma, mb, va, vb = ma[region], mb[region], va[region], vb[region]
    var = va + vb
    # A pixel where either estimator saw no variation has no usable variance estimate (a rare
    # event never sampled): compare only pixels where both did; the image means cover the rest.
    noisy = (va > 0) & (vb > 0)
    assert noisy.mean() > 0.5
    z = np.abs(ma - mb)[noisy] / np.sqrt(var[noisy])
    assert np.mean(z < z_bound(z.size)) >= 0.9975, np.sort(z)[-5:]
    for c in range(3):
        diff = ma[..., c].mean() - mb[..., c].mean()
        se = math.sqrt(va[..., c].sum() + vb[..., c].sum()) / ma[..., c].size
        assert abs(diff) < z_bound(3) * se, (c, diff, se, ma[..., c].mean())