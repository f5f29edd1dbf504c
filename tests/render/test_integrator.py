"""Accuracy tests of the integrator on scenes with known answers."""
import math
import os
import threading

import numpy as np
import pytest

from support.builders import box, camera, icosphere, make_scene, quad
from support.stats import estimators_agree as _estimators_agree, z_bound
from snell.tracer.camera import Camera
from snell.tracer.integrator import CHUNK, Renderer, render

WHITE = [1.0, 1.0, 1.0]
LOSSLESS = {
    "mirror": {"name": "Mirror", "kind": "mirror", "color": WHITE},
    "glass-1.5": {"name": "Glass", "kind": "glass", "color": WHITE, "ior": 1.5},
    "glass-1.0": {"name": "Glass1", "kind": "glass", "color": WHITE, "ior": 1.0},
    "refraction-1.5": {"name": "Water", "kind": "refraction", "color": WHITE, "ior": 1.5},
}


@pytest.mark.parametrize("scale", [1.0, 1000.0])
@pytest.mark.parametrize("material", list(LOSSLESS))
def test_white_furnace_lossless_spheres(material, scale):
    """Inside a world of radiance 1 a lossless sphere vanishes: every sample is exactly 1.

    Every path carries throughput exactly 1, so the estimator has zero variance and the bound
    derived from the sample count is float rounding. A skipped or doubled surface (a
    self-intersection) would show as a path ending inside the glass (0) or a lost sample.
    Cycles' rules end a few paths on a smooth mesh sphere, only at grazing silhouette rays:
    refraction-only surfaces absorb under total internal reflection, samples on the wrong side of
    the geometric surface are rejected, and rays caught in total internal reflection reach the
    depth limit. The test accounts for each such path by the integrator's event counters.
    """
    pos, tri, nrm = icosphere(5, radius=scale)
    spp = 16
    scene = make_scene([(pos, tri, 0, nrm)], [LOSSLESS[material]],
                       camera(position=(0, 0, 4 * scale), resolution=(48, 48)),
                       world=WHITE, spp=spp, max_depth=64)
    result = render(scene, scene.settings(threads=2))
    img = result.mean()
    assert result.nan_count == 0
    stats = result.stats
    lost = np.round((1.0 - img[..., 0]) * spp).astype(int)
    ended = stats["tir_absorbed"] + stats["rejected"] + stats["depth_limited"]
    assert lost.sum() == ended
    assert ended <= 1e-3 * img.size / 3 * spp
    assert np.all(np.abs(img[lost == 0] - 1.0) < 1e-6), f"min {img.min()}, max {img.max()}"
    assert np.all(img[..., 0] == img[..., 2])
    if material == "mirror":
        assert ended == 0
    else:
        assert stats["transmissions"] > 0.5 * img.size / 3 * spp   # the glass was really crossed
    if material == "glass-1.5":
        assert stats["reflections"] > 0


def test_diffuse_furnace_matches_albedo():
    """A convex diffuse sphere of albedo a in a uniform world L renders a*L (NEE + MIS)."""
    pos, tri, nrm = icosphere(4)
    mat = {"name": "Grey", "kind": "diffuse", "color": [0.5, 0.25, 0.75]}
    scene = make_scene([(pos, tri, 0, nrm)], [mat], camera(position=(0, 0, 4), resolution=(24, 24)),
                       world=[2.0, 2.0, 2.0], spp=64, max_depth=2)
    renderer = Renderer(scene)
    result = renderer.render()
    img, var = result.mean(), result.variance_of_mean()
    on = np.ones(img.shape[:2], bool)
    # Only pixels fully covered by the sphere (the camera sees 36 mm / 50 mm wide at distance 4).
    cam = renderer.camera
    ys, xs = np.mgrid[0:24, 0:24]
    corners = [(xs + dx, 24 - ys - dy) for dx in (0, 1) for dy in (0, 1)]
    for cx, cy in corners:
        px = cam.raster_to_camera(cx.ravel().astype(float), cy.ravel().astype(float))
        d = px / np.linalg.norm(px, axis=0)
        b = 8 * d[2]                    # |o + t d|^2 = 1 with o = (0, 0, 4)
        disc = b * b - 4 * (16 - 1)
        on &= (disc > 0.05).reshape(24, 24)
    expected = 2.0 * np.array([0.5, 0.25, 0.75])
    z = (img[on] - expected) / np.sqrt(var[on] + 1e-30)
    assert np.all(np.abs(z) < z_bound(z.size)), np.abs(z).max()
    mean = img[on].mean(axis=0)
    se = np.sqrt(var[on].sum(axis=0)) / on.sum()
    assert np.all(np.abs(mean - expected) < 4 * se + 1e-9)


