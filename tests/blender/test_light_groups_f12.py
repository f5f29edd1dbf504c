"""F12 fills the light groups' passes of the View Layer's Light Groups (#33): "Combined_<group>"
registered for the compositor (with Render On a cluster too) and written into the result with
the tracer's values (on a cluster: tests/blender/test_farm_f12.py)."""
from __future__ import annotations

import importlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import final, registration  # noqa: E402

common = importlib.import_module("common")

SIZE = (16, 12)
NAMES = ("Combined_key", "Combined_sky")


@pytest.fixture(scope="module", autouse=True)
def registered():
    registration.ensure_registered()
    yield


def build(tmp_path):
    """A diffuse floor under a point lamp in "key", a second lamp in no group and a blue world
    in "sky", Snell the engine, F12 saving a multilayer EXR."""
    scene = common.reset()
    common.setup_render(scene, SIZE, samples=4, max_bounces=3)
    common.set_world(scene, (0.2, 0.3, 0.5))
    floor = common.material("Floor", "diffuse", (0.8, 0.5, 0.3))
    common.quad("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], floor)
    layer = scene.view_layers[0]
    for group in ("key", "sky"):
        layer.lightgroups.add(name=group)
    for name, location, group in (("Lamp", (0.0, 0.0, 2.0), "key"),
                                  ("Loose", (1.0, 0.0, 1.0), "")):
        obj = bpy.data.objects.new(name, bpy.data.lights.new(name, "POINT"))
        obj.data.energy = 100.0
        obj.location = location
        obj.lightgroup = group
        scene.collection.objects.link(obj)
    scene.world.lightgroup = "sky"
    common.camera(scene, (0.0, -3.0, 2.0), (0.0, 0.0, 0.0), lens=35.0)
    scene.render.engine = "SNELL"
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):
        settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format, settings.color_depth = "OPEN_EXR_MULTILAYER", "32"
    scene.render.filepath = str(tmp_path / "f12.exr")
    return scene


def test_the_groups_are_registered_for_the_compositor(tmp_path):
    from snell.addon.engine import SnellRenderEngine
    scene = build(tmp_path)
    registered = []

    class Recorder:
        def register_pass(self, scene, layer, name, channels, ids, kind):
            registered.append((name, channels, ids, kind))

    for where in ("DASK_SCHEDULER", "THIS_COMPUTER"):
        scene.snell.render_on = where
        registered.clear()
        SnellRenderEngine.update_render_passes(Recorder(), scene, scene.view_layers[0])
        for name in NAMES:
            assert (name, 3, "RGB", "COLOR") in registered, (where, registered)


def test_f12_writes_the_groups(tmp_path):
    """The passes in F12's EXR are the tracer's for the exported scene, and the loose lamp's
    light is in neither. Deliberate error: the passes written top row first (no flip to
    Blender's bottom-first rows) fails it (measured: 270 of 576 values off, up to 0.43)."""
    from snell.addon.export import export_depsgraph
    from snell.tracer.integrator import Renderer
    from snell.validation.cycles import read_pass
    build(tmp_path)
    bpy.ops.render.render(write_still=True)
    assert final.last_render["error"] is None, final.last_render
    written = {name: read_pass(str(tmp_path / "f12.exr"), name) for name in NAMES}
    exported, _ = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    result = Renderer(exported, exported.settings(light_groups=True)).render()
    expected = result.light_group_images()
    for name in NAMES:
        np.testing.assert_allclose(written[name], expected[name], rtol=1e-5, atol=1e-6)
    assert written["Combined_key"].max() > 0.1 and written["Combined_sky"].max() > 0.1
    loose = result.mean() - sum(expected.values())
    assert loose.max() > 0.01          # the loose lamp's light, in Combined only
