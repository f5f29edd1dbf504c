"""F12 fills the light groups' passes of the View Layer's Light Groups (#33): "Combined_<group>"
registered for the compositor (with Render On a cluster too) and written into the result with
the tracer's values (on a cluster: tests/blender/test_farm_f12.py)."""
from __future__ import annotations

import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import registration  # noqa: E402
from support.render_passes import (f12_against_tracer, lamp_over_floor,  # noqa: E402
                                   registered_passes)

NAMES = ("Combined_key", "Combined_sky")


@pytest.fixture(scope="module", autouse=True)
def registered():
    registration.ensure_registered()
    yield


def build(tmp_path):
    """A diffuse floor under a point lamp in "key", a second lamp in no group and a blue world
    in "sky", Snell the engine, F12 saving a multilayer EXR."""
    scene = lamp_over_floor(tmp_path / "f12.exr", (("Lamp", (0.0, 0.0, 2.0), "key"),
                                                   ("Loose", (1.0, 0.0, 1.0), "")))
    for group in ("key", "sky"):
        scene.view_layers[0].lightgroups.add(name=group)
    scene.world.lightgroup = "sky"
    return scene


def test_the_groups_are_registered_for_the_compositor(tmp_path):
    scene = build(tmp_path)
    for where in ("DASK_SCHEDULER", "THIS_COMPUTER"):
        scene.snell.render_on = where
        registered = registered_passes(scene)
        for name in NAMES:
            assert (name, 3, "RGB", "COLOR") in registered, (where, registered)


def test_f12_writes_the_groups(tmp_path):
    """The passes in F12's EXR are the tracer's for the exported scene, and the loose lamp's
    light is in neither. Deliberate error: the passes written top row first (no flip to
    Blender's bottom-first rows) fails it (measured: 234 of 576 values off)."""
    build(tmp_path)
    written, result = f12_against_tracer(tmp_path / "f12.exr", NAMES, "light_group_images",
                                         light_groups=True)
    assert written["Combined_key"].max() > 0.1 and written["Combined_sky"].max() > 0.1
    loose = result.mean() - sum(result.light_group_images().values())
    assert loose.max() > 0.01          # the loose lamp's light, in Combined only