def test_glass_slab_transmits_one_minus_f_over_one_plus_f():
    """Camera -> glass slab (IOR 1.5) -> emitter of radiance 1: (1 - F) / (1 + F), F = 0.04."""
    slab = box((-2, -2, -0.5), (2, 2, 0.5))
    lamp = quad((0, 0, -3), 10, 10)
    mats = [{"name": "Glass", "kind": "glass", "color": WHITE, "ior": 1.5},
            {"name": "Lamp", "kind": "emission", "color": WHITE, "strength": 1.0}]
    # A long lens keeps every ray within 0.3 degrees of normal incidence (F changes < 1e-6).
    scene = make_scene([(*slab, 0), (*lamp, 1)], mats,
                       camera(position=(0, 0, 10), resolution=(16, 16), lens=2000.0),
                       spp=1024, max_depth=100)
    result = render(scene)
    img = result.mean()
    expected = 0.96 / 1.04
    # Each sample is 1 or 0 (Bernoulli); the mean over all pixels has a known variance.
    n = img[..., 0].size * result.spp
    se = math.sqrt(expected * (1 - expected) / n)
    assert abs(img[..., 0].mean() - expected) < 4 * se
    assert np.all(img[..., 0] == img[..., 1])


def _emitter_sphere_scene(z, radius, focus, aperture, res=96, spp=64):
    pos, tri, nrm = icosphere(2, radius=radius, center=(0, 0, -z))
    mats = [{"name": "Lamp", "kind": "emission", "color": WHITE, "strength": 1.0}]
    dof = {"use_dof": True, "focus_distance": focus, "aperture_radius": aperture}
    return make_scene([(pos, tri, 0, nrm)], mats, camera(position=(0, 0, 0), resolution=(res, res), dof=dof),
                      spp=spp, max_depth=0)


def _second_moment_px(img, cam):
    w = img[..., 0].astype(np.float64)
    ys, xs = np.mgrid[0:img.shape[0], 0:img.shape[1]] + 0.5
    total = w.sum()
    cx, cy = (w * xs).sum() / total, (w * ys).sum() / total
    return (w * ((xs - cx) ** 2 + (ys - cy) ** 2)).sum() / total


def test_thin_lens_circle_of_confusion():
    """A small emitter off the focal plane blurs to a disk of radius a |1/f - 1/z| (tangent space)."""
    a, f, z, r = 0.4, 3.0, 6.0, 0.07
    scene = _emitter_sphere_scene(z, r, f, a, spp=256)
    cam = Camera(scene.camera)
    img = render(scene).mean()
    px_per_tangent = cam.width / (2 * cam.half_x)
    predicted = a * abs(1 / f - 1 / z) * px_per_tangent        # 8.9 px
    rho = r / math.sqrt(z * z - r * r) * px_per_tangent         # the emitter's own radius, 1.6 px
    # The image is the emitter's disk convolved with the CoC disk and the box filter:
    # E[r^2] = R^2 / 2 + rho^2 / 2 + 1 / 6 (a uniform disk of radius R has E[r^2] = R^2 / 2).
    measured = math.sqrt(2 * _second_moment_px(img, cam) - rho ** 2 - 1 / 3)
    assert measured == pytest.approx(predicted, rel=0.03)
    ys, xs = np.nonzero(img[..., 0] > 0)
    radius_support = max(xs.max() - xs.min() + 1, ys.max() - ys.min() + 1) / 2
    assert radius_support == pytest.approx(predicted + rho, abs=1.0)
    # A 10% larger aperture is measurably different.
    assert abs(measured - 1.1 * predicted) > 0.05 * predicted


def test_thin_lens_focal_plane_stays_sharp():
    scene = _emitter_sphere_scene(3.0, 0.01, 3.0, 0.4)
    img = render(scene).mean()
    assert _second_moment_px(img, Camera(scene.camera)) < 0.5
    assert (img[..., 0] > 0).sum() <= 9
    off_plane = render(_emitter_sphere_scene(3.3, 0.01, 3.0, 0.4)).mean()
    assert (off_plane[..., 0] > 0).sum() > 9


