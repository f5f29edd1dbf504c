"""Exact test vectors and sampling checks for the scattering functions."""
import math

import numba
import numpy as np
import pytest

from snell.tracer import fresnel, sampling, specular
from snell.tracer.material_kinds import GLASS, MIRROR, REFRACTION
from support.stats import chi2_pvalue as _chi2_pvalue
from support.stats import sidak


def test_fresnel_test_vectors():
    f0, _ = fresnel.fresnel_dielectric(1.0, 1.5)
    assert f0 == pytest.approx(0.04, abs=1e-12)
    c80 = math.cos(math.radians(80.0))
    f80, cos_t = fresnel.fresnel_dielectric(c80, 1.5)
    assert f80 == pytest.approx(0.387704354691473, rel=1e-12)
    assert math.degrees(math.acos(cos_t)) == pytest.approx(41.03641052520335, rel=1e-12)
    f60, _ = fresnel.fresnel_dielectric(0.5, 1.5)
    assert f60 == pytest.approx(0.08919, abs=5e-6)


def test_total_internal_reflection_is_exact_and_finite():
    # Leaving glass (eta = 1/1.5): the critical angle is asin(1/1.5) = 41.81 degrees.
    crit = math.asin(1 / 1.5)
    angles = [crit - 1e-6, crit + 1e-6, math.radians(60), math.radians(89.999)]
    exact = [fresnel.fresnel_dielectric(math.cos(a), 1 / 1.5) for a in angles]
    assert exact[0][0] < 1.0 and all(f == 1.0 and cos_t == 0.0 for f, cos_t in exact[1:])
    schlick = [fresnel.fresnel_schlick(math.cos(a), 1 / 1.5)[0] for a in angles]
    assert all(f == 1.0 for f in schlick[1:]) and all(math.isfinite(f) for f in schlick)


def test_schlick_matches_at_normal_incidence_and_differs_at_60_degrees():
    assert fresnel.fresnel_schlick(1.0, 1.5)[0] == pytest.approx(0.04, abs=1e-12)
    fs = fresnel.fresnel_schlick(0.5, 1.5)[0]
    assert fs == pytest.approx(0.04 + 0.96 * 0.5 ** 5, abs=1e-12)   # 0.070, the doc's figure
    assert fresnel.fresnel_dielectric(0.5, 1.5)[0] - fs > 0.018
    assert fresnel.fresnel(fresnel.SCHLICK, 0.5, 1.5) == fresnel.fresnel_schlick(0.5, 1.5)
    assert fresnel.fresnel(fresnel.EXACT, 0.5, 1.5) == fresnel.fresnel_dielectric(0.5, 1.5)


def _random_dirs(n, rng):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_reflect_and_refract_round_trips():
    rng = np.random.default_rng(1)
    n = (0.0, 0.0, 1.0)
    for d in _random_dirs(300, rng):
        d = (d[0], d[1], -abs(d[2]))                     # arriving from above
        r = specular.reflect(d, n)
        assert np.allclose(specular.reflect(r, n), d, atol=1e-14)
        assert np.linalg.norm(r) == pytest.approx(1.0)
        cos_i = -d[2]
        f, cos_t = fresnel.fresnel_dielectric(cos_i, 1.5)
        t = specular.refract(d, n, 1.5, cos_i, cos_t)
        assert np.linalg.norm(t) == pytest.approx(1.0, abs=1e-12)
        # Snell's law, then back out through the same interface gives the original direction.
        sin_i, sin_t = np.linalg.norm(np.cross(d, n)), np.linalg.norm(np.cross(t, n))
        assert sin_i == pytest.approx(1.5 * sin_t, abs=1e-12)
        back_f, back_cos_t = fresnel.fresnel_dielectric(-t[2], 1 / 1.5)
        back = specular.refract(tuple(-np.array(t)), (0.0, 0.0, -1.0), 1 / 1.5, -t[2], back_cos_t)
        assert np.allclose(back, -np.array(d), atol=1e-12)
        assert back_f == pytest.approx(f, abs=1e-12)   # Fresnel is reciprocal


