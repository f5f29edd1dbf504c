"""Value and colour nodes in a shader program (#29) against Cycles, whole renders: a diffuse floor
whose colour is a Color Ramp of a Math of its coordinates, mixed (Mix Color, Overlay) with a
Hue/Saturation of a Mapping of them, under an area lamp and a dim world. Snell must be
`snell compare` consistent; deliberate errors in the program (the Mix factor off by 0.05, Sine run
as Cosine) must be caught.
"""
from __future__ import annotations

import importlib

import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict
from support.programs import material_copy, with_constant

from snell.tracer.shader import math_nodes

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")
textured = importlib.import_module("textured_floors")

FULL = {"resolution_percentage": 100}


def _node(tree, idname, **props):
    node = tree.nodes.new(idname)
    for key, value in props.items():
        setattr(node, key, value)
    return node


def value_floor_material():
    """The floor's material: Diffuse whose Color = Mix(Overlay, 0.6, ColorRamp(Math), HSV(...))."""
    mat = common.material("ValueFloor", "diffuse", (0.8, 0.8, 0.8))
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfDiffuse")
    tc = _node(tree, "ShaderNodeTexCoord")
    sep = _node(tree, "ShaderNodeSeparateXYZ")
    tree.links.new(tc.outputs["Object"], sep.inputs[0])
    wave = _node(tree, "ShaderNodeMath", operation="SINE")
    scaled = _node(tree, "ShaderNodeMath", operation="MULTIPLY_ADD")
    tree.links.new(sep.outputs[0], scaled.inputs[0])
    scaled.inputs[1].default_value = 4.0
    tree.links.new(sep.outputs[1], scaled.inputs[2])
    tree.links.new(scaled.outputs[0], wave.inputs[0])
    ramp = _node(tree, "ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].position = 0.2
    ramp.color_ramp.elements[0].color = (0.9, 0.3, 0.1, 1.0)
    ramp.color_ramp.elements[1].color = (0.1, 0.5, 0.9, 1.0)
    ramp.color_ramp.elements.new(0.55).color = (0.95, 0.9, 0.2, 1.0)
    remap = _node(tree, "ShaderNodeMapRange")
    remap.inputs["From Min"].default_value = -1.0
    tree.links.new(wave.outputs[0], remap.inputs["Value"])
    tree.links.new(remap.outputs[0], ramp.inputs[0])
    mapping = _node(tree, "ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, 0.6)
    mapping.inputs["Scale"].default_value = (0.5, 0.5, 1.0)
    tree.links.new(tc.outputs["Object"], mapping.inputs[0])
    hsv = _node(tree, "ShaderNodeHueSaturation")
    hsv.inputs["Hue"].default_value = 0.3
    tree.links.new(mapping.outputs[0], hsv.inputs["Color"])
    mix = _node(tree, "ShaderNodeMix", data_type="RGBA", blend_type="OVERLAY")
    mix.inputs[0].default_value = 0.6
    tree.links.new(ramp.outputs[0], mix.inputs[6])
    tree.links.new(hsv.outputs[0], mix.inputs[7])
    tree.links.new(mix.outputs[2], bsdf.inputs["Color"])
    return mat


def build(path):
    scene = common.reset()
    common.setup_render(scene, (64, 48))
    common.set_world(scene, (0.05, 0.05, 0.06))
    textured.plane("Floor", (0.0, 0.0, 0.0), 3.0, value_floor_material())
    light = bpy.data.lights.new("Lamp", "AREA")
    light.energy = 300.0
    light.size = 1.0
    lamp = bpy.data.objects.new("Lamp", light)
    lamp.location = (0.3, 1.2, 2.0)
    lamp.rotation_euler = (-0.5, 0.0, 0.0)
    scene.collection.objects.link(lamp)
    common.camera(scene, (0.0, -3.0, 2.6), (0.0, 0.1, 0.0), lens=32.0)
    return common.save(path)


@pytest.fixture(scope="module")
def floor(tmp_path_factory):
    return Reference(build(str(tmp_path_factory.mktemp("valuenodes") / "value_floor.blend")),
                     framing=FULL)


def test_value_floor_exports_without_warnings(floor):
    assert floor.warnings == []


def test_value_floor_matches_cycles(floor):
    """Consistent (measured at 256 spp: mean ratio 1.0003/0.9996/0.9993, mean z 0.70/-0.52/-1.33,
    no tile failed, sharpness z -0.26)."""
    verdict, detail = _verdict(floor.compare())
    assert verdict == "consistent", detail


def test_mix_factor_off_by_005_is_caught(floor):
    """The program's Mix factor 0.6 read as 0.65 (measured: mean z -12.9/-44.2/-40.1, mean ratio
    0.994/0.967/0.980, 32 tiles failed)."""
    verdict, detail = _verdict(floor.compare(lambda s: with_constant(s, "ValueFloor", 0.6, 0.65)))
    assert verdict == "inconsistent", detail


def test_sine_computed_as_cosine_is_caught(floor):
    """The Math node's Sine run as Cosine (its row's operation literal changed; measured: 54% of
    pixels within their z bound, 35 tiles failed, sharpness z -174)."""
    def cosine(scene):
        scene, mat = material_copy(scene, "ValueFloor")
        sine = math_nodes.MATH_OPERATIONS.index("SINE")
        rows = [row for row in mat["program"]["code"]
                if row[0] == math_nodes.MATH and row[1] == sine]
        assert len(rows) == 1
        rows[0][1] = math_nodes.MATH_OPERATIONS.index("COSINE")
        return scene
    verdict, detail = _verdict(floor.compare(cosine))
    assert verdict == "inconsistent", detail
