"""The equirectangular environment map (tracer/lights/world.py): Cycles' axis convention, the
density of its importance sampling against the samples (chi-square), its normalisation and the rotation."""
import math

import numba
import numpy as np
import pytest

from snell.tracer.lights import world as environment
from snell.tracer.lights.world import (build_environment, direction_to_equirectangular,
                                       env_lookup, equirectangular_to_direction, pdf_env,
                                       sample_env)
from support.stats import SphereGrid, integrate_bins
from support.stats import chi2_pvalue as _chi2_pvalue


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
    # At the poles Cycles' Repeat extension (the Environment Texture's, device/cpu/image.h
    # interp_linear) blends the top and bottom rows half and half.
    pole = w / 2 - 0.5 + 1000 * (h - 1) / 2
    assert env_lookup(env, (0.0, 0.0, 1.0))[0] == pytest.approx(pole)
    assert env_lookup(env, (0.0, 0.0, -1.0))[0] == pytest.approx(pole)
    # A quarter row from the top: three quarters row 0, one quarter the bottom row.
    z = math.cos(math.pi * 0.25 / h)
    near = (math.sqrt(1 - z * z), 0.0, z)
    assert env_lookup(env, near)[0] == pytest.approx(w / 2 - 0.5 + 1000 * (h - 1) / 4)


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


# The smooth map turned is slow (22 s); the bright texel turned keeps a rotation by default.
@pytest.mark.parametrize("image, rotation", [
    (smooth_map(), 0.0), pytest.param(smooth_map(seed=5), 0.7, marks=pytest.mark.slow),
    (bright_texel_map(), 0.0), (bright_texel_map(), -3 * np.pi / 8)],
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
                                                  "matrix", "inverse", "offset", "det",
                                                  "uniform", "closest", "pixels")


# ---------------------------------------------------------------------------------------------
# General mappings, Closest interpolation


@numba.njit(cache=True)
def _texture_directions(env, d, out):
    """The unit texture direction of every world direction."""
    for i in range(d.shape[0]):
        t = environment.to_texture(env, (d[i, 0], d[i, 1], d[i, 2]))
        n = math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2])
        out[i, 0], out[i, 1], out[i, 2] = t[0] / n, t[1] / n, t[2] / n


MAPPINGS = {
    "euler-xyz": ("POINT", (0, 0, 0), (0.4, -0.7, 2.0), (1, 1, 1)),
    "scaled": ("VECTOR", (0, 0, 0), (0.2, 0.1, -0.5), (1.0, 2.0, 0.5)),
    "texture": ("TEXTURE", (0, 0, 0), (0.3, 0.0, 1.0), (0.7, 1.0, 1.3)),
}


# The Texture type (rotation about two axes, an uneven scale, the inverse matrix) by default; the
# other two slow.
@pytest.mark.parametrize("name", [pytest.param(name, marks=pytest.mark.slow)
                                  if name != "texture" else name for name in MAPPINGS])
def test_mapping_node_matrix_sampling(name):
    """Any Mapping node without a location (rotation about every axis, scale, the Texture type):
    samples carry the density pdf_env gives them, the radiance is the image at the mapped
    direction, and the sampled directions follow the density (chi-square, 1% over the three)."""
    a, b = environment.mapping_transform(*MAPPINGS[name])
    assert not np.any(b)
    env = build_environment(smooth_map(), matrix=a)
    d, radiance, pdf = sample(env, 100_000, seed=5)
    again, lookup = evaluate(env, d)
    np.testing.assert_allclose(again, pdf, rtol=1e-9)
    t = np.zeros_like(d)
    _texture_directions(env, d, t)
    np.testing.assert_allclose(t, (d @ a.T) / np.linalg.norm(d @ a.T, axis=1)[:, None], atol=1e-12)
    plain = build_environment(smooth_map())
    np.testing.assert_allclose(evaluate(plain, t)[1], lookup, rtol=1e-9)
    grid = SphereGrid((0.0, 0.0, 1.0), 1)
    n = 400_000
    d, _, _ = sample(env, n, seed=13)
    probability = integrate_bins(lambda x: evaluate(env, x)[0], grid).ravel()
    assert probability.sum() == pytest.approx(1.0, abs=3e-3)
    assert _chi2_pvalue(grid.histogram(d).ravel(), probability / probability.sum() * n) > 0.01 / 3


