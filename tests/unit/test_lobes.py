"""The rough BSDFs (lobes.py, microfacet.py, fresnel.py), tested as Mitsuba 3 tests its BSDFs:
sampled directions against the density that eval reports (chi-square), sample weights against
eval, reciprocity, white furnaces with the shipped albedo tables, and exact Fresnel values.
"""
import math
import zlib

import numba
import numpy as np
import pytest
from scipy import integrate, special

from snell.tracer import fresnel, lobes, microfacet, microfacet_albedo
from support.microfacet import STANDARD_ERRORS, TABLES, principled_bsdf
from support.stats import SphereGrid, integrate_bins, z_bound
from support.stats import chi2_pvalue as _chi2_pvalue

UP = (0.0, 0.0, 1.0)
WHITE = (1.0, 1.0, 1.0)
GGX, BECKMANN, MULTI_GGX = lobes.DIST_GGX, lobes.DIST_BECKMANN, lobes.DIST_MULTI_GGX


def direction(theta_deg, phi_deg=0.0):
    """A unit vector at polar angle theta from +z (the normal), azimuth phi."""
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return (math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t))


def microfacet_bsdf(dist, roughness, eta=1.0, reflects=True, transmits=False,
                    fresnel_model=lobes.NO_FRESNEL, f0=None, tint_b=None):
    """(lobes array, count) of one microfacet lobe with normal +z, weight 1."""
    rows = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
    lobes.new_microfacet(rows[0], UP, WHITE, dist, roughness * roughness, eta, reflects,
                         transmits, fresnel_model)
    if f0 is not None:
        lobes.set_vec(rows[0], lobes.F0, f0)
    if tint_b is not None:
        lobes.set_vec(rows[0], lobes.TINT_B, tint_b)
    return rows, 1


@numba.njit(cache=True)
def _sample(rows, count, wi, u, wo, weight, pdf, valid):
    """bsdf_sample for every row of u (u_pick, u0, u1)."""
    for i in range(u.shape[0]):
        d, w, p, _, ok = lobes.bsdf_sample(rows, count, (0.0, 0.0, 1.0), wi, u[i, 0], u[i, 1],
                                           u[i, 2])
        wo[i, 0], wo[i, 1], wo[i, 2] = d
        weight[i, 0], weight[i, 1], weight[i, 2] = w
        pdf[i], valid[i] = p, ok


@numba.njit(cache=True)
def _eval(rows, count, wi, wo, f, pdf):
    """bsdf_eval for every row of wo."""
    for i in range(wo.shape[0]):
        value, pdf[i] = lobes.bsdf_eval(rows, count, wi, (wo[i, 0], wo[i, 1], wo[i, 2]),
                                        lobes.ALL_EVENTS)
        f[i, 0], f[i, 1], f[i, 2] = value


@numba.njit(cache=True)
def _lobe_pairs(lobe, wi, u, out):
    """lobe_sample's (f rgb, pdf) and lobe_eval's at the sampled wo for every row of u: out[i]
    = (valid, f_sample rgb, pdf_sample, f_eval rgb, pdf_eval)."""
    for i in range(u.shape[0]):
        wo, f, pdf, _, singular, valid = lobes.lobe_sample(lobe, (0.0, 0.0, 1.0), wi, u[i, 0],
                                                           u[i, 1], u[i, 2])
        out[i, 0] = 1.0 if valid and not singular and pdf > 0.0 else 0.0
        out[i, 1], out[i, 2], out[i, 3], out[i, 4] = f[0], f[1], f[2], pdf
        g, q = lobes.lobe_eval(lobe, wi, wo)
        out[i, 5], out[i, 6], out[i, 7], out[i, 8] = g[0], g[1], g[2], q


