"""Mix Shaders with a constant factor and node groups (#29) against Cycles: where the mix is
one material (addon/export/mixes.py), Snell renders it as that, reading a group's nodes flattened
(addon/export/nodes.py), and must be `snell compare` consistent.

A large sphere of a node group holding Mix(0.3, Diffuse, blue Diffuse), the first Diffuse's
colour the group node's input (red; white inside the group), and a small one of Mix(1, Glass,
GGX Glossy), in the Cornell box seen close up, built here with bpy; the factor off by 0.05 must
be caught, and so must the group's colour read from inside the group.
"""
from __future__ import annotations

import copy
import importlib

import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict
from support.shader_trees import mix_shader_material

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}
FAC = 0.3
RED, BLUE = (0.8, 0.15, 0.1), (0.1, 0.25, 0.8)


def _mixed(name, fac, first, second):
    """A material of Mix(fac, first, second), each a (node idname, {input: value})."""
    return mix_shader_material(name, fac, first, second)[0]


def _grouped(mat, color):
    """The material's nodes moved into a node group whose Color input feeds the mix's first
    Diffuse, the group node's Color set to `color`."""
    tree = mat.node_tree
    group = bpy.data.node_groups.new(mat.name + "Group", "ShaderNodeTree")
    group.interface.new_socket("Color", in_out="INPUT", socket_type="NodeSocketColor")
    group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
    gi, go = group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
    mix = group.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = tree.nodes["Mix Shader"].inputs["Fac"].default_value
    for i, old in ((1, tree.nodes["Diffuse BSDF"]), (2, tree.nodes["Diffuse BSDF.001"])):
        node = group.nodes.new("ShaderNodeBsdfDiffuse")
        node.inputs["Color"].default_value = old.inputs["Color"].default_value
        group.links.new(node.outputs[0], mix.inputs[i])
        if i == 1:
            group.links.new(gi.outputs[0], node.inputs["Color"])
    group.links.new(mix.outputs[0], go.inputs[0])
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    node.inputs["Color"].default_value = (*color, 1.0)
    tree.links.new(node.outputs[0], out.inputs["Surface"])
    return mat


def build(path):
    scene = common.reset()
    common.setup_render(scene, (48, 48))
    common.cornell_box()
    blend = _grouped(_mixed("Blend", FAC, ("ShaderNodeBsdfDiffuse", {"Color": (1, 1, 1, 1)}),
                          ("ShaderNodeBsdfDiffuse", {"Color": (*BLUE, 1.0)})), RED)
    common.uv_sphere("Blend", (-0.25, 0.1, 0.6), 0.6, blend, segments=48, rings=24)
    picked = _mixed("Picked", 1.0, ("ShaderNodeBsdfGlass", {"IOR": 1.5}),
                  ("ShaderNodeBsdfGlossy", {"Color": (0.95, 0.75, 0.5, 1.0), "Roughness": 0.2,
                                            "distribution": "GGX"}))
    common.uv_sphere("Picked", (0.3, -0.5, 0.15), 0.15, picked, segments=48, rings=24)
    common.camera(scene, (-0.25, -2.2, 0.9), (-0.25, 0.1, 0.6), lens=50.0)
    return common.save(path)


@pytest.fixture(scope="module")
def mixes(tmp_path_factory):
    return Reference(build(str(tmp_path_factory.mktemp("mix") / "mix.blend")), framing=FULL)


def test_mixes_export_as_one_material(mixes):
    assert mixes.warnings == []
    mats = {m["name"]: m for m in mixes.scene.materials}
    assert mats["Blend"]["kind"] == "diffuse"
    assert mats["Blend"]["color"] == pytest.approx(
        [(1 - FAC) * r + FAC * b for r, b in zip(RED, BLUE)], rel=1e-6)
    assert mats["Picked"]["kind"] == "glossy"


def test_constant_mixes_match_cycles(mixes):
    """Consistent (measured: mean ratio 1.002/0.999/0.999, z 0.9/-0.2/-0.3, no tile failed)."""
    verdict, detail = _verdict(mixes.compare())
    assert verdict == "consistent", detail


def test_mix_factor_off_by_005_is_caught(mixes):
    """Snell's Blend colour as if Fac were 0.35 (measured: mean z -9.4/1.3/11.3, 6 tiles)."""
    def off(scene):
        scene = copy.copy(scene)
        scene.materials = [dict(m, color=[0.65 * r + 0.35 * b for r, b in zip(RED, BLUE)])
                           if m["name"] == "Blend" else m for m in scene.materials]
        return scene
    verdict, detail = _verdict(mixes.compare(off))
    assert verdict == "inconsistent", detail


def test_group_input_read_inside_the_group_is_caught(mixes):
    """Snell's Blend colour as if the group's Color were the Diffuse's own (white) value
    (measured: every test failed, mean ratio 1.11/1.63/1.63, 35 tiles)."""
    def inside(scene):
        scene = copy.copy(scene)
        scene.materials = [dict(m, color=[(1 - FAC) + FAC * b for b in BLUE])
                           if m["name"] == "Blend" else m for m in scene.materials]
        return scene
    verdict, detail = _verdict(mixes.compare(inside))
    assert verdict == "inconsistent", detail
