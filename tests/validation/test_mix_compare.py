"""Mix Shaders with a constant factor (#29) against Cycles: where the mix is one material
(addon/export/mixes.py), Snell renders it as that and must be `snell compare` consistent.

A large sphere of Mix(0.3, red Diffuse, blue Diffuse) and a small one of Mix(1, Glass, GGX
Glossy) in the Cornell box, seen close up, built here with bpy; the factor off by 0.05 must be
caught.
"""
from __future__ import annotations

import copy
import importlib

import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}
FAC = 0.3
RED, BLUE = (0.8, 0.15, 0.1), (0.1, 0.25, 0.8)


def _mix(name, fac, first, second):
    """A material of Mix(fac, first, second), each a (node idname, {input: value})."""
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = fac
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    for i, (idname, values) in ((1, first), (2, second)):
        node = tree.nodes.new(idname)
        for key, value in values.items():
            if key == "distribution":
                node.distribution = value
            else:
                node.inputs[key].default_value = value
        tree.links.new(node.outputs[0], mix.inputs[i])
    return mat


def build(path):
    scene = common.reset()
    common.setup_render(scene, (48, 48))
    common.cornell_box()
    blend = _mix("Blend", FAC, ("ShaderNodeBsdfDiffuse", {"Color": (*RED, 1.0)}),
                 ("ShaderNodeBsdfDiffuse", {"Color": (*BLUE, 1.0)}))
    common.uv_sphere("Blend", (-0.25, 0.1, 0.6), 0.6, blend, segments=48, rings=24)
    picked = _mix("Picked", 1.0, ("ShaderNodeBsdfGlass", {"IOR": 1.5}),
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