def sample_bsdf(rows, count, wi, n, seed):
    """n samples of bsdf_sample from uniform numbers: (wo, weight, pdf, valid)."""
    u = np.random.default_rng(seed).random((n, 3))
    wo, weight, pdf, valid = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n), np.zeros(n, bool)
    _sample(rows, count, wi, u, wo, weight, pdf, valid)
    return wo, weight, pdf, valid


def eval_bsdf(rows, count, wi, wo):
    """bsdf_eval at every row of wo: (f |cos| rgb, pdf)."""
    wo = np.ascontiguousarray(wo.reshape(-1, 3))
    f, pdf = np.zeros((len(wo), 3)), np.zeros(len(wo))
    _eval(rows, count, wi, wo, f, pdf)
    return f, pdf


# ---------------------------------------------------------------------------------------------
# Chi-square: sampled directions against eval's density


def chi_square_pvalue(rows, count, wi, grid, n=400_000, seed=1):
    """p-value of the sampled directions against bsdf_eval's density over the grid's bins, with
    one more bin for the rejected samples (expected: 1 minus the density's integral)."""
    wo, _, _, valid = sample_bsdf(rows, count, wi, n, seed)
    observed = grid.histogram(wo[valid]).ravel()
    probability = integrate_bins(lambda d: eval_bsdf(rows, count, wi, d)[1], grid).ravel()
    missing = 1.0 - probability.sum()
    assert missing > -1e-4, missing                   # the density integrates to at most 1
    observed = np.append(observed, n - valid.sum())
    expected = np.append(probability, max(missing, 0.0)) * n
    return _chi2_pvalue(observed, expected)


def mirror(wi):
    """wi reflected about +z: the axis of a reflection lobe."""
    return (-wi[0], -wi[1], wi[2])


def pole_exponent(alpha):
    """The grid's k for a lobe of width alpha: puts its peak (1 - cos ~ alpha^2) at w ~ 1/4."""
    return max(1.0, math.log(alpha) / math.log(0.5))


def _reflection_cases():
    for dist in (GGX, BECKMANN):
        for rough in (0.1, 0.3, 0.7):
            for theta in (0.0, 45.0, 80.0):
                yield (f"{'ggx' if dist == GGX else 'beckmann'}-reflect-r{rough}-{theta:.0f}deg",
                       lambda d=dist, r=rough: microfacet_bsdf(d, r), theta, rough)


def _glass_cases():
    for dist in (GGX, BECKMANN):
        name = "ggx" if dist == GGX else "beckmann"
        for eta, side in ((1.5, "enter"), (1 / 1.5, "exit")):
            for rough in (0.3, 0.7):
                for theta in (30.0, 70.0):
                    yield (f"{name}-glass-{side}-r{rough}-{theta:.0f}deg",
                           lambda d=dist, e=eta, r=rough: microfacet_bsdf(
                               d, r, e, True, True, lobes.DIELECTRIC), theta, rough)
        for eta, side, theta in ((1.5, "enter", 45.0), (1 / 1.5, "exit", 30.0),
                                 (1 / 1.5, "exit", 60.0)):
            yield (f"{name}-refraction-{side}-r0.5-{theta:.0f}deg",
                   lambda d=dist, e=eta: microfacet_bsdf(d, 0.5, e, False, True), theta, 0.5)


def _metal_and_principled_cases():
    f0, tint = (0.95, 0.64, 0.54), (0.9, 0.7, 0.6)
    b = fresnel.f82_tint_b(f0, tint)
    for rough, theta in ((0.25, 60.0), (0.6, 20.0)):
        yield (f"f82-metal-r{rough}-{theta:.0f}deg",
               lambda r=rough: microfacet_bsdf(GGX, r, 1.0, True, False, lobes.F82, f0, b),
               theta, rough)
    principled = [("default", {}, True, 0.5), ("metallic-0.5", {"metallic": 0.5}, True, 0.5),
                  ("transmission-enter", {"transmission": 1.0, "roughness": 0.3}, True, 0.3),
                  ("transmission-exit", {"transmission": 1.0, "roughness": 0.3}, False, 0.3),
                  ("coat", {"coat": 1.0}, True, 0.03)]
    for name, params, entering, rough in principled:
        yield (f"principled-{name}-45deg",
               lambda wi, p=params, e=entering: principled_bsdf(wi, e, **p), 45.0, rough)


