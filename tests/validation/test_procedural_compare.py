"""Procedural textures (#29) in whole renders against Cycles: a diffuse floor whose colour is a
Checker texture (Generated coordinates: its Vector is unlinked) under an area lamp, and two
emissive planes coloured by a Noise texture (fBm, 3D, with distortion; Generated coordinates)
and a Voronoi texture (F1, 3D, Object coordinates). Snell must be `snell compare` consistent;
the same scene with the noise's Scale 1% off, or the checker's 2% off, must be caught.

The deliberate errors are made in Blender: the scene is built again with the one value changed
and exported, and Snell renders that export against the reference of the unchanged scene (same
geometry, camera and lamp).

Measured at 512 spp (the stored Cycles reference, 8 seeds): consistent (mean ratios
1.0001-1.0002, mean z 0.2-0.6, z pass fraction 0.9995, sharpness z 0.63); the noise's scale 1%
off: inconsistent (pixel and tile tests, 3 tiles failed, z pass fraction 0.949); the checker's
2% off: inconsistent (17 tiles, mean z -17). The module runs in 41 s with compiled kernels."""
from __future__ import annotations

import importlib

import pytest

from support.cycles_reference import SCALE, SEED, Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}
SPP = 512


def _emissive(name, texture):
    """A material whose Emission colour is texture(tree) (an output socket)."""
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    tree.links.new(texture(tree), emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    return mat


def _noise(scale):
    def texture(tree):
        node = tree.nodes.new("ShaderNodeTexNoise")
        node.noise_dimensions, node.noise_type = "3D", "FBM"
        node.inputs["Scale"].default_value = scale
        node.inputs["Detail"].default_value = 3.0
        node.inputs["Distortion"].default_value = 0.5
        return node.outputs["Color"]
    return texture


def _voronoi(tree):
    node = tree.nodes.new("ShaderNodeTexVoronoi")
    node.voronoi_dimensions, node.feature = "3D", "F1"
    node.inputs["Scale"].default_value = 4.0
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Object"], node.inputs["Vector"])
    return node.outputs["Color"]


def _checker_floor(scale):
    mat = common.material("CheckerFloor", "diffuse", (0.8, 0.8, 0.8))
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname.startswith("ShaderNodeBsdf"))
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = scale
    checker.inputs["Color1"].default_value = (0.8, 0.6, 0.3, 1.0)
    checker.inputs["Color2"].default_value = (0.1, 0.2, 0.5, 1.0)
    tree.links.new(checker.outputs["Color"], bsdf.inputs["Color"])
    return mat


def _plane(name, location, rotation, size, mat):
    bpy.ops.mesh.primitive_plane_add(size=size, location=location, rotation=rotation)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(mat)
    return obj


def build(path, noise_scale=5.0, checker_scale=4.0):
    """The scene, saved to path."""
    scene = common.reset()
    common.setup_render(scene, (64, 32))
    common.set_world(scene, (0.05, 0.05, 0.06))
    _plane("Floor", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 4.0, _checker_floor(checker_scale))
    _plane("NoisePanel", (-0.8, 1.0, 0.8), (1.5708, 0.0, 0.0), 1.4,
           _emissive("NoiseEmission", _noise(noise_scale)))
    _plane("VoronoiPanel", (0.8, 1.0, 0.8), (1.5708, 0.0, 0.0), 1.4,
           _emissive("VoronoiEmission", _voronoi))
    light = bpy.data.lights.new("Lamp", "AREA")
    light.energy = 300.0
    light.size = 1.0
    lamp = bpy.data.objects.new("Lamp", light)
    lamp.location = (0.3, -1.0, 2.5)
    lamp.rotation_euler = (0.3, 0.0, 0.0)
    scene.collection.objects.link(lamp)
    common.camera(scene, (0.0, -3.4, 1.9), (0.0, 0.4, 0.5), lens=32.0)
    return common.save(path)


@pytest.fixture(scope="module")
def panels(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("procedural")
    return Reference(build(str(tmp / "procedural.blend")), framing=FULL, spp=SPP), tmp


def _export_of(path, reference):
    """modify() for Reference.compare: the export of another .blend of the same scene, framed
    and set as the reference's own scene."""
    from snell.validation import compare
    other, _ = compare.load_snell_scene(path)
    other = other.with_camera(**{"resolution_percentage": SCALE, **FULL}).with_render(
        spp=reference.spp, seed=SEED, max_depth=reference.scene.render["max_depth"])
    return lambda scene: other


def test_exporter_reads_the_textures(panels):
    """The three textures compile without a warning."""
    reference, _ = panels
    assert reference.warnings == []


def test_procedural_panels_match_cycles(panels):
    """Consistent."""
    reference, _ = panels
    verdict, detail = _verdict(reference.compare())
    assert verdict == "consistent", detail


def test_noise_scale_off_by_one_percent_is_caught(panels):
    reference, tmp = panels
    wrong = build(str(tmp / "noise_scale.blend"), noise_scale=5.05)
    verdict, detail = _verdict(reference.compare(_export_of(wrong, reference)))
    assert verdict == "inconsistent", detail


def test_checker_scale_off_by_two_percent_is_caught(panels):
    reference, tmp = panels
    wrong = build(str(tmp / "checker_scale.blend"), checker_scale=4.08)
    verdict, detail = _verdict(reference.compare(_export_of(wrong, reference)))
    assert verdict == "inconsistent", detail
