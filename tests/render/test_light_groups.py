"""The light groups' passes (tracer/light_groups.py) on Snell's own renders: Cycles' sum identity
(the image is the groups' passes plus the light in no group), every strategy's light in its
light's group, and the image unchanged by making them."""
from __future__ import annotations

import numpy as np
import pytest

from snell.tracer.integrator import Renderer
from snell.tracer.scene import validate
from support.builders import camera, icosphere, make_scene, quad

WORLD = (0.2, 0.3, 0.5)
GROUPS = ["key", "panel", "sky", "rest"]


def _render(scene, **settings):
    return Renderer(scene, scene.settings(threads=2, **settings)).render()


def _sphere(radius, center, material):
    p, t, n = icosphere(2, radius, center)
    return p, t, material, n


def grouped_scene(spp=16, rest=3, **render):
    """A diffuse floor, a rough glossy sphere, a glass sphere (the point lamp's caustics: the
    light tracer's splats), a Principled sphere, an emissive quad (light vertices start on it),
    a point lamp, an area lamp with a spread, a lamp that casts no shadow and a blue world.
    Groups: the point lamp "key", the emissive quad "panel", the world "sky", the area lamp
    and the shadowless lamp `rest` (an index into GROUPS, or None: in no group)."""
    floor = (*quad((0.0, 0.0, -1.0), 2.0, 2.0), 0)
    glossy = _sphere(0.6, (-1.0, 0.0, -0.4), 1)
    glass = _sphere(0.6, (0.6, 0.2, -0.4), 2)
    principled = _sphere(0.4, (0.0, -1.2, -0.6), 3)
    panel = (*quad((0.0, 2.5, 1.0), 0.5, 0.5, -1.0), 4)
    mats = [{"name": "Floor", "kind": "diffuse", "color": [0.8, 0.3, 0.1]},
            {"name": "Glossy", "kind": "glossy", "color": [0.9, 0.8, 0.7], "roughness": 0.4},
            {"name": "Glass", "kind": "glass", "color": [1.0, 1.0, 1.0], "ior": 1.45},
            {"name": "Principled", "kind": "principled", "color": [0.2, 0.6, 0.3],
             "roughness": 0.3},
            {"name": "Light", "kind": "emission", "color": [1.0, 0.9, 0.8], "strength": 3.0}]
    m = np.eye(4)
    m[:3, 3] = (-1.5, -1.0, 1.5)
    lights = [{"name": "key", "kind": "point", "position": [1.5, -1.5, 1.5],
               "intensity": [30.0, 30.0, 30.0], "radius": 0.1},
              {"name": "area", "kind": "area", "shape": "square", "matrix": m.tolist(),
               "size": [0.5, 0.5], "radiance": [4.0, 4.0, 4.0], "spread": 2.0},
              {"name": "unshadowed", "kind": "point", "position": [-1.5, 1.5, 0.5],
               "intensity": [5.0, 5.0, 5.0], "radius": 0.0, "cast_shadow": False}]
    scene = make_scene([floor, glossy, glass, principled, panel], mats,
                       camera(position=(0.0, 0.0, 5.0), resolution=(24, 24), lens=40.0),
                       world=WORLD, lights=lights, spp=spp, **render)
    scene.light_groups = list(GROUPS)
    scene.lights[0]["light_group"] = 0
    if rest is not None:
        scene.lights[1]["light_group"] = scene.lights[2]["light_group"] = rest
    scene.objects[4]["light_group"] = 1
    scene.world["light_group"] = 2
    return validate(scene)


@pytest.fixture(scope="module")
def grouped():
    scene = grouped_scene()
    return scene, _render(scene, light_groups=True)


def _sum(groups):
    return sum(groups.values())


def test_the_image_is_the_sum_of_the_groups(grouped):
    """Every light in a group: the groups' passes add up to the image, within float32
    rounding (measured: 6.1e-5 at most, in a pixel of 10 or more), with every strategy
    running: light samples, BSDF samples of lamps, emitters and the world, the shadowless
    lamp's light added at once, the light vertices (on the emissive quad and the area lamp)
    and the light tracer's splats (the glass sphere's caustics). Deliberate errors, each
    failing it: the light tracer's splats left out of the groups (Renderer._group_splats
    returning none), largest pixel error 4.49 (the caustic); the shadowless lamp's light
    added to no group (deliver_light's add_grouped given -1), 4.91."""
    _, result = grouped
    assert result.stages["light tracing"][0] and result.stages["light vertices"][0]
    groups = result.light_group_images()
    assert sorted(groups) == sorted(f"Combined_{g}" for g in GROUPS)
    image = result.mean()
    err = np.abs(_sum(groups) - image)
    assert np.all(err <= 1e-5 * (1.0 + np.abs(image))), err.max()
    for name, values in groups.items():
        assert np.all(np.isfinite(values)) and values.max() > 0.0, name