CHI_SQUARE_CASES = [*_reflection_cases(), *_glass_cases(), *_metal_and_principled_cases()]
# Significance 1% over all the cases (Bonferroni).
CHI_SQUARE_ALPHA = 0.01 / len(CHI_SQUARE_CASES)


@pytest.mark.parametrize("name,make,theta,rough", CHI_SQUARE_CASES,
                         ids=[c[0] for c in CHI_SQUARE_CASES])
def test_sampled_directions_follow_the_evaluated_density(name, make, theta, rough):
    """Chi-square goodness of fit of bsdf_sample's directions to bsdf_eval's pdf (400k samples,
    40 x 80 bins about the mirror direction, bins of expectation below 5 merged)."""
    wi = direction(theta, 30.0)
    rows, count = make(wi) if name.startswith("principled") else make()
    grid = SphereGrid(mirror(wi), pole_exponent(rough * rough))
    p = chi_square_pvalue(rows, count, wi, grid, seed=zlib.crc32(name.encode()))
    assert p > CHI_SQUARE_ALPHA, (name, p)


# ---------------------------------------------------------------------------------------------
# Sample weights against eval


# Sampling finds h first, eval from wi and wo: rounding apart, they agree. The coat's lobe (alpha
# 9e-4) loses most in 1 - cos^2 of a microfacet within a few alpha of the normal.
WEIGHT_RTOL = 1e-8


@pytest.mark.parametrize("name,make,theta,rough", CHI_SQUARE_CASES,
                         ids=[c[0] for c in CHI_SQUARE_CASES])
def test_sample_weights_equal_eval_over_pdf(name, make, theta, rough):
    """Every valid sample's throughput (f |cos| / pdf) and density equal bsdf_eval's at the
    sampled direction, to float rounding; so do each lobe's lobe_sample and lobe_eval."""
    wi = direction(theta, 30.0)
    rows, count = make(wi) if name.startswith("principled") else make()
    wo, weight, pdf, valid = sample_bsdf(rows, count, wi, 20_000, zlib.crc32(name.encode()))
    f, eval_pdf = eval_bsdf(rows, count, wi, wo[valid])
    assert valid.sum() > 300                      # most refractions leaving at 60 degrees are TIR
    np.testing.assert_allclose(pdf[valid], eval_pdf, rtol=WEIGHT_RTOL)
    np.testing.assert_allclose(weight[valid], f / eval_pdf[:, None], rtol=WEIGHT_RTOL, atol=1e-12)
    u = np.random.default_rng(zlib.crc32(name.encode()) + 1).random((20_000, 3))
    for i in range(count):
        out = np.zeros((len(u), 9))
        _lobe_pairs(rows[i], wi, u, out)
        ok = out[:, 0] == 1.0
        np.testing.assert_allclose(out[ok, 1:5], out[ok, 5:9], rtol=WEIGHT_RTOL, atol=1e-12)


# ---------------------------------------------------------------------------------------------
# Reciprocity


def _lobe_value(lobe, wi, wo):
    """lobe_eval's f |cos(n, wo)| (red channel)."""
    return lobes.lobe_eval(lobe, tuple(wi), tuple(wo))[0][0]