def test_depth_of_field_off_is_a_pinhole():
    """With depth of field off, the f-stop plays no part: the out-of-focus emitter stays sharp."""
    scene = _emitter_sphere_scene(6.0, 0.01, 3.0, 0.4).with_camera(dof={"use_dof": False})
    cam = Camera(scene.camera)
    assert not cam.has_lens and cam.params().lens_radius == 0.0
    img = render(scene).mean()
    assert _second_moment_px(img, cam) < 0.5 and (img[..., 0] > 0).sum() <= 9


def _lit_floor(max_depth, light):
    floor = quad((0, 0, 0), 50, 50)
    mats = [{"name": "White", "kind": "diffuse", "color": WHITE}]
    m = np.eye(4)
    m[:3, 3] = (0, 0, 5)
    return make_scene([(*floor, 0)], mats, camera(position=(0, 0, 5), resolution=(9, 9), lens=5000.0),
                      lights=[light], spp=64, max_depth=max_depth)


def test_point_light_irradiance():
    """P = 4 pi W at 1 m over a white diffuse floor gives radiance 1/pi (I = P / 4 pi = 1)."""
    light = {"name": "Point", "kind": "point", "position": [0, 0, 1], "intensity": WHITE}
    img = render(_lit_floor(1, light)).mean()
    # The centre pixel covers 4 mm of floor: the cos^3 falloff across it is below 1e-5.
    assert img[4, 4, 0] == pytest.approx(1 / math.pi, rel=2e-4)


def test_disk_area_light_irradiance():
    """A disk lamp of radiance L, radius r at height h gives E = pi L r^2 / (r^2 + h^2) below its centre."""
    m = np.eye(4)
    m[:3, 3] = (0, 0, 1)                      # unrotated: emits along -Z, down onto the floor
    light = {"name": "Disk", "kind": "area", "shape": "disk", "matrix": m.tolist(), "size": [2.0, 2.0],
             "radiance": WHITE, "visible_camera": False}
    result = render(_lit_floor(1, light).with_render(spp=1024))
    img, var = result.mean(), result.variance_of_mean()
    expected = 1 / math.pi * math.pi * 1.0 / 2.0
    assert abs(img[4, 4, 0] - expected) < 4.5 * math.sqrt(var[4, 4, 0])
    assert abs(img[..., 0].mean() - expected) < 4.5 * math.sqrt(var[..., 0].sum()) / 81 + 2e-3


def test_lamps_are_transparent_to_camera_rays():
    """Lamps have no surface (Cycles' light objects): a camera ray adds the light of every lamp it
    crosses and goes on to the emissive wall behind them, so the centre pixel is exactly
    L_front + L_back + L_wall, and a lamp seen from behind adds nothing."""
    wall = quad((0, 0, -1), 5, 5)
    mats = [{"name": "Wall", "kind": "emission", "color": WHITE, "strength": 0.25}]

    def lamp(z, radiance, facing_camera=True):
        m = np.eye(4)
        m[:3, 3] = (0, 0, z)
        if facing_camera:
            m[:3, 1:3] *= -1             # a half turn about X: it emits along +Z, to the camera
        return {"name": f"L{z}", "kind": "area", "shape": "square", "matrix": m.tolist(),
                "size": [1.0, 1.0], "radiance": [radiance] * 3, "visible_camera": True}

    lamps = [lamp(1.0, 2.0), lamp(0.5, 0.5), lamp(0.2, 100.0, facing_camera=False)]
    scene = make_scene([(*wall, 0)], mats, camera(resolution=(9, 9), lens=200.0), lights=lamps,
                       spp=4, max_depth=0)
    img = render(scene).mean()
    assert np.allclose(img[4, 4], 2.0 + 0.5 + 0.25, rtol=1e-6)


def test_max_depth_semantics():
    """m = 0 shows only emitters; m = 1 adds direct light on surfaces (Cycles max_bounces 0)."""
    floor = quad((0, 0, 0), 50, 50)
    lamp = quad((0, 0, 3), 0.5, 0.5, normal_sign=-1)
    mats = [{"name": "White", "kind": "diffuse", "color": WHITE},
            {"name": "Lamp", "kind": "emission", "color": WHITE, "strength": 5.0}]
    cam = camera(position=(2, 0, 6), resolution=(16, 16), lens=20.0)
    base = make_scene([(*floor, 0), (*lamp, 1)], mats, cam, spp=8)
    depth0 = render(base.with_render(max_depth=0)).mean()
    depth1 = render(base.with_render(max_depth=1)).mean()
    lamp_px = depth0[..., 0] > 0
    assert lamp_px.any() and depth0.max() == 5.0 and depth0.min() == 0.0   # emitters only
    floor_px = ~lamp_px
    assert floor_px.sum() > 100
    assert np.mean(depth1[floor_px][:, 0] > 0) > 0.95            # the floor is lit directly
    assert np.array_equal(depth1[lamp_px & (depth0[..., 0] == 5.0)], depth0[lamp_px & (depth0[..., 0] == 5.0)])