def test_mapping_node_formulas():
    """Cycles' svm_mapping: Point R (S v) + L, Texture R^T (v - L) / S, Vector R (S v), Normal
    R (v / S), R = Rz Ry Rx (Blender's XYZ Euler)."""
    v = np.array([0.3, -0.5, 0.8])
    loc, rot, scale = np.array([0.1, 0.2, -0.3]), (0.4, -0.7, 2.0), np.array([1.0, 2.0, 0.5])
    cx, sx, cy, sy, cz, sz = (np.cos(0.4), np.sin(0.4), np.cos(-0.7), np.sin(-0.7), np.cos(2.0),
                              np.sin(2.0))
    r = (np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
         @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
         @ np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]))
    expected = {"POINT": r @ (v * scale) + loc, "TEXTURE": r.T @ (v - loc) / scale,
                "VECTOR": r @ (v * scale), "NORMAL": r @ (v / scale)}
    for kind, want in expected.items():
        a, b = environment.mapping_transform(kind, loc, rot, scale)
        np.testing.assert_allclose(a @ v + b, want, atol=1e-12)


def test_location_samples_uniformly_and_looks_up_exactly():
    """A Mapping location (b != 0) keeps the lookup exact (the image at normalise(A d + b)) and
    samples directions uniformly, so the estimate stays unbiased."""
    a, b = environment.mapping_transform("POINT", (0.2, 0.0, -0.1), (0, 0, 0.5), (1, 1, 1))
    env = build_environment(smooth_map(), matrix=a, offset=b)
    assert env.uniform
    d, radiance, pdf = sample(env, 2000, seed=2)
    np.testing.assert_allclose(pdf, 1 / (4 * np.pi))
    t = d @ a.T + b
    t /= np.linalg.norm(t, axis=1)[:, None]
    np.testing.assert_allclose(evaluate(build_environment(smooth_map()), t)[1], radiance,
                               rtol=1e-9)


def test_closest_interpolation_reads_one_texel():
    """Closest: every direction reads the texel it falls in (Cycles' interp_closest)."""
    h, w = 16, 32
    image = np.zeros((h, w, 3), np.float32)
    image[:] = (np.arange(w)[None, :] + 1000.0 * np.arange(h)[:, None])[:, :, None]
    env = build_environment(image, closest=True)
    d = uniform_directions(5000, 4)
    _, radiance = evaluate(env, d)
    u = (np.pi - np.arctan2(d[:, 1], d[:, 0])) / (2 * np.pi)
    theta = np.arccos(np.clip(d[:, 2], -1, 1))
    col = np.floor(u * w).astype(int) % w
    row = np.floor(theta / np.pi * h).astype(int) % h
    np.testing.assert_allclose(radiance[:, 0], col + 1000.0 * row)


# ---------------------------------------------------------------------------------------------
# Rendering with an environment map, and the scene file


def with_environment(scene, image, strength=1.0, matrix=None, interpolation="linear"):
    """The scene with its world replaced by an environment map of image (validated)."""
    from snell.tracer.scene import validate
    scene.images = [{"name": "map", "source": "test", "pixels": np.asarray(image, np.float32)}]
    scene.world = {"color": [0.0, 0.0, 0.0], "environment": {
        "image": 0, "strength": float(strength),
        "matrix": (np.eye(3) if matrix is None else np.asarray(matrix)).tolist(),
        "offset": [0.0, 0.0, 0.0], "interpolation": interpolation}}
    return validate(scene)


def _sphere_scene(world=(0.0, 0.0, 0.0), spp=64):
    from support.builders import camera, icosphere, make_scene
    pos, tri, nrm = icosphere(3, 1.0)
    mats = [{"name": "white", "kind": "diffuse", "color": [0.8, 0.6, 0.4]}]
    return make_scene([(pos, tri, 0, nrm)], mats, camera((0, 0, 5), (24, 24)), world=world,
                      spp=spp, max_depth=4)


