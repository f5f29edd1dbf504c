"""Shader programs (#29) against Cycles: node trees the fixed material kinds cannot render,
compiled to programs (addon/export/shader/) and run per hit (tracer/shader/), in scenes that
reproduce what the issue's third-party files do. Each must be `snell compare` consistent, and
a small deliberate error in its program must be caught.

Glass: in the Cornell box, glass mixed with Transparent through Is Shadow Ray (its shadow is
light), glass built as Mix(Fresnel, Refraction, Glossy) with the Fresnel node's IOR not the
Refraction's (of one IOR it is exported as glass: test_glass_materials_compare.py), and a
dispersion node group adding three tinted glasses of different IOR.
Cut-outs: a leaf, a Principled BSDF whose Alpha is a striped image (its shadow striped too),
and a lamp panel invisible to the camera: Mix(Emission, Transparent) by Is Camera Ray.
"""
from __future__ import annotations

import importlib

import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict
from support.programs import material_copy, with_constant, with_slot_constant

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")
graphs = importlib.import_module("node_materials")
textured = importlib.import_module("textured_floors")

FULL = {"resolution_percentage": 100}
SHADOW_IOR, FRESNEL_IOR, REFRACTION_IOR = 1.45, 1.47, 1.45
CLEAR = 0.95      # the shadow glass's Transparent colour


def build_glass(path):
    scene = common.reset()
    common.setup_render(scene, (48, 48))
    common.cornell_box(light_size=0.8)
    common.uv_sphere("ShadowSphere", (-0.45, 0.3, 0.45), 0.45,
                     graphs.shadow_glass(SHADOW_IOR, CLEAR), 48, 24)
    common.uv_sphere("FresnelSphere", (0.5, 0.4, 0.35), 0.35,
                     graphs.fresnel_glass(FRESNEL_IOR, REFRACTION_IOR), 48, 24)
    common.uv_sphere("DispersionSphere", (0.1, -0.35, 0.25), 0.25, graphs.dispersion_glass(),
                     48, 24)
    # Close up on the floor, where the spheres and their shadows are.
    common.camera(scene, (0.0, -2.3, 0.9), (0.0, 0.1, 0.45), lens=40.0)
    return common.save(path)


def leaf(stripes):
    """A Principled BSDF whose Alpha is a striped (0.15 / 0.6) image's colour."""
    mat = textured.image_material("Leaf", "principled", stripes, "Alpha", "Closest", "Non-Color",
                                  **{"Base Color": (0.2, 0.6, 0.1, 1.0), "Roughness": 0.5})
    return mat


def hidden_lamp():
    """An emissive panel the camera does not see: Mix(Emission, Transparent, Is Camera Ray)."""
    mat, tree, out = graphs.node_tree("HiddenLamp")
    mix = tree.nodes.new("ShaderNodeMixShader")
    path = tree.nodes.new("ShaderNodeLightPath")
    tree.links.new(path.outputs["Is Camera Ray"], mix.inputs["Fac"])
    tree.links.new(graphs.node(tree, "ShaderNodeEmission", Color=(1.0, 0.8, 0.5, 1.0),
                         Strength=4.0).outputs[0], mix.inputs[1])
    tree.links.new(graphs.node(tree, "ShaderNodeBsdfTransparent").outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    return mat


def build_cutouts(path, stripes):
    scene = common.reset()
    common.setup_render(scene, (48, 48))
    common.cornell_box(light_strength=8.0)
    plane = textured.plane("Leaf", (0.0, 0.2, 1.0), 1.0, leaf(stripes))
    plane.rotation_euler = (1.2, 0.0, 0.3)
    common.quad("HiddenLamp", [(0.9, -0.3, 0.3), (0.9, -0.3, 0.9), (0.9, 0.3, 0.9),
                               (0.9, 0.3, 0.3)], hidden_lamp())
    common.cornell_camera(scene)
    return common.save(path)


@pytest.fixture(scope="module")
def glass(tmp_path_factory):
    return Reference(build_glass(str(tmp_path_factory.mktemp("programs") / "glass.blend")),
                     framing=FULL)


@pytest.fixture(scope="module")
def cutouts(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("programs")
    return Reference(build_cutouts(str(tmp / "cutouts.blend"),
                                   textured.stripes_png(tmp / "stripes.png")), framing=FULL)


def _programs(ref):
    return {m["name"]: m for m in ref.scene.materials if m["kind"] == "program"}


def _changed(name, old, new):
    """A modify function: material `name`'s program with constant `old` replaced by `new`."""
    return lambda scene: with_constant(scene, name, old, new)


def test_glass_trees_compile_to_programs(glass):
    """The three glass trees become programs, with no warning."""
    assert glass.warnings == []
    assert set(_programs(glass)) == {"ShadowGlass", "FresnelGlass", "DispersionGlass"}


def test_glass_trees_match_cycles(glass):
    """Consistent (measured: mean ratio 1.001/1.001/1.002, z 0.2/0.2/0.2, no tile failed)."""
    verdict, detail = _verdict(glass.compare())
    assert verdict == "consistent", detail


def test_shadow_glass_transparency_off_is_caught(glass):
    """The Transparent closure's colour 0.9 times what it is: the shadow 19% darker (two
    crossings; measured: mean ratio 0.989/0.987/0.990, 2 tiles failed)."""
    verdict, detail = _verdict(glass.compare(_changed("ShadowGlass", CLEAR, 0.9 * CLEAR)))
    assert verdict == "inconsistent", detail


def test_fresnel_factor_of_a_wrong_ior_is_caught(glass):
    """The Fresnel node's IOR 1.9 instead of 1.47 (its reflectance at normal incidence 9.6%
    instead of 3.6%), the Refraction BSDF's (1.45) unchanged (measured: mean ratio
    0.977/0.971/0.967, z -3.7/-4.7/-4.6, 7 tiles)."""
    from snell.tracer.shader import inputs
    verdict, detail = _verdict(glass.compare(
        lambda scene: with_slot_constant(scene, "FresnelGlass", inputs.FRESNEL, 2, 1.9)))
    assert verdict == "inconsistent", detail


def test_cutouts_compile_to_programs(cutouts):
    assert cutouts.warnings == []
    programs = _programs(cutouts)
    assert set(programs) == {"Leaf", "HiddenLamp"}
    assert programs["HiddenLamp"]["program"]["emission_varies"]


def test_cutouts_match_cycles(cutouts):
    """Consistent (measured: mean ratio 1.009/1.008/1.005, z 1.6/1.6/1.2, no tile failed)."""
    verdict, detail = _verdict(cutouts.compare())
    assert verdict == "consistent", detail


def test_leaf_rendered_opaque_is_caught(cutouts):
    """The leaf's Alpha link dropped (the block keeps its unlinked Alpha 1: what Snell rendered
    before programs; measured: mean ratio 0.92/1.01/0.92, z -15.7/1.7/-17.1, 9 tiles)."""
    from snell.tracer.shader import inputs

    def opaque(scene):
        scene, mat = material_copy(scene, "Leaf")
        program = mat["program"]
        program["code"] = [r for r in program["code"] if r[0] != inputs.COPY_FLOAT]
        return scene
    verdict, detail = _verdict(cutouts.compare(opaque))
    assert verdict == "inconsistent", detail


def test_hidden_lamp_strength_off_is_caught(cutouts):
    """Strength 4.4 instead of 4 (measured: mean ratio 1.041/1.034/1.029, z 7.4/6.3/6.4)."""
    verdict, detail = _verdict(cutouts.compare(_changed("HiddenLamp", 4.0, 4.4)))
    assert verdict == "inconsistent", detail