def test_specular_sampling_events_and_cycles_rejections():
    """Glass reflects with probability F (u < F), refracts otherwise; a refraction-only surface
    gives nothing under total internal reflection; a shading normal facing away is rejected."""
    up = (0.0, 0.0, 1.0)
    c = math.cos(math.radians(60))
    d = (math.sin(math.radians(60)), 0.0, -c)
    f, _ = fresnel.fresnel_dielectric(c, 1.5)
    white, tint = (1.0, 1.0, 1.0), (0.5, 0.6, 0.7)
    out, w, event, valid, chose_by = specular.sample_specular(GLASS, d, up, up, True, white,
                                                              tint, 1.5, fresnel.EXACT, 0.999 * f)
    assert event == specular.REFLECTED and valid and w == white and out[2] > 0
    assert chose_by == f          # the probability it reflected with (the Fresnel split's F)
    out, w, event, valid, _ = specular.sample_specular(GLASS, d, up, up, True, white, tint, 1.5,
                                                       fresnel.EXACT, 1.001 * f)
    assert event == specular.TRANSMITTED and valid and w == tint and out[2] < 0
    inside = (math.sin(math.radians(60)), 0.0, -c)    # leaving the glass beyond the critical angle
    _, w, event, _, _ = specular.sample_specular(REFRACTION, inside, up, up, False, white, white,
                                                 1.5, fresnel.EXACT, 0.5)
    assert event == specular.TIR_ABSORBED and w == (0.0, 0.0, 0.0)
    _, _, event, valid, _ = specular.sample_specular(GLASS, inside, up, up, False, white, white,
                                                     1.5, fresnel.EXACT, 0.5)
    assert event == specular.TIR and valid
    away = (0.0, 0.0, -1.0)                           # shading normal facing away from the viewer
    _, _, _, valid, chose_by = specular.sample_specular(MIRROR, d, up, away, True, white, white,
                                                        1.0, fresnel.EXACT, 0.5)
    assert not valid and chose_by == 1.0


def _projected_solid_angle(direction, theta, phi, h=1e-5):
    """|cos| dw per dtheta dphi of the direction field at (theta, phi), by central differences."""
    d_theta = (np.array(direction(theta + h, phi)) - direction(theta - h, phi)) / (2 * h)
    d_phi = (np.array(direction(theta, phi + h)) - direction(theta, phi - h)) / (2 * h)
    return abs(direction(theta, phi)[2]) * np.linalg.norm(np.cross(d_theta, d_phi))


@pytest.mark.parametrize("entering", [True, False])
def test_light_refraction_scale_is_the_refracted_bundles_projected_solid_angle(entering):
    """A light path's extra factor at a refraction is (n_i / n_t)^2, the ratio of a bundle's
    projected solid angle |cos| dw after and before the interface, measured here by refracting
    a small bundle of directions with specular.refract (the flux a light path carries spreads
    over it, the radiance Cycles carries does not). IOR 1.45 entering (0.4756) and leaving
    (2.1025) the glass, at incidences up to 40 degrees (the critical angle leaving is 43.6).
    Deliberate errors: the factor n_i / n_t (not squared) is off by 31% (0.690 against 0.476)
    and 45% (1.450 against 2.103); the factor inverted, by a factor 4.4."""
    ior = 1.45
    eta = ior if entering else 1.0 / ior
    normal = (0.0, 0.0, 1.0)                           # facing the arriving light

    def incident(theta, phi):
        return (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi),
                -math.cos(theta))

    def refracted(theta, phi):
        d = incident(theta, phi)
        _, cos_t = fresnel.fresnel_dielectric(-d[2], eta)
        return specular.refract(d, normal, eta, -d[2], cos_t)

    scale = specular.light_refraction_scale(ior, entering)
    assert scale == pytest.approx(1 / 1.45 ** 2 if entering else 1.45 ** 2, rel=1e-12)
    for degrees in (5.0, 20.0, 40.0):
        theta = math.radians(degrees)
        ratio = (_projected_solid_angle(refracted, theta, 0.3)
                 / _projected_solid_angle(incident, theta, 0.3))
        assert ratio == pytest.approx(scale, rel=1e-6), degrees


@numba.njit(cache=True)
def _cosine_samples(normal, u):
    n = u.shape[1]
    wi, pdf = np.empty((3, n)), np.empty(n)
    for i in range(n):
        w, pdf[i] = sampling.sample_cosine_hemisphere(normal, u[0, i], u[1, i])
        wi[0, i], wi[1, i], wi[2, i] = w
    return wi, pdf


def test_cosine_hemisphere_sampling_chi_square():
    rng = np.random.default_rng(7)
    n_samples = 1_000_000
    normal = _random_dirs(1, rng)[0]
    wi, pdf = _cosine_samples(tuple(normal), rng.random((2, n_samples)))
    t, s = (np.array(v) for v in sampling.orthonormal_basis(tuple(normal)))
    z = normal @ wi
    phi = np.mod(np.arctan2(s @ wi, t @ wi), 2 * np.pi)
    assert np.all(z >= 0) and np.allclose(pdf, z / np.pi)
    nz, nphi = 51, 101   # odd on purpose, as in Mitsuba's chi2 tests
    hist, _, _ = np.histogram2d(z, phi, bins=[nz, nphi], range=[[0, 1], [0, 2 * np.pi]])
    z_edges = np.linspace(0, 1, nz + 1)
    # P(z in [a, b], phi cell) = (b^2 - a^2) / nphi for the cosine density.
    expected = np.repeat(((z_edges[1:] ** 2 - z_edges[:-1] ** 2) / nphi)[:, None], nphi, axis=1) * n_samples
    alpha = sidak(0.01, 3)      # Sidak over the three chi-square tests in this file
    assert _chi2_pvalue(hist.ravel(), expected.ravel()) > alpha