def test_deterministic_for_seed_and_independent_of_threads():
    pos, tri, nrm = icosphere(3)
    mats = [{"name": "Grey", "kind": "diffuse", "color": [0.5, 0.5, 0.5]}]
    scene = make_scene([(pos, tri, 0, nrm)], mats, camera(resolution=(20, 20)), world=WHITE, spp=4)
    a = render(scene, scene.settings(threads=1)).mean()
    b = render(scene, scene.settings(threads=2)).mean()
    c = render(scene, scene.settings(seed=1, threads=2)).mean()
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def grey_sphere_512():
    """A grey sphere under a white world at 512x512 and 8 spp: passes of one sample, several
    chunks each."""
    pos, tri, nrm = icosphere(2)
    mats = [{"name": "Grey", "kind": "diffuse", "color": [0.5, 0.5, 0.5]}]
    return make_scene([(pos, tri, 0, nrm)], mats, camera(resolution=(512, 512)), world=WHITE,
                      spp=8)


def test_cancel_keeps_completed_passes():
    scene = grey_sphere_512()
    seen = []
    result = render(scene, progress=lambda r, k, n: seen.append((k, n)) or False)
    # At 512x512, windows of two passes of one sample.
    assert seen == [(1, 4)] and result.cancelled and result.spp == 2
    assert np.all(np.isfinite(result.mean())) and result.mean().max() > 0


def test_every_pass_gives_progress_after_each_pass():
    """The viewport's render (every_pass): windows of one pass, a progress call after each of
    the 8 one-sample passes at 512x512 rather than after each window of two."""
    scene = grey_sphere_512()
    seen = []
    result = Renderer(scene, scene.settings()).render(
        progress=lambda r, k, n: seen.append((k, n, r.spp)) or k < 2, every_pass=True)
    assert seen == [(1, 8, 1), (2, 8, 2)] and result.cancelled and result.spp == 2


def test_stop_event_ends_a_pass_within_a_chunk(monkeypatch):
    """The viewport's cancel: chunks after the stop are skipped, the pass is not counted."""
    scene = grey_sphere_512()
    renderer, stop, traced = Renderer(scene, scene.settings(threads=1)), threading.Event(), []
    trace = renderer.trace_chunk

    def one_chunk_then_stop(*args):
        traced.append(args[0])
        stop.set()
        return trace(*args)

    monkeypatch.setattr(renderer, "trace_chunk", one_chunk_then_stop)
    result = renderer.render(stop=stop, progress=lambda *_: pytest.fail("no pass completes"))
    assert traced == [0] and result.cancelled and result.spp == 0   # 32 chunks in the pass


def test_a_compile_during_the_render_is_left_out_of_its_time(monkeypatch):
    """A kernel compiled inside the render (jit.compile_seconds rising by 30 s in the first
    pass) is reported as compile_s and not counted in time_s, the summary's render time."""
    from snell.tracer import jit, passes
    pos, tri, nrm = icosphere(2)
    mats = [{"name": "Grey", "kind": "diffuse", "color": [0.5, 0.5, 0.5]}]
    scene = make_scene([(pos, tri, 0, nrm)], mats, camera(resolution=(16, 16)), world=WHITE, spp=2)
    renderer = Renderer(scene, scene.settings(threads=1))
    clock = {"compiled": 100.0, "now": 1000.0, "calls": 0}
    trace = renderer.trace_chunk

    def compiling_trace(*args):
        # The first chunk compiles for 30 s; every chunk works for 1 s.
        clock["compiled"], clock["now"] = 130.0, clock["now"] + 1.0 + 30.0 * (clock["calls"] == 0)
        clock["calls"] += 1
        return trace(*args)

    monkeypatch.setattr(renderer, "trace_chunk", compiling_trace)
    monkeypatch.setattr(jit, "compile_seconds", lambda: clock["compiled"])
    monkeypatch.setattr(passes.time, "perf_counter", lambda: clock["now"])
    result = renderer.render()
    assert result.compile_s == pytest.approx(30.0)
    assert result.time_s == pytest.approx(clock["calls"])   # the work, not the compile


