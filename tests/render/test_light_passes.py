"""The light passes (tracer/light_passes.py) on Snell's own renders: Cycles' sum identity, exact
values where every path does the same, the split by bounce and lobe, and the image unchanged by
making them."""
from __future__ import annotations

import numpy as np
import pytest

from snell.tracer import light_passes
from snell.tracer.integrator import Renderer
from support.builders import camera, icosphere, make_scene, quad

WALL = (0.8, 0.3, 0.1)
WORLD = (0.2, 0.3, 0.5)


def _render(scene, **settings):
    return Renderer(scene, scene.settings(threads=2, **settings)).render()


def _sphere(radius, center, material):
    p, t, n = icosphere(2, radius, center)
    return p, t, material, n


def mixed_scene(spp=16, **render):
    """A diffuse floor, a rough glossy sphere, a glass sphere and a glass pane, a Principled
    sphere, an emissive quad above and a point lamp, under a blue world: every pass gets
    light."""
    floor = (*quad((0.0, 0.0, -1.0), 2.0, 2.0), 0)
    glossy = _sphere(0.6, (-1.0, 0.0, -0.4), 1)
    glass = _sphere(0.6, (0.6, 0.2, -0.4), 2)
    principled = _sphere(0.4, (0.0, -1.2, -0.6), 3)
    lamp_quad = (*quad((0.0, 2.5, 1.0), 0.5, 0.5, -1.0), 4)
    # A glass pane over the floor's edge: the world through it is Transmission Direct.
    pane = (*quad((1.8, 0.0, 0.0), 0.7, 0.5), 2)
    mats = [{"name": "Floor", "kind": "diffuse", "color": list(WALL)},
            {"name": "Glossy", "kind": "glossy", "color": [0.9, 0.8, 0.7], "roughness": 0.4},
            {"name": "Glass", "kind": "glass", "color": [1.0, 1.0, 1.0], "ior": 1.45},
            {"name": "Principled", "kind": "principled", "color": [0.2, 0.6, 0.3],
             "roughness": 0.3},
            {"name": "Light", "kind": "emission", "color": [1.0, 0.9, 0.8], "strength": 3.0}]
    lamp = {"name": "lamp", "kind": "point", "position": [1.5, -1.5, 1.5],
            "intensity": [30.0, 30.0, 30.0], "radius": 0.1}
    return make_scene([floor, glossy, glass, principled, lamp_quad, pane], mats,
                      camera(position=(0.0, 0.0, 5.0), resolution=(24, 24), lens=40.0),
                      world=WORLD, lights=[lamp], spp=spp, **render)


@pytest.fixture(scope="module")
def mixed():
    scene = mixed_scene()
    return scene, _render(scene, light_passes=True)


def test_combined_is_the_sum_of_the_light_passes(mixed):
    """Cycles' identity: Combined = (Direct + Indirect) x Color for diffuse, glossy and
    transmission, + Emission + Environment, on Snell's own output (light tracer and light
    vertices on): within float32 rounding (measured: 6.1e-5 at most, in a pixel of 955).
    Deliberate error, in light_passes.add_scattered: Transmission's weight 0 instead of
    1 - diffuse - glossy (the glass's light lost) fails it, largest pixel error 1.148."""
    _, result = mixed
    passes = result.light_pass_images()
    total = passes["Emission"] + passes["Environment"]
    for kind in ("Diffuse", "Glossy", "Transmission"):
        total = total + (passes[f"{kind} Direct"] + passes[f"{kind} Indirect"]) \
            * passes[f"{kind} Color"]
    image = result.mean()
    assert np.all(np.isfinite(total))
    err = np.abs(total - image)
    assert np.all(err <= 1e-5 * (1.0 + np.abs(image))), err.max()
    for name in light_passes.PASSES:       # every pass has light in this scene
        assert passes[name].max() > 0.0, name


def _sum_of_passes(passes):
    total = passes["Emission"] + passes["Environment"]
    for kind in ("Diffuse", "Glossy", "Transmission"):
        total = total + (passes[f"{kind} Direct"] + passes[f"{kind} Indirect"]) \
            * passes[f"{kind} Color"]
    return total


def test_the_passes_add_up_to_an_adaptive_image():
    """With adaptive sampling the image is the mean of each pixel's two halves' means
    (adaptive.Halves.mean), and so are the passes: the sum identity still holds. Deliberate
    error: the passes' pooled means instead (sums over the pixel's samples) miss it by up to
    0.070 (4.3% of a pixel's 1 + value) on this render of 32 to 64 samples per pixel."""
    scene = mixed_scene(spp=64)
    result = _render(scene, light_passes=True, noise_threshold=0.05, min_spp=8)
    assert result.samples().min() < result.samples().max()      # pixels stopped early
    image = result.mean()
    err = np.abs(_sum_of_passes(result.light_pass_images()) - image)
    assert np.all(err <= 1e-5 * (1.0 + np.abs(image))), err.max()


