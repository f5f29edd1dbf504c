"""F12 fills the light groups' passes of the View Layer's Light Groups (#33): "Combined_<group>"
registered for the compositor and written into the result with the tracer's values; on a
cluster they are left out with a warning, never written empty."""
from __future__ import annotations

import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import final, registration  # noqa: E402
from support.render_passes import (exr_channels, f12_against_tracer,  # noqa: E402
                                   lamp_over_floor, registered_passes)

NAMES = ("Combined_key", "Combined_sky")


@pytest.fixture(scope="module", autouse=True)
def registered():
    registration.ensure_registered()
    yield


@pytest.fixture
def no_remote():
    yield
    final.remote_render = None


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
    registered = registered_passes(build(tmp_path))
    for name in NAMES:
        assert (name, 3, "RGB", "COLOR") in registered, registered


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


def test_on_a_cluster_the_groups_are_left_out_with_a_warning(tmp_path, no_remote):
    """Render On a cluster (here a stand-in that renders in this process, as the farm's
    Session is called): a warning names the missing passes, and the EXR has none of them."""
    from snell.tracer.integrator import Renderer
    build(tmp_path)
    final.remote_render = lambda scene, settings, name, frame, progress, stop=None: \
        Renderer(scene, settings).render(progress=progress)
    bpy.ops.render.render(write_still=True)
    assert final.last_render["error"] is None, final.last_render
    assert final.GROUPS_ON_CLUSTER in final.last_render["warnings"]
    channels = list(exr_channels(tmp_path / "f12.exr"))
    assert any(".Combined." in c for c in channels), channels
    assert not any("Combined_" in c for c in channels), channels
