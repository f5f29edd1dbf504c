"""Rough and Principled surfaces in the integrator: energy in a white furnace, next-event
estimation against BSDF sampling, emission, and the split with the light tracer.

The BSDFs themselves (sampling against their densities, tables) are tested in test_lobes.py and
test_microfacet_tables.py; here they are tested as the renderer uses them.
"""
import math

import numpy as np
import pytest

from support.builders import camera, icosphere, make_scene, quad
from snell.tracer import material_kinds
from snell.tracer.integrator import Renderer, render
from snell.tracer.materials import kind_code
from snell.tracer.microfacet_tables import ggx_albedo, shipped_tables
from support.stats import estimators_agree as _estimators_agree
from support.stats import z_bound

WHITE = [1.0, 1.0, 1.0]


def _furnace(material, spp=32, resolution=24):
    """A unit sphere of `material` in a world of radiance 1: (image, result)."""
    pos, tri, nrm = icosphere(4)
    scene = make_scene([(pos, tri, 0, nrm)], [material],
                       camera(position=(0, 0, 4), resolution=(resolution, resolution)),
                       world=WHITE, spp=spp, max_depth=64)
    result = render(scene, scene.settings(threads=2))
    return result.mean().astype(np.float64), result


def _sphere_pixels(img):
    """A mask of the pixels well inside the sphere's silhouette (24 px image, radius ~5.5 px)."""
    h, w = img.shape[:2]
    y, x = np.mgrid[:h, :w]
    return (x + 0.5 - w / 2) ** 2 + (y + 0.5 - h / 2) ** 2 < 4.0 ** 2


def _mean_and_se(img, result, mask):
    var = result.variance_of_mean()[..., 0][mask]
    return img[..., 0][mask].mean(), math.sqrt(var.sum()) / mask.sum()


@pytest.mark.parametrize("material", [
    {"name": "MultiGlossy", "kind": "glossy", "color": WHITE, "roughness": 0.6,
     "distribution": "multi_ggx"},
    {"name": "MultiGlass", "kind": "glass", "color": WHITE, "ior": 1.5, "roughness": 0.5,
     "distribution": "multi_ggx"},
    {"name": "WhitePlastic", "kind": "principled", "color": WHITE, "roughness": 0.5},
    {"name": "Chrome", "kind": "principled", "color": WHITE, "metallic": 1.0, "roughness": 0.4},
    {"name": "FrostedGlass", "kind": "principled", "color": WHITE, "transmission": 1.0,
     "roughness": 0.4},
], ids=lambda m: m["name"])
def test_energy_conserving_surfaces_vanish_in_a_white_furnace(material):
    """Multiscatter GGX and a white Principled BSDF conserve energy (Cycles' compensation): a
    sphere of them in a world of radiance 1 has radiance 1 wherever it is seen, up to the
    accuracy of the albedo tables (0.5%)."""
    img, result = _furnace(material)
    mean, se = _mean_and_se(img, result, _sphere_pixels(img))
    assert abs(mean - 1.0) < 0.005 + z_bound(5) * se, (mean, se)
    assert result.nan_count == 0


def test_single_scattering_ggx_loses_the_energy_its_albedo_table_says():
    """Plain GGX reflects E(mu) of the light: at the centre of the sphere (mu near 1) the image
    equals the table's E, and it is darker than its Multiscatter twin everywhere."""
    rough = 0.7
    single = {"name": "GGX", "kind": "glossy", "color": WHITE, "roughness": rough,
              "distribution": "ggx"}
    img, result = _furnace(single, spp=64)
    centre = np.zeros(img.shape[:2], bool)
    centre[11:13, 11:13] = True
    mean, se = _mean_and_se(img, result, centre)
    # The centre pixels see the sphere at mu > 0.99; E varies by < 0.2% there.
    expected, _ = ggx_albedo(shipped_tables(), rough, 0.995)
    assert expected < 0.95
    assert abs(mean - expected) < 0.004 + z_bound(1) * se, (mean, expected, se)