@pytest.mark.parametrize("dist", [GGX, BECKMANN])
@pytest.mark.parametrize("model", [lobes.NO_FRESNEL, lobes.DIELECTRIC])
def test_reflection_is_reciprocal(dist, model):
    """f(wi, wo) = f(wo, wi) for reflection without Fresnel or with the dielectric's (which
    depends on wi.h = wo.h only): value(wi, wo) / cos wo = value(wo, wi) / cos wi."""
    rng = np.random.default_rng(5 + dist + 10 * model)
    rows, _ = microfacet_bsdf(dist, 0.4, 1.5, True, False, model)
    checked = 0
    for _ in range(500):
        wi, wo = (direction(math.degrees(math.acos(rng.uniform(0.01, 1))), rng.uniform(0, 360))
                  for _ in range(2))
        forward, backward = _lobe_value(rows[0], wi, wo), _lobe_value(rows[0], wo, wi)
        # Beckmann's D underflows to 0 for microfacets far from the normal, both ways.
        assert (forward > 0.0) == (backward > 0.0)
        if forward > 0.0:
            assert forward / wo[2] == pytest.approx(backward / wi[2], rel=1e-10)
            checked += 1
    assert checked > 400


@pytest.mark.parametrize("dist", [GGX, BECKMANN])
@pytest.mark.parametrize("model", [lobes.NO_FRESNEL, lobes.DIELECTRIC])
def test_refraction_obeys_generalized_reciprocity(dist, model):
    """Cycles' BTDF is Walter et al.'s, without a 1 / eta^2 radiance scaling: it is reciprocal
    only in the generalized sense f_t(wi, wo) / eta_o^2 = f_t(wo, wi) / eta_i^2, here with
    eta_i = 1 on wi's side and eta_o = eta: seen from wo the surface's normal is -z and its
    relative index 1 / eta. Plain reciprocity is off by exactly eta^2."""
    eta = 1.5
    rng = np.random.default_rng(9 + dist + 10 * model)
    above, _ = microfacet_bsdf(dist, 0.5, eta, model == lobes.DIELECTRIC, True, model)
    below = above.copy()
    lobes.set_vec(below[0], lobes.NORMAL, (0.0, 0.0, -1.0))
    below[0, lobes.ETA] = 1.0 / eta
    checked = 0
    for _ in range(2000):
        wi = direction(math.degrees(math.acos(rng.uniform(0.01, 1))), rng.uniform(0, 360))
        wo = direction(180.0 - math.degrees(math.acos(rng.uniform(0.01, 1))), rng.uniform(0, 360))
        forward = _lobe_value(above[0], wi, wo) / abs(wo[2])
        backward = _lobe_value(below[0], wo, wi) / abs(wi[2])
        assert (forward > 0.0) == (backward > 0.0)    # the same microfacets refract both ways
        if forward > 0.0:
            assert forward / eta ** 2 == pytest.approx(backward, rel=1e-9)
            checked += 1
    assert checked > 300


# ---------------------------------------------------------------------------------------------
# White furnace: the albedo of one lobe against the tables


def furnace(rows, count, wi, n=200_000, seed=0):
    """(mean, standard error) of the red throughput over n samples (rejected samples count 0):
    the BSDF's albedo seen from wi."""
    _, weight, _, valid = sample_bsdf(rows, count, wi, n, seed)
    value = np.where(valid, weight[:, 0], 0.0)
    return value.mean(), value.std(ddof=1) / math.sqrt(n)


# (roughness column, mu row) cells of ggx_e (32 x 32).
GGX_CELLS = [(8, 20), (16, 9), (24, 28), (31, 5)]


def test_ggx_conductor_albedo_is_the_table_and_multiscatter_restores_it_to_one():
    """A GGX conductor without Fresnel reflects E(mu) < 1 (single scattering loses the light
    that would bounce again between microfacets): its furnace mean equals the table's E at
    grid points. Multiscatter GGX (scaled by 1 / E) reflects 1. Bounds: 5-sigma Sidak over
    the 2 x 4 checks, sigma combining the Monte Carlo and the table's standard errors."""
    z = z_bound(2 * len(GGX_CELLS))
    for x, y in GGX_CELLS:
        rough, mu = x / 31, y / 31
        wi = (math.sqrt(1 - mu * mu), 0.0, mu)
        table_e, table_se = TABLES.ggx_e[y, x], STANDARD_ERRORS["ggx_e"][y, x]
        rows, count = microfacet_bsdf(GGX, rough)
        mean, se = furnace(rows, count, wi, seed=x * 32 + y)
        assert table_e < 0.995 and abs(mean - table_e) < z * math.hypot(se, table_se), (x, y)
        rows = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
        count = lobes.setup_glossy(rows, TABLES, UP, wi, WHITE, rough, MULTI_GGX)
        mean, se = furnace(rows, count, wi, seed=x * 32 + y + 1)
        assert abs(mean - 1.0) < z * math.hypot(se, table_se / table_e), (x, y, mean)