def test_nan_samples_are_counted_and_kept_out_of_the_image(monkeypatch):
    pos, tri, nrm = icosphere(2)
    mats = [{"name": "Grey", "kind": "diffuse", "color": [0.5, 0.5, 0.5]}]
    scene = make_scene([(pos, tri, 0, nrm)], mats, camera(resolution=(8, 8)), world=WHITE, spp=2)
    from snell.tracer import wavefront
    original = wavefront.film

    def poisoned(radiance, n, *args):
        radiance[:n:7, 1] = np.nan
        radiance[:n:11, 0] = np.inf
        return original(radiance, n, *args)
    monkeypatch.setattr(wavefront, "film", poisoned)
    result = render(scene)
    # One pass of 128 paths (64 pixels x 2 samples) in chunks; each chunk poisons its own rows.
    from snell.tracer.passes import jobs
    chunks = [n for _, n in jobs(0, 128, 2)]
    assert len(chunks) == 4
    expected_bad = sum(len(set(range(0, n, 7)) | set(range(0, n, 11))) for n in chunks)
    assert result.nan_count == expected_bad
    assert np.all(np.isfinite(result.mean()))


def test_non_finite_light_splats_are_counted_and_left_out():
    """The light tracer's splats: a NaN or Inf one is counted and dropped, its pixel keeps the
    others."""
    from snell.tracer import wavefront
    film = np.zeros((3, 3))
    pixels = np.array([0, 1, 1, 2])
    contributions = np.array([[1.0, 1.0, 1.0], [np.nan, 0.0, 0.0], [2.0, 2.0, 2.0],
                              [1.0, np.inf, 1.0]])
    assert wavefront.splat(pixels, contributions, film) == 2
    assert np.array_equal(film, [[1.0, 1.0, 1.0], [2.0, 2.0, 2.0], [0.0, 0.0, 0.0]])


def test_light_sampling_and_bsdf_sampling_agree_near_a_two_sided_lamp():
    """A lamp quad hanging just under a diffuse ceiling lights it through its back face.

    NEE with MIS and pure BSDF sampling estimate the same integral; any bias in light
    sampling (pdfs, shadow-ray lengths, two-sided emission) shows as a difference.
    """
    ceiling = quad((0, 0, 2.0), 3, 3, normal_sign=-1)
    floor = quad((0, 0, 0), 3, 3)
    lamp = quad((0, 0, 1.85), 0.5, 0.5, normal_sign=-1)
    mats = [{"name": "White", "kind": "diffuse", "color": [0.8, 0.8, 0.8]},
            {"name": "Lamp", "kind": "emission", "color": WHITE, "strength": 10.0}]
    m = np.diag([1.0, -1.0, -1.0, 1.0])      # look straight up at the lamp's edge and the ceiling
    m[:3, 3] = (1.0, 0, 0.5)
    cam = camera(resolution=(20, 20), lens=30.0, matrix=m.tolist())
    scene = make_scene([(*ceiling, 0), (*floor, 0), (*lamp, 1)], mats, cam, max_depth=3)
    _estimators_agree(scene, 256, 2048)


def test_light_sampling_and_bsdf_sampling_agree_for_lamps_and_world():
    """Area lamp (one-sided), point-free scene with a world: both estimators, same answer."""
    floor = quad((0, 0, 0), 5, 5)
    pos, tri, nrm = icosphere(2, radius=0.5, center=(0, 0, 0.5))
    mats = [{"name": "Grey", "kind": "diffuse", "color": [0.5, 0.6, 0.7]}]
    m = np.eye(4)
    m[:3, 3] = (0.5, 0, 2)
    lamp = {"name": "Area", "kind": "area", "shape": "ellipse", "matrix": m.tolist(), "size": [1.0, 0.5],
            "radiance": [4.0, 4.0, 4.0], "visible_camera": True}
    cam = camera(position=(0, 0, 6), resolution=(16, 16), lens=35.0)
    scene = make_scene([(*floor, 0), (pos, tri, 0, nrm)], mats, cam, world=[0.2, 0.3, 0.4],
                       lights=[lamp], max_depth=3)
    _estimators_agree(scene, 256, 1024)


