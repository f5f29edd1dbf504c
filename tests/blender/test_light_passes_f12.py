"""F12 fills the light passes the View Layer asks for (#33): Blender registers them for the
compositor, the render writes them into its result (read back from the multilayer EXR F12
saves), with the values the tracer makes for the scene."""
from __future__ import annotations

import importlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import final, registration  # noqa: E402

common = importlib.import_module("common")

SIZE = (16, 12)
FLOOR = (0.8, 0.5, 0.3)
SWITCHES = ("use_pass_emit", "use_pass_environment", "use_pass_diffuse_direct",
            "use_pass_diffuse_color", "use_pass_glossy_indirect")
NAMES = ("Emission", "Environment", "Diffuse Direct", "Diffuse Color", "Glossy Indirect")


@pytest.fixture(scope="module", autouse=True)
def registered():
    registration.ensure_registered()
    yield


def build(tmp_path):
    """A diffuse floor under a point lamp and a blue world, Snell the engine, five of
    the light passes switched on, F12 saving a multilayer EXR."""
    scene = common.reset()
    common.setup_render(scene, SIZE, samples=4, max_bounces=3)
    common.set_world(scene, (0.2, 0.3, 0.5))
    floor = common.material("Floor", "diffuse", FLOOR)
    common.quad("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], floor)
    lamp = bpy.data.lights.new("Lamp", "POINT")
    lamp.energy = 100.0
    obj = bpy.data.objects.new("Lamp", lamp)
    obj.location = (0.0, 0.0, 2.0)
    scene.collection.objects.link(obj)
    common.camera(scene, (0.0, -3.0, 2.0), (0.0, 0.0, 0.0), lens=35.0)
    layer = scene.view_layers[0]
    for switch in SWITCHES:
        setattr(layer, switch, True)
    scene.render.engine = "SNELL"
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):
        settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format, settings.color_depth = "OPEN_EXR_MULTILAYER", "32"
    scene.render.filepath = str(tmp_path / "f12.exr")
    return scene


def test_the_light_passes_are_registered_for_the_compositor(tmp_path):
    from snell.addon.engine import SnellRenderEngine
    scene = build(tmp_path)
    registered = []

    class Recorder:
        def register_pass(self, scene, layer, name, channels, ids, kind):
            registered.append((name, channels, ids, kind))

    SnellRenderEngine.update_render_passes(Recorder(), scene, scene.view_layers[0])
    for name in NAMES:
        assert (name, 3, "RGB", "COLOR") in registered, registered
    assert not any(name == "Glossy Color" for name, *_ in registered)


def test_f12_writes_the_light_passes(tmp_path):
    """The passes in F12's EXR are the tracer's for the exported scene. Deliberate error: the
    rows written top first (no flip to Blender's bottom-first rows) fails it, 180 of 576
    values off by up to 0.5."""
    from snell.addon.export import export_depsgraph
    from snell.tracer.integrator import Renderer
    from snell.validation.cycles import read_pass
    scene = build(tmp_path)
    bpy.ops.render.render(write_still=True)
    assert final.last_render["error"] is None, final.last_render
    written = {name: read_pass(str(tmp_path / "f12.exr"), name) for name in NAMES}
    exported, _ = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    expected = Renderer(exported, exported.settings(light_passes=True)).render() \
        .light_pass_images()
    for name in NAMES:
        np.testing.assert_allclose(written[name], expected[name], rtol=1e-5, atol=1e-6)
    color = written["Diffuse Color"]
    # Pixels the floor covers have its colour exactly (edge pixels a share of it).
    inside = np.all(np.isclose(color, FLOOR, atol=1e-6), axis=-1)
    assert inside.sum() > 20 and np.all(color <= np.array(FLOOR) + 1e-6)
    assert written["Environment"].max() > 0.1 and written["Diffuse Direct"].max() > 0.1
