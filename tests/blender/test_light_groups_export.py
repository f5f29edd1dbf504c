"""The light groups' export (addon/export/light_groups.py): the view layer's groups, each lamp's,
object's and the world's group as an index into them, written to and read back from a file."""
import importlib
import os

import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import export  # noqa: E402
from snell.addon.export.depsgraph import differs_from_cycles  # noqa: E402
from snell.tracer import scene as scene_mod  # noqa: E402
from snell.tracer.scene import SceneError  # noqa: E402

common = importlib.import_module("common")


def build():
    """Two groups, 'key' and 'fill 2'; a lamp in 'key', an emissive quad and the world in
    'fill 2', a second lamp naming a group the view layer does not list, a floor in none."""
    scene = common.reset()
    common.camera(scene, (0.0, -6.0, 2.0), (0.0, 0.0, 0.0))
    common.set_world(scene, (0.1, 0.1, 0.1))
    layer = scene.view_layers[0]
    layer.lightgroups.add(name="key")
    layer.lightgroups.add(name="fill 2")
    floor = common.material("Floor", "diffuse")
    common.quad("Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], floor)
    light = common.material("Panel", "emission", (1.0, 1.0, 1.0), Strength=2.0)
    panel = common.quad("Panel", [(-1, 1, 1), (1, 1, 1), (1, 1, 2), (-1, 1, 2)], light)
    panel.lightgroup = "fill 2"
    for name, group in (("Key", "key"), ("Stray", "nowhere")):
        lamp = bpy.data.objects.new(name, bpy.data.lights.new(name, "POINT"))
        lamp.location = (0.0, -1.0, 3.0)
        lamp.lightgroup = group
        scene.collection.objects.link(lamp)
    scene.world.lightgroup = "fill 2"
    return scene


def test_groups_lights_objects_and_world_export_as_indices(tmp_path):
    """Names in the view layer's order; the lamp's, the emissive object's and the world's index;
    a group the view layer does not list is none, with a warning that Cycles does the same
    (so the validator still compares). Deliberate error: the objects' entries left out of the
    export (Exporter.add_instance without its light_groups.entry) fails the Panel's index."""
    build()
    scene, warnings = export.export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert scene.light_groups == ["key", "fill 2"]
    lights = {light["name"]: light for light in scene.lights}
    assert lights["Key"]["light_group"] == 0 and "light_group" not in lights["Stray"]
    objects = {obj["name"]: obj for obj in scene.objects}
    assert objects["Panel"]["light_group"] == 1 and "light_group" not in objects["Floor"]
    assert scene.world["light_group"] == 1
    stray = [w for w in warnings if "'nowhere'" in w]
    assert len(stray) == 1 and "light 'Stray'" in stray[0] and not differs_from_cycles(stray[0])
    path = os.path.join(tmp_path, "groups.snell")
    scene_mod.save(scene, path)
    back = scene_mod.load(path)
    assert back.light_groups == scene.light_groups
    assert [x.get("light_group") for x in back.lights] == [x.get("light_group")
                                                            for x in scene.lights]


def test_a_scene_without_groups_exports_as_before():
    """No light groups: no light_groups key in the header, no light_group anywhere (files and
    the stored Cycles references' scenes read as before)."""
    common.reset()
    common.camera(bpy.context.scene, (0.0, -6.0, 2.0), (0.0, 0.0, 0.0))
    common.quad("Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)],
                common.material("Floor", "diffuse"))
    scene, _ = export.export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert scene.light_groups == [] and "light_groups" not in scene.header()
    assert all("light_group" not in obj for obj in scene.objects)


@pytest.mark.parametrize("change, message", [
    (lambda s: s.lights.__setitem__(0, {**s.lights[0], "light_group": 2}),
     "lights[0].light_group: expected an index into light_groups from 0 to 1, got 2"),
    (lambda s: setattr(s, "light_groups", ["key", "key"]),
     "light_groups: names must be distinct"),
    (lambda s: s.world.__setitem__("light_group", "fill"),
     "world.light_group: expected an index into light_groups"),
])
def test_a_bad_group_is_an_error_naming_it(change, message):
    build()
    scene, _ = export.export_depsgraph(bpy.context.evaluated_depsgraph_get())
    change(scene)
    with pytest.raises(SceneError, match=message.replace("[", r"\[").replace("]", r"\]")):
        scene_mod.validate(scene)