def test_the_image_is_the_same_with_and_without_the_passes(mixed):
    scene, result = mixed
    plain = _render(scene)
    assert np.array_equal(plain.mean(), result.mean())


def test_a_diffuse_wall_seen_directly_gives_its_colour_and_direct_light_only():
    """A Lambert wall lit only by a point lamp (no world, one bounce): Diffuse Color is the wall's
    colour exactly; all light is Diffuse Direct, which times the colour is the image."""
    wall = (*quad((0.0, 0.0, -1.0), 10.0, 10.0), 0)
    lamp = {"name": "lamp", "kind": "point", "position": [0.0, 0.0, 1.0],
            "intensity": [20.0, 20.0, 20.0], "radius": 0.0}
    scene = make_scene([wall], [{"name": "Wall", "kind": "diffuse", "color": list(WALL)}],
                       camera(resolution=(8, 8)), lights=[lamp], spp=4, max_depth=1)
    result = _render(scene, light_passes=True)
    passes = result.light_pass_images()
    assert np.allclose(passes["Diffuse Color"], WALL, rtol=1e-6)
    assert not passes["Diffuse Indirect"].any() and not passes["Glossy Direct"].any()
    assert not passes["Emission"].any() and not passes["Environment"].any()
    assert np.allclose(passes["Diffuse Direct"] * passes["Diffuse Color"], result.mean(),
                       rtol=1e-5)


def test_the_world_seen_directly_is_environment_and_an_emitter_emission():
    """Camera rays that escape give Environment (the world's colour exactly); an Emission
    surface seen directly gives Emission; no surface, no Color. Deliberate error, in
    light_passes.add_found: the world seen directly counted as Emission fails it (Environment
    0 where the world is (0.2, 0.3, 0.5))."""
    light = (*quad((0.0, 0.0, -1.0), 1.0, 1.0), 0)
    scene = make_scene([light], [{"name": "L", "kind": "emission", "color": [1.0, 0.5, 0.25],
                                  "strength": 2.0}],
                       camera(resolution=(8, 8), lens=50.0), world=WORLD, spp=4)
    result = _render(scene, light_passes=True)
    passes = result.light_pass_images()
    env, emission = passes["Environment"], passes["Emission"]
    assert np.allclose(env[0, 0], WORLD) and not emission[0, 0].any()
    assert np.allclose(emission[4, 4], (2.0, 1.0, 0.5)) and not env[4, 4].any()
    assert np.allclose(env + emission, result.mean(), rtol=1e-6)
    for kind in ("Diffuse", "Glossy", "Transmission"):
        assert not passes[f"{kind} Color"].any()


def test_a_mirror_shows_its_reflection_in_glossy_and_glass_in_transmission():
    """Through a white mirror the world is Glossy Direct (colour 1), none of it Environment or
    Transmission. Deliberate error, in light_passes.add_colors: the glossy albedo 5% high fails
    it (Glossy Color 1.05)."""
    mirror = (np.array([[-1, -1, 1], [1, -1, -1], [1, 1, -1], [-1, 1, 1]], np.float32),
              np.array([[0, 1, 2], [0, 2, 3]], np.int32), 0)
    scene = make_scene([mirror], [{"name": "M", "kind": "mirror", "color": [1.0, 1.0, 1.0]}],
                       camera(resolution=(8, 8), lens=150.0), world=WORLD, spp=2)
    passes = _render(scene, light_passes=True).light_pass_images()
    assert np.allclose(passes["Glossy Color"], 1.0, atol=1e-3)
    assert np.allclose(passes["Glossy Direct"], WORLD, rtol=1e-3)
    assert not passes["Environment"].any() and not passes["Transmission Direct"].any()


def test_film_light_passes_leaves_out_and_counts_nan_samples():
    rows = np.ones((3, light_passes.COLUMNS))
    rows[1, 5] = np.nan
    total = np.zeros((2, light_passes.COLUMNS))
    bad = light_passes.film_light_passes(rows, 3, 0, 2, np.zeros(0, np.int64), total)
    assert bad == 1
    assert np.array_equal(total[0], np.ones(light_passes.COLUMNS))
    assert np.array_equal(total[1], np.ones(light_passes.COLUMNS))


def test_safe_divide_even_color_follows_cycles():
    """util/color.h: a zero channel of the divisor takes the mean of the others' quotients."""
    a = np.array([[2.0, 4.0, 6.0], [2.0, 4.0, 6.0], [2.0, 4.0, 6.0], [1.0, 1.0, 1.0]])
    b = np.array([[1.0, 2.0, 3.0], [0.0, 2.0, 3.0], [0.0, 0.0, 2.0], [0.0, 0.0, 0.0]])
    out = light_passes.safe_divide_even_color(a, b)
    assert np.allclose(out, [[2, 2, 2], [2, 2, 2], [3, 3, 3], [0, 0, 0]])