@numba.njit(cache=True)
def _aperture_samples(u, blades, rotation):
    out = np.empty((u.shape[1], 2))
    for i in range(u.shape[1]):
        if blades:
            out[i] = sampling.sample_regular_polygon(u[0, i], u[1, i], blades, rotation)
        else:
            out[i] = sampling.sample_uniform_disk(u[0, i], u[1, i])
    return out


@pytest.mark.parametrize("blades", [0, 5])
def test_aperture_sampling_is_uniform(blades):
    """Disk and polygon samples: inside the shape, chi-square uniform over its area."""
    rng = np.random.default_rng(11 + blades)
    n_samples = 400_000
    u = rng.random((2, n_samples))
    p = _aperture_samples(u, blades, 0.3)
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
    alpha = sidak(0.01, 3)
    assert _chi2_pvalue(hist.ravel(), expected.ravel()) > alpha


@numba.njit(cache=True)
def _bent_normals(ng, wi, normal):
    n = wi.shape[1]
    before, bent, after = np.empty(n), np.empty((3, n)), np.empty(n)
    for i in range(n):
        w = (wi[0, i], wi[1, i], wi[2, i])
        nrm = (normal[0, i], normal[1, i], normal[2, i])
        before[i] = specular.reflect((-w[0], -w[1], -w[2]), nrm)[2]
        b = specular.valid_reflection_normal(ng, w, nrm)
        bent[0, i], bent[1, i], bent[2, i] = b
        after[i] = specular.reflect((-w[0], -w[1], -w[2]), b)[2]
    return before, bent, after


def test_valid_reflection_normal_lifts_reflections_to_cycles_threshold():
    """Bent normals put the mirror reflection exactly at height min(0.9 wi.ng, 0.01); others stay."""
    rng = np.random.default_rng(5)
    n = 100_000
    th, ph = rng.uniform(0, 0.999 * np.pi / 2, n), rng.uniform(0, 2 * np.pi, n)
    wi = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
    tn, pn = rng.uniform(0, 0.6, n), rng.uniform(0, 2 * np.pi, n)
    normal = np.stack([np.sin(tn) * np.cos(pn), np.sin(tn) * np.sin(pn), np.cos(tn)])
    threshold = np.minimum(0.9 * wi[2], 0.01)
    before, bent, after = _bent_normals((0.0, 0.0, 1.0), wi, normal)
    low = before < threshold
    assert 0.05 < low.mean() < 0.5
    assert np.allclose(after[low], threshold[low], atol=1e-9)
    assert np.array_equal(bent[:, ~low], normal[:, ~low])
    assert np.allclose(np.linalg.norm(bent, axis=0), 1.0, atol=1e-12)


def test_a_hit_faces_its_normals_to_the_ray_and_samples_with_them():
    """geometry.facing turns both normals towards the ray (a back face: not entering), and
    sample_at_hit samples with the shading normal bent for a reflection only where the mesh has
    shading normals and the surface reflects (not refraction-only)."""
    from snell.tracer.geometry import facing
    s = 1.0 / math.sqrt(1.0 + 0.6 ** 2)
    ng, ns = (0.0, 0.0, 1.0), (-0.6 * s, 0.0, s)
    d = (0.8, 0.0, 0.6)                        # from below: meets the back face
    ng_f, ns_f, entering = facing(d, ng, ns)
    assert not entering and ng_f == (-0.0, -0.0, -1.0) and ns_f == tuple(-c for c in ns)
    assert facing((0.0, 0.0, -1.0), ng, ns) == (ng, ns, True)
    white = (1.0, 1.0, 1.0)
    bent = specular.valid_reflection_normal(ng_f, tuple(-c for c in d), ns_f)
    assert bent != ns_f                        # this grazing view needs the bend
    for kind, normals, n in ((MIRROR, True, bent), (MIRROR, False, ns_f),
                             (GLASS, True, bent), (REFRACTION, True, ns_f)):
        got = specular.sample_at_hit(kind, d, ng_f, ns_f, entering, normals, white, white, 1.5,
                                     fresnel.EXACT, 0.3)
        assert got == specular.sample_specular(kind, d, ng_f, n, entering, white, white, 1.5,
                                               fresnel.EXACT, 0.3), (kind, normals)
