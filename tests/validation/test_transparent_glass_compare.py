"""Film > Transparent > Transparent Glass against Cycles (#30): the world seen through clear
glass is transparent too, as Cycles' LABEL_TRANSMIT_TRANSPARENT keeps a camera path's
PATH_RAY_TRANSPARENT_BACKGROUND through transmissions of roughness up to the threshold.

A glass product shot for compositing: on a transparent film under a grey world, a smooth glass
sphere, a Glass BSDF of roughness 0.05 (under Cycles' default threshold 0.1) and one of 0.3
(over it), in front of the sky, above a diffuse floor. Image and alpha are held against Cycles'
RGBA render; Snell without Transparent Glass, and with a threshold that makes the 0.05 glass
opaque, are each caught in the alpha.

Not held here: a Holdout seen through clear glass, where Cycles' Russian roulette biases its
Holdout low behind tinted glass (tests/validation/test_holdout_glass_compare.py,
docs/measurements.md).
"""
from __future__ import annotations

import importlib

import pytest

from support.cycles_reference import Reference, assert_image_and_alpha_consistent

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}
THRESHOLD = 0.1


def build(path):
    scene = common.reset()
    common.setup_render(scene, (48, 32), max_bounces=6)
    scene.render.film_transparent = True
    scene.cycles.film_transparent_glass = True
    scene.cycles.film_transparent_roughness = THRESHOLD
    common.set_world(scene, (0.5, 0.55, 0.6), 1.0)
    common.quad("Floor", [(-4, -3, 0), (4, -3, 0), (4, 3, 0), (-4, 3, 0)],
                common.material("Floor", "diffuse", (0.6, 0.6, 0.55)))
    for name, x, roughness in (("Clear", -1.3, 0.0), ("Frosted", 0.0, 0.05),
                               ("Milky", 1.3, 0.3)):
        common.uv_sphere(name, (x, 0.0, 0.9), 0.55,
                         common.material(name, "glass", (0.95, 0.95, 0.95), IOR=1.45,
                                         Roughness=roughness), segments=24, rings=12)
    common.camera(scene, (0.0, -5.0, 1.3), (0.0, 0.0, 0.9), lens=40.0)
    return common.save(path)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    blend = build(str(tmp_path_factory.mktemp("glassfilm") / "glassfilm.blend"))
    return Reference(blend, framing=FULL)


def test_the_file_asks_for_transparent_glass(reference):
    from snell.validation import cycles
    render = reference.scene.render
    assert (render["film_transparent_glass"], render["film_transparent_roughness"]) == \
        (True, THRESHOLD)
    assert cycles.scene_film(reference.scene)[2:] == (True, THRESHOLD)


def test_image_and_alpha_are_consistent(reference):
    assert_image_and_alpha_consistent(reference.compare())


def test_opaque_glass_is_caught(reference):
    """Snell without Transparent Glass (the world through the glass in the image, alpha 1)."""
    report = reference.compare(modify=lambda s: s.with_render(film_transparent_glass=False))
    assert report["alpha_channel"]["verdict"] == "inconsistent", report["alpha_channel"]


def test_a_lower_threshold_is_caught(reference):
    """Threshold 0.01: the 0.05 glass counts as rough, so its pixels turn opaque."""
    report = reference.compare(
        modify=lambda s: s.with_render(film_transparent_roughness=0.01))
    assert report["alpha_channel"]["verdict"] == "inconsistent", report["alpha_channel"]
