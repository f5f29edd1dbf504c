"""The equirectangular environment map (environment.py): Cycles' axis convention, the density of
its importance sampling against the samples (chi-square), its normalisation and the rotation."""
import math

import numba
import numpy as np
import pytest

from snell.tracer import environment
from snell.tracer.environment import (build_environment, direction_to_equirectangular,
                                      env_lookup, equirectangular_to_direction, pdf_env,
                                      sample_env)
from test_lobes import SphereGrid, integrate_bins
from test_bsdf import _chi2_pvalue


@numba.njit(cache=True)
def _samples(env, u, d, radiance, pdf):
    """sample_env for every row of u."""
    for i in range(u.shape[0]):
        w, L, p = sample_env(env, u[i, 0], u[i, 1])
        d[i, 0], d[i, 1], d[i, 2] = w
        radiance[i, 0], radiance[i, 1], radiance[i, 2] = L
        pdf[i] = p


@numba.njit(cache=True)
def _pdfs(env, d, pdf, radiance):
    """pdf_env and env_lookup at every row of d."""
    for i in range(d.shape[0]):
        w = (d[i, 0], d[i, 1], d[i, 2])
        pdf[i] = pdf_env(env, w)
        radiance[i, 0], radiance[i, 1], radiance[i, 2] = env_lookup(env, w)


def sample(env, n, seed):
    """n directions from sample_env: (directions, radiance, pdf)."""
    u = np.random.default_rng(seed).random((n, 2))
    d, radiance, pdf = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)
    _samples(env, u, d, radiance, pdf)
    return d, radiance, pdf


def evaluate(env, d):
    """(pdf_env, env_lookup) at every row of d."""
    d = np.ascontiguousarray(d.reshape(-1, 3))
    pdf, radiance = np.zeros(len(d)), np.zeros((len(d), 3))
    _pdfs(env, d, pdf, radiance)
    return pdf, radiance


def smooth_map(h=32, w=64, seed=3):
    """A random smooth positive map: exp of a few low-frequency waves in (u, v)."""
    rng = np.random.default_rng(seed)
    v, u = np.meshgrid((np.arange(h) + 0.5) / h, (np.arange(w) + 0.5) / w, indexing="ij")
    field = np.zeros((h, w))
    for _ in range(6):
        ku, kv = rng.integers(1, 4), rng.integers(1, 4)
        field += rng.normal() * np.cos(2 * np.pi * ku * u + rng.uniform(0, 2 * np.pi)) \
            * np.cos(np.pi * kv * v + rng.uniform(0, np.pi))
    tint = rng.uniform(0.3, 1.0, 3)
    return (np.exp(field)[:, :, None] * tint).astype(np.float32)


def bright_texel_map(h=32, w=64, row=9, col=40, background=0.01, bright=2000.0):
    """A dim constant map with one bright texel."""
    image = np.full((h, w, 3), background, np.float32)
    image[row, col] = bright
    return image


def uniform_directions(n, seed):
    """n uniform unit directions."""
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1)[:, None]


def test_axis_convention_matches_cycles():
    """Cycles' direction_to_equirectangular with Blender's default range (kernel/camera/
    projection.h: u = (atan2(y, x) - pi) / -2 pi, v = (acos(z) - pi) / -pi): +X is the image's
    centre (0.5, 0.5), +Y a quarter from its left edge (u = 0.25), -Y at 0.75, +Z its top row
    (v = 1), -Z its bottom row (v = 0)."""
    expected = {(1, 0, 0): (0.5, 0.5), (0, 1, 0): (0.25, 0.5), (0, -1, 0): (0.75, 0.5),
                (0, 0, 1): (None, 1.0), (0, 0, -1): (None, 0.0)}
    for d, (u, v) in expected.items():
        got_u, got_v = direction_to_equirectangular(tuple(map(float, d)))
        if u is not None:
            assert got_u == pytest.approx(u, abs=1e-12), d
        assert got_v == pytest.approx(v, abs=1e-12), d
    # -X is the seam: u = 0 or 1.
    assert direction_to_equirectangular((-1.0, 1e-300, 0.0))[0] == pytest.approx(0.0, abs=1e-12)
    assert direction_to_equirectangular((-1.0, -1e-300, 0.0))[0] == pytest.approx(1.0, abs=1e-12)
    for d in uniform_directions(100, 0):
        back = equirectangular_to_direction(*direction_to_equirectangular(tuple(d)))
        np.testing.assert_allclose(back, d, atol=1e-12)

    # In the image (top row first): column j holds j, row r holds 1000 r. +X falls between
    # columns W/2 - 1 and W/2 of the middle rows, +Z on row 0 and -Z on the last row.
    h, w = 16, 32
    image = np.zeros((h, w, 3), np.float32)
    image[:] = (np.arange(w)[None, :] + 1000.0 * np.arange(h)[:, None])[:, :, None]
    env = build_environment(image)
    assert env_lookup(env, (1.0, 0.0, 0.0))[0] == pytest.approx(w / 2 - 0.5 + 1000 * (h / 2 - 0.5))
    assert env_lookup(env, (0.0, 1.0, 0.0))[0] == pytest.approx(w / 4 - 0.5 + 1000 * (h / 2 - 0.5))
    assert env_lookup(env, (0.0, 0.0, 1.0))[0] // 1000 == 0
    assert env_lookup(env, (0.0, 0.0, -1.0))[0] // 1000 == h - 1


