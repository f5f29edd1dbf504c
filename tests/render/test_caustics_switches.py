"""Cycles' caustics switches (tracer/path_limits.py) in the hybrid: the light tracer drops the
same paths as the path tracer, so the split of path space stays exact with a switch off.

The caustic room (support/caustic_scenes.py): a glass sphere and a mirror sphere under a small
emissive lamp, their caustics on the floor. Renders use independent samples and batches, so
every variance is honest.
"""
import numpy as np
import pytest

from support.caustic_scenes import BATCHES, caustic_room, hybrid_agrees
from snell.validation import metrics
from snell.tracer.integrator import Renderer
from snell.tracer.settings import LIGHT_PATHS_PER_CAMERA_PATH as FIXED_SHARE

SWITCHES = {"reflective off": {"caustics_reflective": False},
            "refractive off": {"caustics_refractive": False}}


def test_the_switches_partition_the_light_tracers_paths():
    """A light path's fate depends only on its last scattering before the floor: reflected or
    refracted. With the same light paths (same seed), the splats with reflective caustics off
    and those with refractive caustics off add up to all of them; both off, no light tracer."""
    scene = caustic_room(8).with_render(spp=64)
    splats = {}
    for name, switches in {"on": {}, **SWITCHES}.items():
        # The same light paths in each: a fixed share (the pilot's follows the switches).
        result = Renderer(scene, scene.settings(threads=1, batches=1, light_vertices=False,
                                                noise_threshold=0.0,
                                                light_paths_per_camera_path=FIXED_SHARE,
                                                **switches)).render()
        splats[name] = result.stats["caustic_splats"]
    assert splats["reflective off"] > 0 and splats["refractive off"] > 0, splats
    assert splats["reflective off"] + splats["refractive off"] == splats["on"], splats
    both = scene.settings(caustics_reflective=False, caustics_refractive=False)
    renderer = Renderer(scene, both)
    assert renderer.caustics is None
    assert renderer.stages()["light tracing"] == (
        False, "Cycles' reflective and refractive caustics off")


@pytest.mark.parametrize("name", sorted(SWITCHES))
def test_the_hybrid_renders_the_path_tracers_image_with_a_switch_off(name):
    """With a switch off the hybrid and the path tracer alone (independent seeds) still agree:
    the light tracer leaves out exactly the paths whose lobe the path tracer drops; and the
    switch changes the image (the path tracer with it on is brighter, and inconsistent)."""
    scene = caustic_room(8).with_render(**SWITCHES[name])
    hybrid, path = hybrid_agrees(scene)
    assert hybrid.light_in_image and hybrid.stats["caustic_splats"] > 0
    on = Renderer(scene, scene.settings(seed=2, sampler="independent", caustics=False, spp=512,
                                        batches=BATCHES, caustics_reflective=True,
                                        caustics_refractive=True)).render()
    vb, dfb = path.variance_and_dof()
    vc, dfc = on.variance_and_dof()
    changed = metrics.compare(on.mean(), vc, dfc, path.mean(), vb, dfb)
    assert changed["verdict"] == metrics.INCONSISTENT
    assert float(np.mean(on.mean())) > float(np.mean(path.mean()))