# (index slice, mu row, roughness column) cells of the glass tables (16 x 16 x 16).
GLASS_CELLS = [(6, 5, 8), (6, 12, 15), (10, 3, 12), (3, 9, 5)]


def _glass(wi, entering, roughness, dist, ior):
    """The Glass BSDF, white, with no absorption."""
    rows = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
    count = lobes.setup_glass(rows, TABLES, UP, wi, entering, WHITE, WHITE, roughness, dist, ior)
    return rows, count


@pytest.mark.parametrize("entering", [True, False], ids=["enter", "exit"])
def test_rough_glass_conserves_energy_with_multiscatter_only(entering):
    """A white rough dielectric reflects and refracts all the light with Multiscatter GGX
    (reflection + transmission = 1 within the table's error, at its grid points), and with plain
    GGX loses the table's 1 - E, more the rougher it is."""
    name = "glass_e" if entering else "glass_inv_e"
    table = getattr(TABLES, name)
    z = z_bound(2 * len(GLASS_CELLS))
    for cell in GLASS_CELLS:
        zi, y, x = cell
        rough, mu, ior = x / 15, y / 15, microfacet_albedo.grid_ior(zi, 16)
        wi = (math.sqrt(1 - mu * mu), 0.0, mu)
        table_e, table_se = table[cell], STANDARD_ERRORS[name][cell]
        mean, se = furnace(*_glass(wi, entering, rough, MULTI_GGX, ior), wi, seed=sum(cell))
        assert abs(mean - 1.0) < z * math.hypot(se, table_se / table_e), (cell, mean)
        mean, se = furnace(*_glass(wi, entering, rough, GGX, ior), wi, seed=sum(cell) + 1)
        assert abs(mean - table_e) < z * math.hypot(se, table_se), (cell, mean, table_e)
    # The loss grows with roughness: 1 - E at ior 1.5, mu 0.5 (standard errors below 0.001).
    wi = direction(60.0)
    losses = [1.0 - furnace(*_glass(wi, entering, r, GGX, 1.5), wi, seed=7)[0]
              for r in (0.1, 0.4, 0.7, 1.0)]
    assert losses[0] < 0.005 and np.all(np.diff(losses) > 0.01), losses


# ---------------------------------------------------------------------------------------------
# Fresnel test vectors


COSINES = np.linspace(0.0, 1.0, 41)


@pytest.mark.parametrize("eta", [1.5, 1 / 1.5, 2.4, 1.01])
def test_remapped_fresnel_is_the_dielectric_at_its_own_f0(eta):
    f0 = fresnel.f0_from_ior(eta)
    for c in COSINES:
        remapped, cos_t = fresnel.fresnel_remapped(c, eta, (f0, f0, f0))
        exact, exact_cos_t = fresnel.fresnel_dielectric(c, eta)
        assert remapped == pytest.approx((exact,) * 3, abs=1e-15) and cos_t == exact_cos_t