def test_constant_map_is_uniform():
    """A constant map's density is 1 / 4 pi at every texel centre (up to the midpoint rule's
    error in the sin(theta) weights, (pi / H)^2 / 24) and, within a row, varies only as
    sin(theta_row) / sin(theta), as in Cycles; its radiance is the constant times the strength."""
    h, w = 64, 128
    env = build_environment(np.full((h, w, 3), 0.5, np.float32), strength=3.0)
    rows, cols = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    u, v = (cols.ravel() + 0.5) / w, 1.0 - (rows.ravel() + 0.5) / h
    centres = np.array([equirectangular_to_direction(a, b) for a, b in zip(u, v)])
    pdf, radiance = evaluate(env, centres)
    np.testing.assert_allclose(pdf * 4 * np.pi, 1.0, rtol=(np.pi / h) ** 2 / 24 * 1.5)
    np.testing.assert_allclose(radiance, 1.5, rtol=1e-6)

    d = uniform_directions(20_000, 1)
    pdf, _ = evaluate(env, d)
    theta = np.arccos(np.clip(d[:, 2], -1, 1))
    row = np.minimum((theta / np.pi * h).astype(int), h - 1)
    sin_row = np.sin(np.pi * (row + 0.5) / h)
    np.testing.assert_allclose(pdf * 4 * np.pi * np.sin(theta) / sin_row, 1.0,
                               rtol=(np.pi / h) ** 2 / 24 * 1.5)


@pytest.mark.parametrize("image, rotation", [(smooth_map(), 0.0), (smooth_map(seed=5), 0.7),
                                             (bright_texel_map(), -1.1)])
def test_sample_pdf_is_pdf_env(image, rotation):
    """pdf_env at sample_env's directions is the density it returned, and its radiance is
    env_lookup's."""
    env = build_environment(image, strength=2.0, rotation=rotation)
    d, radiance, pdf = sample(env, 100_000, seed=7)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
    again, lookup = evaluate(env, d)
    assert (pdf > 0).all()
    np.testing.assert_allclose(again, pdf, rtol=1e-9)
    np.testing.assert_allclose(lookup, radiance, rtol=1e-12)


@pytest.mark.parametrize("image, rotation", [(smooth_map(), 0.0), (smooth_map(seed=5), 0.7),
                                             (bright_texel_map(), 0.0),
                                             (bright_texel_map(), -3 * np.pi / 8)],
                         ids=["smooth", "smooth-rotated", "bright-texel", "bright-rotated"])
def test_chi_square(image, rotation):
    """Sampled directions against pdf_env's probability of each bin of a (cos theta, phi) grid;
    four tests at a 1% family-wise level. The bright texel turns by a multiple of pi / 8, which
    keeps its edges on bin edges: an edge across a bin leaves the quadrature ~1e-3 off there,
    which 400000 samples see."""
    env = build_environment(image, rotation=rotation)
    grid = SphereGrid((0.0, 0.0, 1.0), 1)
    n = 400_000
    d, _, _ = sample(env, n, seed=11)
    observed = grid.histogram(d).ravel()
    probability = integrate_bins(lambda x: evaluate(env, x)[0], grid).ravel()
    # The 1 / sin(theta) of the pole rows costs this quadrature up to ~1e-3 in the pole bins
    # (test_pdf_integrates_to_one checks the total exactly): compare shapes.
    assert probability.sum() == pytest.approx(1.0, abs=2e-3)
    assert _chi2_pvalue(observed, probability / probability.sum() * n) > 0.01 / 4


