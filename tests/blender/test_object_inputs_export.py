"""The exporter's side of the object and attribute inputs (addon/export/shader/input_nodes.py,
depsgraph.py, meshes.py, custom_properties.py): what the scene file carries and what is warned.
Their values against Cycles: tests/validation/test_object_inputs.py."""
from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import export  # noqa: E402
from snell.addon.export.custom_properties import property_rgba  # noqa: E402
from snell.tracer import scene as scene_mod  # noqa: E402


def _scene(make_color):
    """A quad whose Emission Color is make_color(tree)'s socket, and a camera."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    mesh = bpy.data.meshes.new("Quad")
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    colours = mesh.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
    colours.data.foreach_set("color", np.arange(16, dtype=np.float32) / 16)
    obj = bpy.data.objects.new("Quad", mesh)
    scene.collection.objects.link(obj)
    mat = bpy.data.materials.new("Probe")
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    tree.links.new(make_color(tree), emission.inputs["Color"])
    mesh.materials.append(mat)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0, 0, 3)
    scene.collection.objects.link(cam)
    scene.camera = cam
    return export.export_depsgraph(bpy.context.evaluated_depsgraph_get())


def _attribute(kind, name):
    def make(tree):
        node = tree.nodes.new("ShaderNodeAttribute")
        node.attribute_type, node.attribute_name = kind, name
        return node.outputs["Color"]
    return make


@pytest.mark.parametrize("kind, name, what", [("GEOMETRY", "pointiness", "standard")])
def test_unread_attributes_are_warned_naming_material_node_and_attribute(kind, name, what):
    """A Cycles standard attribute Snell does not read (in a program: its Emission Strength
    from Object Info, so that the program renders more of the tree than the fixed kinds) is
    warned, read as 0."""
    def make(tree):
        info = tree.nodes.new("ShaderNodeObjectInfo")
        emission = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
        tree.links.new(info.outputs["Random"], emission.inputs["Strength"])
        return _attribute(kind, name)(tree)
    scene, warnings = _scene(make)
    assert scene.materials[0]["kind"] == "program"
    assert any("material 'Probe'" in w and "'Attribute'" in w and repr(name) in w
               and what in w for w in warnings), warnings


def test_texture_coordinate_and_object_info_outputs_are_evaluated():
    """Every Texture Coordinate output (Object of another object too) and every Object Info
    output compile without a warning."""
    def make(tree):
        tc = tree.nodes.new("ShaderNodeTexCoord")
        tc.object = bpy.data.objects.get("Camera")
        info = tree.nodes.new("ShaderNodeObjectInfo")
        add = None
        for socket in [*tc.outputs, *info.outputs]:
            node = tree.nodes.new("ShaderNodeVectorMath")
            tree.links.new(socket, node.inputs[0])
            if add is not None:
                tree.links.new(add.outputs[0], node.inputs[1])
            add = node
        return add.outputs[0]
    scene, warnings = _scene(make)
    assert warnings == []
    (obj,) = scene.objects
    assert set(obj) == {"name", "closed", "matrix", "color", "pass_index", "random_id"}


def test_objects_carry_their_data_only_where_a_program_reads_it():
    """A program of Texture Coordinate Generated leaves the scene's objects as they were
    (the stored Cycles references of such scenes keep their keys)."""
    def make(tree):
        return tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"]
    scene, warnings = _scene(make)
    assert [set(o) for o in scene.objects] == [{"name", "closed"}]


def test_attributes_survive_a_scene_file(tmp_path):
    """A Color Attribute's texture coordinates (the point colours at each triangle's corners)
    and an object property's are saved and loaded with the scene."""
    def make(tree):
        node = tree.nodes.new("ShaderNodeVertexColor")
        node.layer_name = "Col"
        mix = tree.nodes.new("ShaderNodeVectorMath")
        tree.links.new(node.outputs["Color"], mix.inputs[0])
        tree.links.new(_attribute("OBJECT", "pass_index")(tree), mix.inputs[1])
        return mix.outputs[0]
    scene, warnings = _scene(make)
    assert warnings == []
    kinds = {(tc["kind"], tc["name"]) for tc in scene.texcoords}
    assert kinds == {("attribute", "Col"), ("attribute_extra", "Col"),
                     ("object_attribute", "object:pass_index"),
                     ("object_attribute_extra", "object:pass_index")}
    colour = next(tc for tc in scene.texcoords if tc["kind"] == "attribute")["coords"]
    points = np.arange(16, dtype=np.float32).reshape(4, 4)[:, :3] / 16
    quad = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)], np.float32)
    corners = scene.positions[scene.triangles][:, :, :2]            # (T, 3, 2)
    which = np.argmin(np.abs(corners[:, :, None] - quad).sum(-1), axis=-1)
    assert np.allclose(colour, points[which])
    scene_mod.save(scene, tmp_path / "a.snell")
    loaded = scene_mod.load(tmp_path / "a.snell")
    assert [(tc["kind"], tc["name"]) for tc in loaded.texcoords] == \
        [(tc["kind"], tc["name"]) for tc in scene.texcoords]