def _render(scene, **kw):
    from snell.tracer.integrator import Renderer
    result = Renderer(scene, scene.settings(threads=2, sampler="independent", **kw)).render()
    return result.mean().astype(np.float64), result.variance_of_mean(), result


def test_constant_map_renders_as_the_uniform_world():
    """A diffuse sphere (convex: it never sees itself) under a constant map of radiance c shows
    albedo x c, the background c, exactly as under the uniform world c; the two renders agree
    pixel by pixel within 4.5 sigma (the map's next-event estimation and MIS at work)."""
    c = np.array([0.5, 0.7, 0.9])
    uniform = _sphere_scene(world=tuple(c))
    mapped = with_environment(_sphere_scene(), np.broadcast_to(c / 2, (16, 32, 3)), strength=2.0)
    a, va, _ = _render(uniform)
    b, vb, result = _render(mapped)
    assert result.stages["environment"][0]
    on_sphere = np.zeros(a.shape[:2], bool)
    on_sphere[9:15, 9:15] = True            # the sphere fills the middle of the 24 x 24 image
    for image, var in ((a, va), (b, vb)):
        np.testing.assert_allclose(image[~on_sphere & (var.max(axis=2) == 0)], np.tile(c, (1, 1))
                                   .repeat(int((~on_sphere & (var.max(axis=2) == 0)).sum()), 0),
                                   rtol=1e-6)
        z = (image[on_sphere] - np.array([0.8, 0.6, 0.4]) * c) / np.sqrt(var[on_sphere])
        assert np.abs(z).max() < 4.5
    z = (a - b) / np.sqrt(np.maximum(va + vb, 1e-30))
    assert np.abs(z).max() < 4.5


def _wall_scene(normal, spp):
    """A diffuse square of albedo 0.5 facing `normal`, filling a pinhole camera's view."""
    from support.builders import camera, make_scene, quad
    pos, tri = quad((0.0, 0.0, 0.0), 1.0, 1.0)
    n = np.asarray(normal, np.float64)
    n /= np.linalg.norm(n)
    # Rotate +Z onto n (Rodrigues), and the camera with it, 3 m in front.
    axis = np.cross([0.0, 0.0, 1.0], n)
    s, c = np.linalg.norm(axis), n[2]
    k = np.zeros((3, 3)) if s == 0 else np.cross(np.eye(3), axis / s)
    r = np.eye(3) + s * k + (1 - c) * k @ k
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = r, 3.0 * n
    cam = camera((0, 0, 0), (8, 8), lens=120.0)
    cam["matrix"] = m.tolist()
    mats = [{"name": "wall", "kind": "diffuse", "color": [0.5, 0.5, 0.5]}]
    return make_scene([((pos.astype(np.float64) @ r.T).astype(np.float32), tri, 0)], mats, cam,
                      spp=spp, max_depth=1)


def _small_source(h=256, w=512, row=100, col=300, value=1000.0):
    """A black map with one bright texel: (image, the texel centre's direction, its solid
    angle)."""
    image = np.zeros((h, w, 3), np.float32)
    image[row, col] = value
    u, v = (col + 0.5) / w, 1.0 - (row + 0.5) / h
    d = np.array(equirectangular_to_direction(u, v))
    theta = np.pi * (row + 0.5) / h
    return image, d, (2 * np.pi / w) * (np.pi / h) * np.sin(theta)