def test_interreflection_inside_a_diffuse_sphere_with_russian_roulette():
    """pbrt-v4's integrator test: a point light of intensity pi at the centre of a closed diffuse
    sphere of radius 1 and albedo 0.5 gives radiance a E / (pi (1 - a)) = 1 everywhere.

    Paths bounce up to 100 times, so Russian roulette decides almost every path's end: a biased
    roulette (or a lost bounce) shows as a mean away from 1.
    """
    pos, tri, nrm = icosphere(4)
    mats = [{"name": "Half", "kind": "diffuse", "color": [0.5, 0.5, 0.5]}]
    light = {"name": "P", "kind": "point", "position": [0, 0, 0], "intensity": [math.pi] * 3}
    scene = make_scene([(pos, tri, 0, nrm)], mats, camera(position=(0, 0, 0.2), resolution=(16, 16)),
                       lights=[light], spp=256, max_depth=100)
    result = Renderer(scene, scene.settings(sampler="independent")).render()
    img, var = result.mean(), result.variance_of_mean()
    assert result.stats["rr_killed"] > 0.5 * img[..., 0].size * result.spp
    mean = img[..., 0].mean()
    se = math.sqrt(var[..., 0].sum()) / img[..., 0].size
    # The mesh is inscribed in the unit sphere (faces slightly nearer the light): allow 0.5%.
    assert abs(mean - 1.0) < 4 * se + 0.005, (mean, se)


WARM_CHECK = r"""
import sys
sys.path[:0] = ["tests", "tests/render"]
import numba
from snell.tracer import integrator, jit, wavefront
integrator.warm_up()
def signatures(kernel):
    # A kernel called from Python compiles its Python-facing dispatcher (jit.Compiled._outer).
    if isinstance(kernel, jit.Compiled):
        kernel = kernel._outer
    return len(kernel.overloads) if isinstance(kernel, numba.core.registry.CPUDispatcher) else 0
def count():
    return sum(signatures(getattr(wavefront, n)) for n in dir(wavefront))
before = count()
from test_integrator import LOSSLESS, WHITE
from support.builders import camera, icosphere, make_scene, quad
pos, tri, nrm = icosphere(2)
m = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 3], [0, 0, 0, 1]]
area = {"name": "A", "kind": "area", "shape": "disk", "matrix": m, "size": [1.0, 1.0],
        "radiance": WHITE, "visible_camera": True}
sun = {"name": "S", "kind": "sun", "direction": [0, 0, -1], "irradiance": WHITE, "angle": 0.1}
from snell.tracer.shader import closures as c
# A node-graph material (Mix of a Glossy and a Transparent, and a varying Emission) and coloured
# glass (an absorbing medium): the program and media stages.
veil = {"name": "P", "kind": "program", "program": {
    "registers": 10, "constants": [0.8, 0.6, 0.4, 0.3, 1.0, 1.0, 1.0, 0.2],
    "code": [[c.MIX_CLOSURE, 8, 9, -1, 3, 0, 0, 0], [c.GLOSSY, 8, 0, 7, 0, -1, 0, 0],
             [c.TRANSPARENT_BSDF, 9, 4, 0, 0, 0, 0, 0], [c.EMISSION, 9, 0, 3, 0, 0, 0, 0]],
    "data": [], "emission_varies": True, "refracts": False}}
mats = [dict(LOSSLESS["glass-1.5"], absorption=[0.2, 0.4, 0.6]),
        {"name": "D", "kind": "diffuse", "color": [0.5, 0.5, 0.5]},
        {"name": "E", "kind": "emission", "color": WHITE, "strength": 2.0}, veil]
scene = make_scene([(pos, tri, 0, nrm), (*quad((0, 0, -1), 3, 3), 1), (*quad((0, 0, 4), 1, 1, -1), 2),
                    (*quad((0.5, 0, 1.5), 1, 1), 3)],
                   mats, camera(resolution=(8, 8), dof={"use_dof": True, "aperture_radius": 0.1}),
                   world=[0.2, 0.2, 0.2], lights=[area, sun], spp=4, max_depth=6)
for sampler in integrator.SAMPLERS:
    integrator.Renderer(scene, scene.settings(sampler=sampler)).render()
integrator.Renderer(scene, scene.settings(denoising_passes=True)).render()
print(before, count())
"""


