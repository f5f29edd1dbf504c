"""Caustics from the world (issue 34): the light tracer starts light paths on the world (a
direction from the environment map's importance distribution, a line through a disk across a
specular object: tracer/light_tracer.py aimed_line), and the path tracer leaves it exactly the
world-lit paths L S+ D E that it used to render (the world seen through glass from a diffuse
vertex, weight 1 after a specular vertex).

The hybrid is held against the path tracer alone (caustics off, an independent seed): the same
image in expectation (the validator's tiles and image mean; pixels to 99%, as
test_caustics.py's hybrid test, since the path tracer finds a sun spot through glass on rare,
heavy-tailed paths), and far less noise in the caustic region (where the light tracer carries at
least 10% of the hybrid's image) at the same samples. Power: the world's light paths dropped
(the path tracer then skips light that nothing renders) or doubled are caught.

A uniform world starts no light paths (the path tracer renders its caustics with less noise:
lights.dispatch.WORLD_PEAK), but pure light tracing starts them on any world: that checks the
world's emission weights against the path tracer where the camera sees the floor.
"""
import math

import numpy as np
import pytest

from support import hdri
from support.builders import icosphere, make_scene, quad
from support.caustic_scenes import BATCHES, GLASS, WALLS, WHITE, look_at
from snell.tracer.integrator import Renderer
from snell.tracer.scene import validate
from snell.validation import metrics

RESOLUTION = (24, 24)
SPP = 512
# The caustic region's per-pixel variance of the mean, path tracer alone over hybrid, at equal
# samples: measured 20.7 (the test HDRI's sun spot of peak 200; variance x time 17.4).
VARIANCE_REDUCTION = 8.0


def world_scene(world, sun_peak=200.0):
    """A white floor and a smooth glass sphere (radius 0.3, centre 0.6 above it) under the test
    HDRI (a sky with a sun spot 34 degrees from the zenith) or a uniform white world."""
    pos, tri, normals = icosphere(3, radius=0.3, center=(0.0, 0.0, 0.6))
    floor = (*quad((0.0, 0.0, 0.0), 1.5, 1.5), WHITE)
    cam = look_at((0.0, -1.0, 1.6), (-0.1, 0.2, 0.1), RESOLUTION)
    scene = make_scene([floor, (pos, tri, GLASS, normals)], WALLS, cam, max_depth=6,
                       world=(1.0, 1.0, 1.0) if world == "uniform" else (0.0, 0.0, 0.0))
    if world == "hdri":
        # The sun spot at azimuth pi / 2 + 0.3: its caustic falls beside the sphere's foot.
        scene.images = [{"name": "sky", "source": "test",
                         "pixels": hdri.sky(sun_phi=0.5 * math.pi + 0.3, sun_peak=sun_peak)}]
        scene.world = {"color": [0.0, 0.0, 0.0], "environment": {
            "image": 0, "strength": 1.0, "matrix": np.eye(3).tolist(),
            "offset": [0.0, 0.0, 0.0], "interpolation": "linear"}}
        scene = validate(scene)
    return scene


def render(scene, **settings):
    return Renderer(scene, scene.settings(sampler="independent", batches=BATCHES,
                                          **{"spp": SPP, **settings})).render()


@pytest.fixture(scope="module")
def pair():
    """(hybrid result, path tracer result) under the HDRI."""
    scene = world_scene("hdri")
    return render(scene), render(scene, seed=1, caustics=False)


def caustic_region(hybrid):
    share = hybrid.light_image().sum(axis=2) / np.maximum(hybrid.mean().sum(axis=2), 1e-12)
    return share >= 0.1


def test_which_worlds_start_light_paths():
    """An HDRI with a sun spot starts light paths, named in the stages, and the path tracer
    leaves it the world-lit caustic paths; a uniform world or the sky without its sun does not
    (peak 1 and 1.6 of WORLD_PEAK 8), nor a world over no diffuse surface."""
    renderer = Renderer(world_scene("hdri"))
    assert renderer.split and renderer.world_split
    assert renderer.stages()["light tracing"] == (True, "from the world")
    for scene in (world_scene("uniform"), world_scene("hdri", sun_peak=0.0)):
        assert Renderer(scene).caustics is None
    assert Renderer(world_scene("uniform"), world_scene("uniform").settings(
        pure_light_tracing=True)).caustics is not None


def test_hybrid_renders_the_path_tracers_image(pair):
    """Same expectation: the world's caustic by light paths, the rest path traced, against the
    path tracer alone."""
    hybrid, path = pair
    assert hybrid.light_paths > 0 and hybrid.stats["caustic_splats"] > 0
    assert caustic_region(hybrid).sum() >= 10
    va, dfa = hybrid.variance_and_dof()
    vb, dfb = path.variance_and_dof()
    stats = metrics.compare(hybrid.mean(), va, dfa, path.mean(), vb, dfb, error_metrics=False)
    stats.pop("maps")
    assert stats["tests"]["tiles"] and stats["tests"]["image_mean"], stats
    assert stats["z_pass_fraction"] >= 0.99, stats


def test_far_less_noise_in_the_caustic(pair):
    """At equal samples the caustic region's variance falls by the measured factor (the bound
    is 40% of the measurement)."""
    hybrid, path = pair
    region = caustic_region(hybrid)
    ratio = path.variance_of_mean()[region].mean() / hybrid.variance_of_mean()[region].mean()
    assert ratio > VARIANCE_REDUCTION, ratio


@pytest.mark.parametrize("error", ["dropped", "doubled"])
def test_missing_or_doubled_world_light_paths_are_caught(pair, error):
    """Power: the hybrid without the world's light paths (while the path tracer still skips
    those paths), or with their weight doubled, is inconsistent with the path tracer."""
    hybrid, path = pair
    wrong = hybrid.mean() + (-1.0 if error == "dropped" else 1.0) * hybrid.light_image()
    va, dfa = hybrid.variance_and_dof()
    vb, dfb = path.variance_and_dof()
    stats = metrics.compare(wrong, va, dfa, path.mean(), vb, dfb, error_metrics=False)
    assert not (stats["tests"]["tiles"] and stats["tests"]["image_mean"]), error


def test_pure_light_tracing_from_a_uniform_world_matches_the_path_tracer():
    """The world's emission weights (uniform directions, the disk across the scene): pure light
    tracing renders what the camera sees of the floor (every path but the world seen directly
    or through the glass) as the path tracer does; doubled, it is caught."""
    scene = world_scene("uniform")
    result = render(scene, spp=1024, pure_light_tracing=True, light_paths_per_camera_path=0.5)
    floor = (Renderer(scene).object_index(4) == 0).all(axis=2)[..., None]
    pt = np.where(floor, result.mean(), 0.0)
    pt_var = np.where(floor, result.variance_of_mean(), 0.0)
    lt = np.where(floor, result.light_image(), 0.0)
    lt_var = np.where(floor, result.light_variance_of_mean(), 0.0)
    assert floor.sum() > 200
    for factor, verdict in ((1.0, metrics.CONSISTENT), (2.0, metrics.INCONSISTENT)):
        stats = metrics.compare(factor * lt, lt_var, BATCHES - 1, pt, pt_var, BATCHES - 1,
                                error_metrics=False)
        stats.pop("maps")
        assert stats["verdict"] == verdict, (factor, stats)