def test_layered_hits_are_counted_and_smooth_scenes_never_build_lobes():
    """A rough sphere goes through the layered code path; roughness 0 keeps the exact mirror and
    glass paths (the validator's smooth results do not move)."""
    _, rough = _furnace({"name": "R", "kind": "glossy", "color": WHITE, "roughness": 0.3}, spp=2)
    assert rough.stats["layered_hits"] > 0
    _, smooth = _furnace({"name": "S", "kind": "glossy", "color": WHITE, "roughness": 0.0},
                         spp=2)
    assert smooth.stats["layered_hits"] == 0 and smooth.stats["reflections"] > 0
    assert kind_code({"kind": "glass", "ior": 1.5, "roughness": 0.0}) == material_kinds.GLASS
    assert kind_code({"kind": "glass", "ior": 1.5, "roughness": 0.002}) == material_kinds.GLASS
    assert kind_code({"kind": "glass", "ior": 1.5, "roughness": 0.01}) == material_kinds.LAYERED
    assert kind_code({"kind": "principled", "color": WHITE}) == material_kinds.LAYERED


def _lit_rough_scene(material, max_depth=3):
    """A rough sphere on a grey floor under a one-sided area lamp, with a dim world."""
    floor = quad((0, 0, 0), 5, 5)
    pos, tri, nrm = icosphere(3, radius=0.6, center=(0, 0, 0.6))
    mats = [{"name": "Grey", "kind": "diffuse", "color": [0.5, 0.5, 0.5]}, material]
    m = np.eye(4)
    m[:3, 3] = (0.8, 0.3, 1.8)
    # A large lamp close by: light and BSDF sampling densities are comparable, so the MIS
    # weights matter (a small lamp leaves every weight near 0 or 1 and hides a wrong density).
    lamp = {"name": "Area", "kind": "area", "shape": "square", "matrix": m.tolist(),
            "size": [2.5, 2.5], "radiance": [2.0, 2.0, 2.0], "visible_camera": True}
    cam = camera(position=(0, 0, 5.0), resolution=(16, 16), lens=110.0)   # the sphere fills it
    return make_scene([(*floor, 0), (pos, tri, 1, nrm)], mats, cam, world=[0.1, 0.1, 0.1],
                      lights=[lamp], max_depth=max_depth)


@pytest.mark.parametrize("material", [
    {"name": "Glossy", "kind": "glossy", "color": [0.9, 0.7, 0.5], "roughness": 0.5},
    {"name": "RoughGlass", "kind": "glass", "color": WHITE, "ior": 1.5, "roughness": 0.5},
    {"name": "Plastic", "kind": "principled", "color": [0.2, 0.5, 0.8], "roughness": 0.4,
     "coat_weight": 1.0, "coat_roughness": 0.1},
], ids=lambda m: m["name"])
def test_light_sampling_and_bsdf_sampling_agree_on_rough_surfaces(material):
    """NEE with MIS (the lobes' eval and density) and BSDF sampling alone estimate the same
    image: a density that disagrees with the sampler, or an eval that disagrees with the
    sample's weight, shows as a difference."""
    _estimators_agree(_lit_rough_scene(material), 256, 1024)


def test_principled_emission_lights_the_scene_like_an_emission_shader():
    """A Principled BSDF's emission is a light: an emitting quad over a floor lights it as an
    Emission shader of the same radiance does (its own black base reflects nothing)."""
    floor = quad((0, 0, 0), 3, 3)
    panel = quad((0, 0, 1.0), 0.5, 0.5, normal_sign=-1)
    grey = {"name": "Grey", "kind": "diffuse", "color": [0.5, 0.5, 0.5]}
    emission = {"name": "Panel", "kind": "emission", "color": [1.0, 0.8, 0.6], "strength": 5.0}
    principled = {"name": "Panel", "kind": "principled", "color": [0.0, 0.0, 0.0],
                  "specular_ior_level": 0.0, "emission_color": [1.0, 0.8, 0.6],
                  "emission_strength": 5.0}
    m = np.eye(4)
    m[:3, 3] = (0.0, 0.0, 4.0)
    images = []
    for panel_mat in (emission, principled):
        scene = make_scene([(*floor, 0), (*panel, 1)], [grey, panel_mat],
                           camera(resolution=(16, 16), lens=30.0, matrix=m.tolist()),
                           spp=256, max_depth=2, seed=3)
        result = render(scene, scene.settings(threads=2))
        images.append((result.mean().astype(np.float64), result.variance_of_mean()))
    (a, va), (b, vb) = images
    for c in range(3):
        diff = a[..., c].mean() - b[..., c].mean()
        se = math.sqrt(va[..., c].sum() + vb[..., c].sum()) / a[..., c].size
        assert abs(diff) < z_bound(3) * se, (c, diff, se)
    assert a.mean() > 0.1


