"""The Denoising Albedo and Denoising Normal passes (tracer/features.py): Cycles' rule on lobes,
exact values where every path writes the same (a diffuse wall seen directly, through a mirror,
through glass of index 1), and the image unchanged by them."""
from __future__ import annotations

import numpy as np
import pytest

from snell.tracer import features, lobes, wavefront
from snell.tracer.integrator import Renderer
from snell.tracer.microfacet_tables import shipped_tables
from support.builders import box, camera, make_scene, quad

WALL = (0.8, 0.3, 0.1)


def _lobe(table, kind, weight, alpha, normal=(0.0, 0.0, 1.0)):
    row = table
    if kind == lobes.LAMBERT:
        lobes.new_lobe(row, lobes.LAMBERT, normal, weight)
    else:
        lobes.new_microfacet(row, normal, weight, lobes.DIST_GGX, alpha, 1.0, True, False,
                             lobes.NO_FRESNEL)
    return row


@pytest.mark.parametrize("rough_weight, writes", [(0.2, False), (0.25, False), (0.3, True)])
def test_a_surface_writes_when_more_than_a_quarter_of_its_sample_weight_is_rough(rough_weight,
                                                                                 writes):
    table = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
    _lobe(table[0], lobes.LAMBERT, (rough_weight,) * 3, 0.0, (0.0, 1.0, 0.0))
    _lobe(table[1], lobes.MICROFACET, (1.0 - rough_weight,) * 3, 0.0)
    wrote, rough, normal, specular = features.surface_features(table, 2, shipped_tables(),
                                                               (0.0, 0.0, 1.0))
    assert wrote == writes
    assert np.allclose(rough, rough_weight) and np.allclose(specular, 1.0 - rough_weight)
    if writes:      # the normal averaged by sample weight
        assert np.allclose(normal, (0.0, rough_weight, 1.0 - rough_weight))


@pytest.mark.parametrize("alpha, rough", [(0.074, False), (0.076, True)])
def test_a_microfacet_lobe_is_rough_above_cycles_threshold(alpha, rough):
    """Cycles: rough when alpha_x alpha_y > 0.075^2 (roughness above sqrt(0.075) = 0.274)."""
    table = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
    _lobe(table[0], lobes.MICROFACET, (0.5, 0.5, 0.5), alpha)
    wrote, rough_albedo, _, specular = features.surface_features(table, 1, shipped_tables(),
                                                                 (0.0, 0.0, 1.0))
    assert wrote == rough
    assert np.allclose(rough_albedo if rough else specular, 0.5)


def test_film_features_leaves_out_and_counts_nan_samples():
    albedo = np.array([[0.5, 0.5, 0.5], [np.nan, 0.0, 0.0], [0.25, 0.25, 0.25]])
    normal = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, np.inf, 1.0]])
    a_sum, n_sum = np.zeros((3, 3)), np.zeros((3, 3))
    bad = wavefront.film_features(albedo, normal, 3, 0, 1, np.zeros(0, np.int64), a_sum, n_sum)
    assert bad == 2
    assert np.array_equal(a_sum[0], albedo[0]) and not a_sum[1:].any() and not n_sum[1:].any()


def _mirror_scene(mirror_color, wall=True, world=(1.0, 1.0, 1.0), **render):
    """Camera looking down -z at a 45-degree mirror that turns every ray to +x, towards a diffuse
    wall at x = 3 facing -x (or the world)."""
    mirror = (np.array([[-1, -1, 1], [1, -1, -1], [1, 1, -1], [-1, 1, 1]], np.float32),
              np.array([[0, 1, 2], [0, 2, 3]], np.int32), 0)
    quad_x = (np.array([[3, -5, -5], [3, -5, 5], [3, 5, 5], [3, 5, -5]], np.float32),
              np.array([[0, 1, 2], [0, 2, 3]], np.int32), 1)
    mats = [{"name": "Mirror", "kind": "mirror", "color": list(mirror_color)},
            {"name": "Wall", "kind": "diffuse", "color": list(WALL)}]
    return make_scene([mirror, quad_x] if wall else [mirror], mats,
                      camera(resolution=(8, 8), lens=150.0), world=world, **render)