def test_the_image_is_the_same_with_and_without_groups(grouped):
    """The light groups change no sample: the image bit for bit."""
    scene, result = grouped
    assert np.array_equal(_render(scene).mean(), result.mean())


def test_light_in_no_group_is_in_no_pass(grouped):
    """With the area lamp and the shadowless lamp in no group, the other groups' passes are the
    same, bit for bit (the same samples), and the image less their sum is what the 'rest' group
    held. Deliberate error: light in no group added to group 0 (add_grouped writing to
    max(group, 0)) fails the first assertion (Combined_key differs)."""
    _, result = grouped
    scene = grouped_scene(rest=None)
    alone = _render(scene, light_groups=True)
    groups, all_groups = alone.light_group_images(), result.light_group_images()
    for name in ("Combined_key", "Combined_panel", "Combined_sky"):
        assert np.array_equal(groups[name], all_groups[name]), name
    assert not groups["Combined_rest"].any()
    image = alone.mean()
    err = np.abs(image - _sum(groups) - all_groups["Combined_rest"])
    assert np.all(err <= 1e-5 * (1.0 + np.abs(image))), err.max()


def test_the_groups_add_up_to_an_adaptive_image():
    """With adaptive sampling the image is the mean of each pixel's two halves' means, and so
    are the groups' passes: the identity still holds."""
    scene = grouped_scene(spp=64)
    result = _render(scene, light_groups=True, noise_threshold=0.05, min_spp=8)
    assert result.samples().min() < result.samples().max()
    image = result.mean()
    err = np.abs(_sum(result.light_group_images()) - image)
    assert np.all(err <= 1e-5 * (1.0 + np.abs(image))), err.max()


def test_a_transparent_film_keeps_the_world_in_its_group():
    """Film > Transparent: the world a camera ray sees is not in the image, but Cycles still
    writes it to the world's group when it renders the Environment pass (film_write_background;
    measured in Cycles 5.0 on a transparent film: the world's group (0.2, 0.3, 0.5) with the
    Environment pass on, 0 with it off; Snell's light passes include Environment): a pixel
    that sees only the world has the world's colour in 'sky' and none in the image.
    Deliberate error: the add_to_group call left out of emitters fails it (sky 0)."""
    scene = grouped_scene(spp=4)
    result = _render(scene, light_groups=True, light_passes=True, film_transparent=True)
    sky = result.light_group_images()["Combined_sky"]
    assert np.allclose(sky[0, 0], WORLD) and not result.mean()[0, 0].any()


def test_clamped_light_is_clamped_in_its_group():
    """With Light Paths > Clamping, each group gets a contribution as Combined gets it, after
    clamping (Cycles' film_clamp_light before film_write_*): the identity holds with clamps
    that cut most of the light (direct 0.5, indirect 0.2). Deliberate error: the light a path
    finds given to its group unclamped (add_found_light) fails it, largest pixel error 954
    (the point lamp seen directly); the other tests, unclamped, pass with it."""
    scene = grouped_scene(spp=8)
    result = _render(scene, light_groups=True, sample_clamp_direct=0.5,
                     sample_clamp_indirect=0.2)
    image = result.mean()
    assert image.max() < _render(scene).mean().max()        # the clamps cut the light
    err = np.abs(_sum(result.light_group_images()) - image)
    assert np.all(err <= 1e-5 * (1.0 + np.abs(image))), err.max()


def test_the_splats_spread_by_a_wide_pixel_filter_keep_the_identity():
    """Blackman-Harris 1.5 px (Blender's default): each group's splats are spread over the
    pixels as the image's are (Renderer._group_splats), so the identity holds. Deliberate
    error: the groups' splats left unspread (each in the pixel its point lands in, as a
    1-pixel box) fails it, largest pixel error 1.16."""
    scene = grouped_scene(spp=8)
    result = _render(scene, light_groups=True, pixel_filter="blackman_harris", filter_width=1.5)
    image = result.mean()
    err = np.abs(_sum(result.light_group_images()) - image)
    assert np.all(err <= 1e-5 * (1.0 + np.abs(image))), err.max()