def test_warm_up_loads_every_kernel_signature_a_render_uses():
    """After warm_up, rendering a scene with every feature (node-graph materials and absorbing
    media among them), also with the denoising features F12 makes by default, compiles or loads
    nothing more: the one-time cost is all in warm_up (the kernels' argument types do not depend
    on the scene). Before warm_up had a program material, this scene compiled a signature more
    after it (the Python-facing ones counted: 6 -> 7); without warm_up's render with the
    features, 7 -> 10."""
    import subprocess
    import sys
    from support.paths import ROOT as root
    out = subprocess.run([sys.executable, "-c", WARM_CHECK], cwd=root, capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    before, after = map(int, out.stdout.split()[-2:])
    assert before > 0 and after == before


def test_mean_rounds_once_into_float32_without_a_float64_copy():
    """mean() is the float64 quotient rounded to float32, and makes no float64 image on the way
    (at 8192x8192 that copy was 1.5 GB, found by `snell stress`'s peak-memory case)."""
    import tracemalloc
    from snell.tracer.integrator import RenderResult
    rng = np.random.default_rng(3)
    total = rng.random((256, 256, 3)) * 1e3
    result = RenderResult(256, 256, total, total * total, spp=7)
    tracemalloc.start()
    try:
        image = result.mean()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert image.dtype == np.float32 and np.array_equal(image, (total / 7).astype(np.float32))
    assert peak < image.nbytes + (1 << 20)


@pytest.mark.parametrize("begin, end, unit", [(0, 1 << 17, 2), (0, 9600, 16), (0, 80, 16),
                                              (0, 3 * CHUNK + 3, 3), (5, 7, 1), (100, 1100, 1)])
def test_a_pass_splits_into_even_jobs_of_whole_pixels(begin, end, unit):
    """Jobs cover the pass in order, hold whole pixels' samples and at most CHUNK paths, and come
    in a multiple of JOB_MULTIPLE (fewer only when there are fewer pixels), even to one pixel:
    small adaptive passes keep both threads busy."""
    from snell.tracer.passes import JOB_MULTIPLE, jobs as split
    jobs = split(begin, end, unit)
    starts = [s for s, _ in jobs]
    sizes = [n for _, n in jobs]
    assert starts[0] == begin and sum(sizes) == end - begin
    assert all(a + n == b for (a, n), b in zip(jobs, starts[1:]))
    assert all(n % unit == 0 and 0 < n <= CHUNK for n in sizes)
    units = (end - begin) // unit
    assert len(jobs) % JOB_MULTIPLE == 0 or len(jobs) == units
    assert max(sizes) - min(sizes) <= unit


def test_time_limit_stops_after_whole_passes():
    """time_limit (Cycles' Time Limit): the render stops once the limit has passed, with a whole
    image of the passes done, not a cancelled one; 0 has no limit."""
    from support.builders import tiny_scene
    scene = tiny_scene()
    limited = Renderer(scene, scene.settings(spp=10_000_000, noise_threshold=0.0, time_limit=0.3,
                                             threads=1)).render()
    assert limited.time_limited and not limited.cancelled
    assert 0 < limited.spp < 10_000_000 and limited.time_s < 30
    assert np.isfinite(limited.mean()).all() and limited.mean().max() > 0
    full = Renderer(scene, scene.settings(spp=4, noise_threshold=0.0, threads=1)).render()
    assert not full.time_limited and full.spp == 4


@pytest.mark.parametrize("passes", [False, True])
def test_the_stages_get_none_for_what_a_render_does_not_make(monkeypatch, passes):
    """Without the light passes and the denoising features the materials stage gets None for
    their arrays, so it is compiled without their code (wavefront.py); with them, their rows."""
    import inspect
    from snell.tracer import wavefront
    seen = []
    real = wavefront.materials
    names = inspect.signature(real.py_func)

    def spy(*args):
        given = names.bind(*args).arguments
        seen.append((given["pass_sums"], given["feature_albedo"], given["feature_normal"]))
        return real(*args)

    monkeypatch.setattr(wavefront, "materials", spy)
    scene = _lit_floor(3, {"name": "L", "kind": "point", "position": [0, 0, 1],
                           "intensity": WHITE})
    settings = scene.settings(spp=1, threads=1, denoising_passes=passes,
                              light_passes=passes)
    Renderer(scene, settings).render()
    assert seen
    for arrays in seen:
        assert all((a is not None) == passes for a in arrays)