@pytest.mark.parametrize("rotation", [0.0, 2.0], ids=["plain", "turned"])
def test_one_bright_texel_gives_the_irradiance_of_a_small_source(rotation):
    """A wall facing the bright texel's direction sideways (45 degrees off it) receives
    E = L Omega cos(45) (the texel a small source; bilinear filtering spreads but keeps its
    integral, to (pi / H)^2); its radiance is albedo E / pi. Turning the Mapping node by a turns
    the source by -a about Z: a wall facing the turned direction gets the same light, one facing
    the unturned direction gets a different one."""
    image, d, omega = _small_source()
    rz = environment.rotation_matrix((0.0, 0.0, rotation))
    seen = rz.T @ d                         # where the source appears after the rotation
    # A normal 45 degrees from the source, in the plane of the source and +Z.
    side = np.cross(seen, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    normal = np.cos(np.pi / 4) * seen + np.sin(np.pi / 4) * np.cross(side, seen)
    expected = 0.5 * 1000.0 * omega * np.cos(np.pi / 4) / np.pi
    scene = with_environment(_wall_scene(normal, spp=32), image, matrix=rz)
    img, var, _ = _render(scene)
    wall = img[2:6, 2:6].mean(axis=(0, 1))
    se = np.sqrt(var[2:6, 2:6].sum(axis=(0, 1))) / 16
    assert np.all(np.abs(wall - expected) < 4.5 * se + 2e-3 * expected), (wall, expected, se)
    if rotation:
        # The unturned direction's wall sees the source at another angle.
        unturned_side = np.cross(d, [0.0, 0.0, 1.0])
        unturned_side /= np.linalg.norm(unturned_side)
        normal0 = np.cos(np.pi / 4) * d + np.sin(np.pi / 4) * np.cross(unturned_side, d)
        other = with_environment(_wall_scene(normal0, spp=32), image, matrix=rz)
        img0, _, _ = _render(other)
        cos0 = max(float(normal0 @ seen), 0.0)
        want0 = 0.5 * 1000.0 * omega * cos0 / np.pi
        assert abs(img0[2:6, 2:6].mean() - want0) < 0.02 * expected + 4.5 * se.max()
        assert abs(want0 - expected) > 0.2 * expected


def test_scene_file_stores_the_map(tmp_path):
    """The scene file holds the image and its SHA-256; it loads back equal, and a file whose
    pixels do not match the hash, or whose environment names no image, is refused by name."""
    import json

    from snell.tracer import scene as S
    image = smooth_map()
    sc = with_environment(_sphere_scene(), image, strength=1.5,
                          matrix=environment.rotation_matrix((0, 0, 0.4)))
    path = tmp_path / "env.snell"
    S.save(sc, str(path))
    back = S.load(str(path))
    np.testing.assert_array_equal(back.images[0]["pixels"], image)
    assert back.world == sc.world and back.features()["environment"]
    with np.load(path) as npz:
        data = {k: npz[k] for k in npz.files}
    damaged = dict(data, image_0=data["image_0"] * np.float32(1.01))
    np.savez(tmp_path / "damaged.snell.npz", **damaged)
    with pytest.raises(S.SceneError, match=r"images\[0\] \('map'\): pixels do not match"):
        S.load(str(tmp_path / "damaged.snell.npz"))
    header = json.loads(data["header"].tobytes())
    header["world"]["environment"]["image"] = 3
    np.savez(tmp_path / "noimage.npz", **dict(data, header=np.frombuffer(
        json.dumps(header).encode(), np.uint8)))
    with pytest.raises(S.SceneError, match=r"world.environment.image"):
        S.load(str(tmp_path / "noimage.npz"))
    header["world"]["environment"].update(image=0, interpolation="cubic")
    np.savez(tmp_path / "cubic.npz", **dict(data, header=np.frombuffer(
        json.dumps(header).encode(), np.uint8)))
    with pytest.raises(S.SceneError, match=r"world.environment.interpolation"):
        S.load(str(tmp_path / "cubic.npz"))


def test_building_a_large_map_needs_little_more_than_its_table():
    """A 1k x 2k map: the tables are the two CDFs (8 bytes a texel), the image is not copied,
    and the build's temporaries stay a few MB (bands of rows), not another table."""
    import tracemalloc
    image = np.random.default_rng(0).random((1024, 2048, 3), dtype=np.float32)
    tracemalloc.start()
    try:
        env = build_environment(image)
        held, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    table = env.conditional.nbytes + env.marginal.nbytes
    assert np.shares_memory(env.image, image)
    assert held < table + 1e6
    assert peak < held + 12e6, (peak, held, table)      # bands of 2^18 texels