def _render(scene, **settings):
    return Renderer(scene, scene.settings(threads=2, **settings)).render()


def test_a_diffuse_wall_seen_directly_gives_its_colour_and_normal():
    wall = (*quad((0.0, 0.0, -1.0), 10.0, 10.0), 0)
    scene = make_scene([wall], [{"name": "Wall", "kind": "diffuse", "color": list(WALL)}],
                       camera(resolution=(8, 8)), world=(1.0, 1.0, 1.0), spp=4)
    result = _render(scene, denoising_passes=True)
    assert np.allclose(result.denoising_albedo(), WALL, atol=1e-6)
    # Facing the camera: Cycles' camera space has z into the scene.
    assert np.allclose(result.denoising_normal(), (0.0, 0.0, -1.0), atol=1e-6)


def test_through_a_mirror_the_passes_show_the_wall_tinted_by_the_mirror():
    """Stopping at the mirror would give albedo 0 and the mirror's normal."""
    tint = (0.5, 0.75, 1.0)
    result = _render(_mirror_scene(tint, spp=4), denoising_passes=True)
    assert np.allclose(result.denoising_albedo(), np.multiply(tint, WALL), atol=1e-6)
    assert np.allclose(result.denoising_normal(), (-1.0, 0.0, 0.0), atol=1e-6)


def test_light_found_on_the_way_is_added_to_the_albedo_as_cycles_does():
    """Cycles adds the world (and lamps, emitters) a path finds while it still carries the
    features, times their weight: the world seen in the mirror is the image's light (tint x
    world colour) times the features' weight (tint again), and the normal nothing."""
    tint, world = (0.5, 0.75, 1.0), (0.2, 0.4, 0.6)
    result = _render(_mirror_scene(tint, wall=False, world=world, spp=4), denoising_passes=True)
    assert np.allclose(result.denoising_albedo(), np.square(tint) * world, atol=1e-6)
    assert not result.denoising_normal().any()


def test_through_glass_of_index_one_the_passes_show_the_wall_tinted_by_the_glass():
    """Index 1: no reflection, every path goes through both faces; the weight is the glass's
    transmission colour at each face."""
    tint = (0.5, 1.0, 1.0)
    slab = (*box((-3.0, -3.0, 0.0), (3.0, 3.0, 1.0)), 0)
    wall = (*quad((0.0, 0.0, -1.0), 10.0, 10.0), 1)
    mats = [{"name": "Glass", "kind": "glass", "color": list(tint), "ior": 1.0},
            {"name": "Wall", "kind": "diffuse", "color": list(WALL)}]
    scene = make_scene([slab, wall], mats, camera(resolution=(8, 8)), world=(1.0, 1.0, 1.0),
                       spp=4)
    result = _render(scene, denoising_passes=True)
    expected = np.multiply(np.square(tint), WALL)
    assert np.allclose(result.denoising_albedo(), expected, atol=1e-6)
    assert np.allclose(result.denoising_normal(), (0.0, 0.0, -1.0), atol=1e-6)


@pytest.mark.parametrize("mode", [{}, {"noise_threshold": 0.05, "spp": 64},
                                  {"batches": 2, "spp": 8}])
def test_the_passes_leave_the_image_unchanged(mode):
    scene = _mirror_scene((0.9, 0.9, 0.9), spp=8)
    plain = _render(scene, **mode)
    passes = _render(scene, denoising_passes=True, **mode)
    assert plain.albedo_sum is None and passes.has_features
    assert np.array_equal(plain.mean(), passes.mean())
    assert passes.feature_nan_count == 0
    assert np.allclose(passes.denoising_albedo(), np.multiply(0.9, WALL), atol=1e-6)
