"""Exact test vectors and sampling checks for the scattering functions."""
import math

import numpy as np
import pytest
from scipy import stats

from snell.tracer import bsdf


def test_fresnel_test_vectors():
    f0, _ = bsdf.fresnel_dielectric(np.array([1.0]), np.array([1.5]))
    assert f0[0] == pytest.approx(0.04, abs=1e-12)
    c80 = math.cos(math.radians(80.0))
    f80, cos_t = bsdf.fresnel_dielectric(np.array([c80]), np.array([1.5]))
    assert f80[0] == pytest.approx(0.387704354691473, rel=1e-12)
    assert math.degrees(math.acos(cos_t[0])) == pytest.approx(41.03641052520335, rel=1e-12)
    f60, _ = bsdf.fresnel_dielectric(np.array([0.5]), np.array([1.5]))
    assert f60[0] == pytest.approx(0.08919, abs=5e-6)


def test_total_internal_reflection_is_exact_and_finite():
    # Leaving glass (eta = 1/1.5): the critical angle is asin(1/1.5) = 41.81 degrees.
    crit = math.asin(1 / 1.5)
    angles = np.array([crit - 1e-6, crit + 1e-6, math.radians(60), math.radians(89.999)])
    f, cos_t = bsdf.fresnel_dielectric(np.cos(angles), np.full(4, 1 / 1.5))
    assert f[0] < 1.0 and np.all(f[1:] == 1.0) and np.all(cos_t[1:] == 0.0)
    fs, _ = bsdf.fresnel_schlick(np.cos(angles), np.full(4, 1 / 1.5))
    assert np.all(fs[1:] == 1.0) and np.all(np.isfinite(fs))


def test_schlick_matches_at_normal_incidence_and_differs_at_60_degrees():
    fs, _ = bsdf.fresnel_schlick(np.array([1.0, 0.5]), np.array([1.5, 1.5]))
    assert fs[0] == pytest.approx(0.04, abs=1e-12)
    assert fs[1] == pytest.approx(0.04 + 0.96 * 0.5 ** 5, abs=1e-12)   # 0.070, the doc's figure
    fe, _ = bsdf.fresnel_dielectric(np.array([0.5]), np.array([1.5]))
    assert fe[0] - fs[1] > 0.018


def _random_dirs(n, rng):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_reflect_and_refract_round_trips():
    rng = np.random.default_rng(1)
    n = np.tile([[0.0], [0.0], [1.0]], (1, 1000))
    d = _random_dirs(1000, rng).T
    d[2] = -np.abs(d[2])                             # arriving from above
    r = bsdf.reflect(d, n)
    assert np.allclose(bsdf.reflect(r, n), d, atol=1e-14)
    assert np.allclose(np.linalg.norm(r, axis=0), 1.0)
    eta = np.full(1000, 1.5)
    cos_i = -d[2]
    f, cos_t = bsdf.fresnel_dielectric(cos_i, eta)
    t = bsdf.refract(d, n, eta, cos_i, cos_t)
    assert np.allclose(np.linalg.norm(t, axis=0), 1.0, atol=1e-12)
    # Snell's law, then back out through the same interface gives the original direction.
    sin_i = np.linalg.norm(np.cross(d.T, n.T), axis=1)
    sin_t = np.linalg.norm(np.cross(t.T, n.T), axis=1)
    assert np.allclose(sin_i, 1.5 * sin_t, atol=1e-12)
    # The reversed refracted ray leaves the glass along the reversed incident ray.
    back_cos_i = -t[2]
    back_f, back_cos_t = bsdf.fresnel_dielectric(back_cos_i, 1 / eta)
    back = bsdf.refract(-t, -n, 1 / eta, back_cos_i, back_cos_t)
    assert np.allclose(back, -d, atol=1e-12)
    assert np.allclose(back_f, f, atol=1e-12)   # Fresnel is reciprocal


def _chi2_pvalue(observed, expected):
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


