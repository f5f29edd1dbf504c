"""Image textures (#16) against Cycles: a diffuse floor of a checker image (8-bit sRGB, Linear
interpolation: Cycles decodes after interpolating) and a metal floor whose roughness is an image
(Non-Color, Closest), under an area lamp and a dim world. Snell must be `snell compare`
consistent; the checker moved by a tenth of a texel, or read as Non-Color, must be caught."""
from __future__ import annotations

import copy
import importlib

import numpy as np
import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}


textured = importlib.import_module("textured_floors")
checker_png, stripes_png, build_floors = textured.checker_png, textured.stripes_png, textured.build_floors
_plane = textured.plane


@pytest.fixture(scope="module")
def floors(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("textures")
    blend = build_floors(str(tmp / "floors.blend"), checker_png(tmp / "checker.png"),
                         stripes_png(tmp / "stripes.png"))
    return Reference(blend, framing=FULL, spp=1024)


def _modified(fn):
    def modify(scene):
        scene = copy.copy(scene)
        scene.materials = copy.deepcopy(scene.materials)
        scene.images = [dict(im) for im in scene.images]
        fn(scene)
        return scene
    return modify


def test_exporter_reads_the_textures(floors):
    """Both textures export, from the planes' UV maps, with no warning."""
    assert floors.warnings == []
    mats = {m["name"]: m for m in floors.scene.materials}
    checker = mats["Checker"]["textures"]["color"]
    assert checker["interpolation"] == "linear" and checker["extension"] == "repeat"
    assert floors.scene.images[checker["image"]]["colorspace"] == "srgb"
    rough = mats["RoughStripes"]["textures"]["roughness"]
    assert rough["interpolation"] == "closest"
    assert floors.scene.images[rough["image"]]["colorspace"] == "linear"
    assert floors.scene.features()["textures"]


def test_textured_floors_match_cycles(floors):
    """Consistent (measured at 1024 spp: mean ratio 1.0026, z 1.26; sharpness z -1.6; at 256
    spp its sharpness test failed at p 0.009, everything else passing)."""
    verdict, detail = _verdict(floors.compare())
    assert verdict == "consistent", detail


def test_checker_moved_a_tenth_of_a_texel_is_caught(floors):
    def shift(scene):
        for mat in scene.materials:
            for tex in (mat.get("textures") or {}).values():
                tex["offset"] = [0.1 / 8, 0.0, 0.0]
    verdict, detail = _verdict(floors.compare(_modified(shift)))
    assert verdict == "inconsistent", detail


def test_checker_read_as_non_color_is_caught(floors):
    def as_linear(scene):
        for im in scene.images:
            im["colorspace"] = "linear"
    verdict, detail = _verdict(floors.compare(_modified(as_linear)))
    assert verdict == "inconsistent", detail


def test_roughness_texture_scaled_is_caught(floors):
    """The roughness image x 1.15 (0.15 -> 0.17, 0.6 -> 0.69) in Snell alone is caught."""
    def rougher(scene):
        for mat in scene.materials:
            tex = (mat.get("textures") or {}).get("roughness")
            if tex is not None:
                image = scene.images[tex["image"]]
                image["pixels"] = image["pixels"] * np.float32(1.15)
    verdict, detail = _verdict(floors.compare(_modified(rougher)))
    assert verdict == "inconsistent", detail


def test_nodes_between_images_and_the_bsdf_make_a_program(tmp_path):
    """A procedural texture and math between an image and the BSDF are compiled into a shader
    program; an image's Alpha, which Snell does not keep, is reported with material, node and
    output named (read as 1)."""
    from snell.tracer.shader import inputs, math_nodes, procedural_textures
    from snell.validation import compare
    scene = common.reset()
    common.setup_render(scene, (8, 8))
    png = checker_png(tmp_path / "c.png")
    mat = common.material("Mixed", "principled", (0.5, 0.5, 0.5), Roughness=0.4, Metallic=0.0)
    tree = mat.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    noise = tree.nodes.new("ShaderNodeTexNoise")
    tree.links.new(noise.outputs["Color"], bsdf.inputs["Base Color"])
    image = tree.nodes.new("ShaderNodeTexImage")
    image.image = bpy.data.images.load(png)
    math_node = tree.nodes.new("ShaderNodeMath")
    tree.links.new(image.outputs["Color"], math_node.inputs[0])
    tree.links.new(math_node.outputs[0], bsdf.inputs["Roughness"])
    tree.links.new(image.outputs["Alpha"], bsdf.inputs["Metallic"])
    _plane("P", (0.0, 0.0, 0.0), 2.0, mat)
    common.camera(scene, (0.0, -3.0, 2.0), (0.0, 0.0, 0.0))
    exported, warnings = compare.load_snell_scene(common.save(str(tmp_path / "m.blend")))
    (converted,) = exported.materials
    assert converted["kind"] == "program"
    ops = {row[0] for row in converted["program"]["code"]}
    assert inputs.IMAGE in ops and ops & set(math_nodes.SPECS)
    assert ops & set(procedural_textures.SPECS)
    assert len(warnings) == 1 and "material 'Mixed': node 'Image Texture': output 'Alpha' " \
        "is read as 1" in warnings[0], warnings