def test_property_rgba_reads_as_blender_does():
    """Custom properties before RNA paths; numbers splat with alpha 1; arrays of up to four
    fill (0, 0, 0, 1); strings, long and boolean arrays are not found."""
    obj = bpy.data.objects.new("Props", None)
    obj["pass_index"] = 0.5             # a custom property shadows the RNA one
    obj["pair"] = [2.0, 3.0]
    obj["flag"] = True
    obj["text"] = "red"
    obj["long"] = [1.0, 2.0, 3.0, 4.0, 5.0]
    obj.pass_index = 9
    assert property_rgba(obj, "pass_index") == (0.5, 0.5, 0.5, 1.0)
    assert property_rgba(obj, "pair") == (2.0, 3.0, 0.0, 1.0)
    assert property_rgba(obj, "flag") == (1.0, 1.0, 1.0, 1.0)
    assert property_rgba(obj, "location") == (0.0, 0.0, 0.0, 1.0)
    for name in ("text", "long", "missing", ""):
        assert property_rgba(obj, name) is None


def test_texture_coordinate_from_instancer_is_warned():
    """From Instancer (Cycles' instancer's Generated and UV) is warned; the object's are used."""
    def make(tree):
        node = tree.nodes.new("ShaderNodeTexCoord")
        node.from_instancer = True
        info = tree.nodes.new("ShaderNodeObjectInfo")
        emission = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeEmission")
        tree.links.new(info.outputs["Random"], emission.inputs["Strength"])
        return node.outputs["Generated"]
    scene, warnings = _scene(make)
    assert any("From Instancer" in w and "'Texture Coordinate'" in w for w in warnings), warnings


def test_nonfinite_attribute_values_are_warned_and_read_as_0():
    """NaN and Inf in a colour attribute and in an object property: a warning naming the
    object and attribute, 0 in the scene file (which holds finite numbers only)."""
    def make(tree):
        obj = bpy.data.objects["Quad"]
        values = np.arange(16, dtype=np.float32) / 16
        values[[0, 5]] = np.nan, np.inf
        obj.data.color_attributes["Col"].data.foreach_set("color", values)
        obj["bad"] = float("inf")
        node = tree.nodes.new("ShaderNodeVertexColor")
        node.layer_name = "Col"
        mix = tree.nodes.new("ShaderNodeVectorMath")
        tree.links.new(node.outputs["Color"], mix.inputs[0])
        tree.links.new(_attribute("OBJECT", "bad")(tree), mix.inputs[1])
        return mix.outputs[0]
    scene, warnings = _scene(make)
    assert any("'Quad'" in w and "'Col'" in w and "NaN or Inf" in w for w in warnings), warnings
    assert any("'Quad'" in w and "'bad'" in w and "NaN or Inf" in w for w in warnings), warnings
    for tc in scene.texcoords:
        assert np.isfinite(tc["coords"]).all()