def test_cosine_hemisphere_sampling_chi_square():
    rng = np.random.default_rng(7)
    n_samples = 1_000_000
    normal = _random_dirs(1, rng)[0]
    wi, pdf = bsdf.sample_cosine_hemisphere(np.tile(normal[:, None], (1, n_samples)), rng.random((2, n_samples)))
    t, s = bsdf.orthonormal_basis(normal[:, None])
    z = normal @ wi
    phi = np.mod(np.arctan2(s[:, 0] @ wi, t[:, 0] @ wi), 2 * np.pi)
    assert np.all(z >= 0) and np.allclose(pdf, z / np.pi)
    nz, nphi = 51, 101   # odd on purpose, as in Mitsuba's chi2 tests
    hist, _, _ = np.histogram2d(z, phi, bins=[nz, nphi], range=[[0, 1], [0, 2 * np.pi]])
    z_edges = np.linspace(0, 1, nz + 1)
    # P(z in [a, b], phi cell) = (b^2 - a^2) / nphi for the cosine density.
    expected = np.repeat(((z_edges[1:] ** 2 - z_edges[:-1] ** 2) / nphi)[:, None], nphi, axis=1) * n_samples
    alpha = 1 - (1 - 0.01) ** (1 / 3)      # Sidak over the three chi-square tests in this file
    assert _chi2_pvalue(hist.ravel(), expected.ravel()) > alpha


@pytest.mark.parametrize("blades", [0, 5])
def test_aperture_sampling_is_uniform(blades):
    """Disk and polygon samples: inside the shape, chi-square uniform over its area."""
    rng = np.random.default_rng(11 + blades)
    n_samples = 400_000
    u = rng.random((2, n_samples))
    p = (bsdf.sample_regular_polygon(u, blades, 0.3) if blades else bsdf.sample_uniform_disk(u)).T
    r = np.linalg.norm(p, axis=1)
    assert r.max() <= 1.0 + 1e-12
    # Angular sectors: for a disk, equal-area rings (r^2 uniform) x sectors; for the polygon,
    # every one of its n triangles gets 1/n of the samples, spread evenly over r^2 / apothem^2.
    ang = np.mod(np.arctan2(p[:, 1], p[:, 0]) - (0.3 if blades else 0.0), 2 * np.pi)
    sectors = blades if blades else 16
    if blades:
        # Rotate so each sector is one triangle of the fan (corners at rotation + k 2pi/n +- pi/n).
        ang = np.mod(ang + np.pi / blades, 2 * np.pi)
        apothem = math.cos(math.pi / blades)
        radial = (r * np.cos(np.mod(ang, 2 * np.pi / blades) - np.pi / blades) / apothem) ** 2
    else:
        radial = r ** 2
    hist, _, _ = np.histogram2d(radial, ang, bins=[9, sectors], range=[[0, 1], [0, 2 * np.pi]])
    expected = np.full(hist.shape, n_samples / hist.size)
    alpha = 1 - (1 - 0.01) ** (1 / 3)
    assert _chi2_pvalue(hist.ravel(), expected.ravel()) > alpha


def test_valid_reflection_normal_lifts_reflections_to_cycles_threshold():
    """Bent normals put the mirror reflection exactly at height min(0.9 wi.ng, 0.01); others stay."""
    rng = np.random.default_rng(5)
    n = 100_000
    ng = np.tile([[0.0], [0.0], [1.0]], (1, n))
    th, ph = rng.uniform(0, 0.999 * np.pi / 2, n), rng.uniform(0, 2 * np.pi, n)
    wi = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
    tn, pn = rng.uniform(0, 0.6, n), rng.uniform(0, 2 * np.pi, n)
    normal = np.stack([np.sin(tn) * np.cos(pn), np.sin(tn) * np.sin(pn), np.cos(tn)])
    threshold = np.minimum(0.9 * wi[2], 0.01)
    before = bsdf.reflect(-wi, normal)[2]
    bent = bsdf.valid_reflection_normal(ng, wi, normal)
    after = bsdf.reflect(-wi, bent)[2]
    low = before < threshold
    assert 0.05 < low.mean() < 0.5
    assert np.allclose(after[low], threshold[low], atol=1e-9)
    assert np.array_equal(bent[:, ~low], normal[:, ~low])
    assert np.allclose(np.linalg.norm(bent, axis=0), 1.0, atol=1e-12)