def test_light_tracer_leaves_rough_glass_to_the_path_tracer():
    """Light paths end on layered surfaces and the path tracer counts every path through them:
    with the caustics light tracer on and off, a floor under a rough glass sphere and a small
    lamp renders the same."""
    floor = quad((0, 0, 0), 3, 3)
    pos, tri, nrm = icosphere(3, radius=0.5, center=(0, 0, 0.8))
    mats = [{"name": "Grey", "kind": "diffuse", "color": [0.7, 0.7, 0.7]},
            {"name": "Frosted", "kind": "glass", "color": WHITE, "ior": 1.5, "roughness": 0.2},
            {"name": "Mirror", "kind": "mirror", "color": WHITE}]
    mirror = quad((1.2, 0, 0.5), 0.3, 0.3)
    lamp = {"name": "Point", "kind": "point", "position": [0.0, 0.0, 2.5], "radius": 0.05,
            "intensity": [8.0, 8.0, 8.0]}
    m = np.eye(4)
    m[:3, 3] = (0.0, 0.0, 4.0)
    scene = make_scene([(*floor, 0), (pos, tri, 1, nrm), (*mirror, 2)], mats,
                       camera(resolution=(16, 16), lens=30.0, matrix=m.tolist()),
                       lights=[lamp], spp=128, max_depth=6)
    on = Renderer(scene, scene.settings(caustics=True))
    assert on.caustics is not None          # the mirror gives the light tracer work
    a = on.render()
    b = Renderer(scene, scene.settings(caustics=False)).render()
    ma, mb = a.mean().astype(np.float64), b.mean().astype(np.float64)
    va, vb = a.variance_of_mean(), b.variance_of_mean()
    for c in range(3):
        diff = ma[..., c].mean() - mb[..., c].mean()
        se = math.sqrt(va[..., c].sum() + vb[..., c].sum()) / ma[..., c].size
        assert abs(diff) < z_bound(3) * se, (c, diff, se)


def test_a_lamp_invisible_to_glossy_rays_does_not_light_a_glossy_lobe():
    """Cycles leaves out the closures a lamp is invisible to: with visible_glossy off, a rough
    metal sphere in a black world stays black under the lamp (light sampling and BSDF sampling
    both), while a diffuse base under a Principled coat still sees it."""
    def sphere_light(material, visible_glossy):
        pos, tri, nrm = icosphere(3, radius=0.6)
        m = np.eye(4)
        m[:3, 3] = (0.0, 0.0, 2.0)
        lamp = {"name": "Area", "kind": "area", "shape": "square", "matrix": m.tolist(),
                "size": [2.0, 2.0], "radiance": [3.0, 3.0, 3.0], "visible_glossy": visible_glossy}
        scene = make_scene([(pos, tri, 0, nrm)], [material], camera(resolution=(12, 12)),
                           lights=[lamp], spp=16, max_depth=3)
        return render(scene, scene.settings(threads=2)).mean()

    metal = {"name": "Metal", "kind": "glossy", "color": WHITE, "roughness": 0.4}
    assert sphere_light(metal, True).max() > 0.05
    assert sphere_light(metal, False).max() == 0.0
    plastic = {"name": "Plastic", "kind": "principled", "color": [0.5, 0.5, 0.5],
               "coat_weight": 1.0}
    seen, unseen = sphere_light(plastic, True), sphere_light(plastic, False)
    assert 0.0 < unseen.mean() < seen.mean()