@pytest.mark.parametrize("image", [smooth_map(), bright_texel_map()], ids=["smooth", "bright"])
def test_pdf_integrates_to_one(image):
    """The density integrates to 1 over the sphere: midpoint quadrature in (theta, phi) on a grid
    4x finer than the texels (pdf sin(theta) is constant on each texel, so it is exact there),
    and to 1e-3 on a (cos theta, phi) grid that ignores the texels (the pole rows' 1 / sin(theta)
    is hard on Gauss-Legendre in cos theta)."""
    h, w = image.shape[:2]
    env = build_environment(image)
    nt, npf = 4 * h, 4 * w
    theta = (np.arange(nt) + 0.5) * np.pi / nt
    phi = (np.arange(npf) + 0.5) * 2 * np.pi / npf
    t, p = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    pdf, _ = evaluate(env, d)
    total = np.sum(pdf.reshape(nt, npf) * np.sin(t)) * (np.pi / nt) * (2 * np.pi / npf)
    assert total == pytest.approx(1.0, abs=1e-9)
    grid = SphereGrid((0.0, 0.0, 1.0), 1, nw=20, nphi=40)
    assert integrate_bins(lambda x: evaluate(env, x)[0], grid).sum() == \
        pytest.approx(1.0, abs=2e-3)


def test_rotation_turns_the_map_about_z():
    """A Mapping node's Z rotation by a (Point type: texture coordinate = Rz(a) direction) moves
    a bright texel's direction by -a in azimuth, in sampling, lookup and density alike."""
    image = np.zeros((32, 64, 3), np.float32)
    image[12, 40] = 1.0
    plain = build_environment(image)
    for angle in (0.3, -2.0, 4.0):
        turned = build_environment(image, rotation=angle)
        d0, L0, p0 = sample(plain, 2000, seed=3)
        d1, L1, p1 = sample(turned, 2000, seed=3)
        az0, az1 = np.arctan2(d0[:, 1], d0[:, 0]), np.arctan2(d1[:, 1], d1[:, 0])
        np.testing.assert_allclose(np.angle(np.exp(1j * (az1 - az0 + angle))), 0.0, atol=1e-9)
        np.testing.assert_allclose(d1[:, 2], d0[:, 2], atol=1e-12)
        np.testing.assert_allclose(p1, p0, rtol=1e-9)
        np.testing.assert_allclose(L1, L0, rtol=1e-9)
        # The texel's centre, seen through the rotation.
        u, v = (40 + 0.5) / 64, 1.0 - (12 + 0.5) / 32
        c = np.array(equirectangular_to_direction(u, v))
        ca, sa = math.cos(angle), math.sin(angle)
        seen = (ca * c[0] + sa * c[1], -sa * c[0] + ca * c[1], c[2])
        assert env_lookup(turned, seen)[0] == pytest.approx(1.0)
        assert env_lookup(plain, tuple(c))[0] == pytest.approx(1.0)
        assert pdf_env(turned, seen) == pytest.approx(pdf_env(plain, tuple(c)))


def test_black_map_and_bad_images():
    """A black map still has valid tables (zero radiance); a wrong shape or NaN is refused."""
    env = build_environment(np.zeros((8, 16, 3), np.float32))
    d, radiance, pdf = sample(env, 1000, seed=1)
    assert (radiance == 0).all() and (pdf > 0).all()
    with pytest.raises(ValueError):
        build_environment(np.zeros((8, 16), np.float32))
    bad = np.zeros((8, 16, 3), np.float32)
    bad[1, 2, 0] = np.nan
    with pytest.raises(ValueError):
        build_environment(bad)


def test_memory_is_image_plus_distribution():
    """The map holds the float32 image (not a copy when it is already one) and the two CDFs."""
    image = smooth_map()
    env = build_environment(image)
    assert env.image is image or np.shares_memory(env.image, image)
    h, w = image.shape[:2]
    assert env.marginal.shape == (h + 1,) and env.marginal.dtype == np.float64
    assert env.conditional.shape == (h, w + 1) and env.conditional.dtype == np.float64
    assert environment.EnvironmentMap._fields == ("image", "marginal", "conditional", "strength",
                                                  "rot_cos", "rot_sin")