def test_f82_tint_is_schlick_with_white_tint_and_scales_schlick_at_82_degrees():
    f0, tint = (0.95, 0.64, 0.54), (0.9, 0.7, 0.2)
    assert fresnel.f82_tint_b(f0, WHITE) == (0.0, 0.0, 0.0)
    b = fresnel.f82_tint_b(f0, tint)
    for c in COSINES:
        schlick = [fresnel.fresnel_schlick(c, fresnel.ior_from_f0(f))[0] for f in f0]
        assert fresnel.fresnel_f82(c, f0, (0.0, 0.0, 0.0)) == pytest.approx(schlick, abs=1e-12)
    schlick_82 = [f + (1 - f) * (6 / 7) ** 5 for f in f0]
    assert fresnel.fresnel_f82(1 / 7, f0, b) == pytest.approx(
        [t * s for t, s in zip(tint, schlick_82)], abs=1e-12)


@pytest.mark.parametrize("eta", [1.01, 1.1, 1.2, 1.33, 1.5, 2.0, 3.0,
                                 1 / 1.01, 1 / 1.1, 1 / 1.33, 1 / 1.5, 1 / 2.0, 1 / 3.0])
def test_dielectric_fss_fits_the_average_reflectance(eta):
    """Kulla and Conty's fit (Cycles' fresnel_dielectric_Fss, which Snell reproduces rather than
    the integral) against 2 int_0^1 F(mu) mu dmu by quadrature: within its accuracy, 0.0065
    (at eta 1.2; 0.0018 for eta < 1)."""
    exact, _ = integrate.quad(lambda mu: 2 * mu * fresnel.fresnel_dielectric(mu, eta)[0], 0, 1,
                              limit=200, points=[math.sqrt(max(1 - eta * eta, 0.0))])
    assert fresnel.dielectric_fss(eta) == pytest.approx(exact, abs=6.5e-3 if eta > 1 else 1.8e-3)


def test_f82_fss_is_the_exact_average():
    f0, tint = (0.95, 0.64, 0.54), (0.9, 0.7, 0.2)
    b = fresnel.f82_tint_b(f0, tint)
    exact = [integrate.quad(lambda mu: 2 * mu * fresnel.f82_channel(mu, f0[k], b[k]), 0, 1)[0]
             for k in range(3)]
    assert fresnel.f82_fss(f0, b) == pytest.approx(exact, abs=1e-10)


@pytest.mark.parametrize("ior", [1.0, 1.0001, 1.33, 1.5, 2.42, 10.0, 300.0])
def test_ior_from_f0_inverts_f0_from_ior(ior):
    assert fresnel.ior_from_f0(fresnel.f0_from_ior(ior)) == pytest.approx(ior, rel=1e-12)


# ---------------------------------------------------------------------------------------------
# Beckmann visible normals


def test_erfinv_matches_scipy_to_double_precision_and_stays_finite_at_one():
    tails = 1.0 - np.logspace(-16, -1, 61)
    x = np.concatenate([np.linspace(-0.999999, 0.999999, 2001), tails, -tails])
    ours = np.array([microfacet.erfinv(v) for v in x])
    np.testing.assert_allclose(ours, special.erfinv(x), rtol=2e-15, atol=1e-300)
    largest = special.erfinv(1.0 - 2.0 ** -53)                # 5.86
    assert microfacet.erfinv(1.0) == pytest.approx(largest, rel=1e-15)
    assert microfacet.erfinv(-1.0) == pytest.approx(-largest, rel=1e-15)


@pytest.mark.parametrize("u", [(0.0, 0.0), (0.0, 0.5), (0.5, 0.0), (1 - 2 ** -24, 1 - 2 ** -24)])
@pytest.mark.parametrize("theta", [0.0, 50.0, 89.0])
def test_beckmann_visible_normals_are_finite_at_the_corners_of_the_unit_square(u, theta):
    """Uniform numbers are 24-bit and include 0: u1 = 0 asked erfinv(-1), whose infinite slope
    made the microfacet normal NaN."""
    h = microfacet.sample_beckmann_visible_normal(direction(theta), 0.3, *u)
    assert np.all(np.isfinite(h)) and h[2] > 0.0 and math.isclose(np.linalg.norm(h), 1.0)
