"""Bump mapping in shader programs (#29, "Shading normals": the Bump node with a linked Height,
and bump displacement) against Cycles.

The bump scene: an upright wall whose Diffuse BSDF is bumped by a Wave texture (bands,
Generated coordinates), a second wall whose Diffuse BSDF is bumped, inverted, by sin(8 x) of
Geometry Position (a Math of Position), and a smooth sphere whose Glossy BSDF is bumped at
Strength 0.7 by a large-scale Noise texture of no detail; a lamp grazes them. The back-face
scene shows two Wave-bumped walls (Diffuse and Glossy) from behind. The displacement scene
bumps a Principled sphere and a Diffuse wall through the Material Output's Displacement
(a Displacement node in object space of a Wave texture's and a Noise texture's height; the
displacement method Cycles' default, Bump Only). Each must be `snell compare` consistent, and
the Bump nodes' Distance (or the Displacement node's Scale) 10% larger must be caught.

The image scene bumps a wall by an Image Texture of a height map (a PNG written here: smooth
domes; UV coordinates, Linear interpolation), and a wall (Diffuse) and a smooth sphere (Glossy)
by a tangent-space Vector Displacement (their UV maps' MikkTSpace tangents) of a Wave texture
along the frame's normal axis.

The wide-filter scene bumps a wall by sin(8 x) of Position through a Bump of Filter Width 2.5:
its heights are read a sizeable part of a period apart (the step is 2.5 times the pixel's
footprint, some 0.15 m), so the bent normal depends on the differentials' size, which must be
Cycles' (the camera ray's dD times the distance); the differentials 10% wider must be caught.

With compiled kernels and the stored references the module runs in about 30 s.
"""
from __future__ import annotations

import importlib
import math

import numpy as np
import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict
from support.programs import material_copy

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")
textured = importlib.import_module("textured_floors")

FULL = {"resolution_percentage": 100}
BUMPED = ("WaveDiffuse", "PositionDiffuse", "NoiseGlossy")
BACK = ("BackWaveDiffuse", "BackWaveGlossy")
DISPLACED = ("DisplacedPrincipled", "DisplacedDiffuse")
IMAGED = ("ImageDiffuse", "TangentDiffuse", "TangentGlossy")


def _wave(tree, scale=0.6):
    node = tree.nodes.new("ShaderNodeTexWave")
    node.wave_type, node.bands_direction, node.wave_profile = "BANDS", "X", "SIN"
    node.inputs["Scale"].default_value = scale
    node.inputs["Distortion"].default_value = 0.0
    node.inputs["Detail"].default_value = 0.0
    return node.outputs["Fac"]


def _noise(tree, scale=2.5):
    node = tree.nodes.new("ShaderNodeTexNoise")
    node.noise_dimensions, node.noise_type = "3D", "FBM"
    node.inputs["Scale"].default_value = scale
    node.inputs["Detail"].default_value = 0.0
    node.inputs["Distortion"].default_value = 0.0
    return node.outputs["Fac"]


def _position_sine(tree, frequency=8.0):
    """sin(frequency x) of Geometry Position."""
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    split = tree.nodes.new("ShaderNodeSeparateXYZ")
    tree.links.new(geometry.outputs["Position"], split.inputs[0])
    times = tree.nodes.new("ShaderNodeMath")
    times.operation = "MULTIPLY"
    times.inputs[1].default_value = frequency
    tree.links.new(split.outputs["X"], times.inputs[0])
    sine = tree.nodes.new("ShaderNodeMath")
    sine.operation = "SINE"
    tree.links.new(times.outputs[0], sine.inputs[0])
    return sine.outputs[0]


def bumped(name, shader, height, distance, strength=1.0, invert=False, filter_width=0.1,
           **values):
    """A material: shader (Diffuse, Glossy, ...) with its Normal from a Bump node whose Height
    is height(tree)."""
    mat = common.material(name, shader, (0.7, 0.5, 0.35), **values)
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname.startswith("ShaderNodeBsdf"))
    node = tree.nodes.new("ShaderNodeBump")
    node.invert = invert
    node.inputs["Filter Width"].default_value = filter_width
    node.inputs["Distance"].default_value = distance
    node.inputs["Strength"].default_value = strength
    tree.links.new(height(tree), node.inputs["Height"])
    tree.links.new(node.outputs["Normal"], bsdf.inputs["Normal"])
    return mat


def displaced(name, shader, height, scale, **values):
    """A material: shader into the Surface, a Displacement node of height(tree) (midlevel 0.5,
    object space) into the Displacement; displacement method Bump Only."""
    mat = common.material(name, shader, (0.6, 0.55, 0.4), **values)
    mat.displacement_method = "BUMP"
    tree = mat.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    node = tree.nodes.new("ShaderNodeDisplacement")
    node.space = "OBJECT"
    node.inputs["Midlevel"].default_value = 0.5
    node.inputs["Scale"].default_value = scale
    tree.links.new(height(tree), node.inputs["Height"])
    tree.links.new(node.outputs["Displacement"], out.inputs["Displacement"])
    return mat


def wall(name, location, rotation, mat, size=2.0):
    obj = textured.plane(name, location, size, mat)
    obj.rotation_euler = rotation
    return obj


def _lamp(scene, location=(0.0, -1.2, 2.8), rotation=(0.4, 0.0, 0.0), energy=600.0):
    light = bpy.data.lights.new("Lamp", "AREA")
    light.energy = energy
    light.size = 0.5
    lamp = bpy.data.objects.new("Lamp", light)
    lamp.location = location
    lamp.rotation_euler = rotation
    scene.collection.objects.link(lamp)


def build_bumps(path):
    scene = common.reset()
    common.setup_render(scene, (96, 48))
    common.set_world(scene, (0.02, 0.02, 0.025))
    # Upright walls facing -y (the plane's +z turned to -y).
    wall("WaveWall", (-1.7, 0.0, 1.0), (math.pi / 2, 0.0, 0.25),
         bumped("WaveDiffuse", "diffuse", _wave, 0.15))
    wall("PositionWall", (0.0, 0.2, 1.0), (math.pi / 2, 0.0, -0.2),
         bumped("PositionDiffuse", "diffuse", _position_sine, 0.06, invert=True), size=1.4)
    common.uv_sphere("NoiseBall", (1.6, 0.0, 1.0), 0.6,
                     bumped("NoiseGlossy", "glossy", _noise, 0.25, strength=0.7,
                            Roughness=0.3), 32, 16)
    _lamp(scene)
    common.camera(scene, (0.0, -5.2, 1.0), (0.0, 0.0, 1.0), lens=35.0)
    return common.save(path)


def build_back_faces(path):
    scene = common.reset()
    common.setup_render(scene, (48, 48))
    common.set_world(scene, (0.02, 0.02, 0.025))
    # Walls facing +y: the camera at -y sees their back faces.
    wall("BackDiffuse", (-0.55, 0.0, 1.0), (-math.pi / 2, 0.0, 0.2),
         bumped("BackWaveDiffuse", "diffuse", _wave, 0.15), size=1.0)
    wall("BackGlossy", (0.55, 0.0, 1.0), (-math.pi / 2, 0.0, -0.2),
         bumped("BackWaveGlossy", "glossy", _wave, 0.15, Roughness=0.35), size=1.0)
    _lamp(scene, energy=400.0)
    common.camera(scene, (0.0, -4.0, 1.0), (0.0, 0.0, 1.0), lens=35.0)
    return common.save(path)


def build_displacement(path):
    scene = common.reset()
    common.setup_render(scene, (64, 48))
    common.set_world(scene, (0.02, 0.02, 0.025))
    wall("DisplacedWall", (-0.8, 0.0, 1.0), (math.pi / 2, 0.0, 0.2),
         displaced("DisplacedDiffuse", "diffuse", _wave, 0.3), size=1.6)
    common.uv_sphere("DisplacedBall", (0.9, 0.0, 1.0), 0.6,
                     displaced("DisplacedPrincipled", "principled", _noise, 0.4,
                               Roughness=0.35), 32, 16)
    _lamp(scene)
    common.camera(scene, (0.0, -4.4, 1.0), (0.0, 0.0, 1.0), lens=35.0)
    return common.save(path)


def domes_png(path, size=64, n=4):
    """A height map of n x n smooth domes (8-bit grey, (1 - cos) profile), read as Non-Color."""
    y, x = np.mgrid[0:size, 0:size].astype(np.float64) + 0.5
    h = (0.5 - 0.5 * np.cos(2 * math.pi * n * x / size)) * (0.5 - 0.5 * np.cos(
        2 * math.pi * n * y / size))
    grey = np.round(h * 255.0).astype(np.uint8)
    return textured.write_png(path, np.repeat(grey[..., None], 3, axis=2))


def _image(path):
    def height(tree):
        node = tree.nodes.new("ShaderNodeTexImage")
        node.image = bpy.data.images.load(str(path))
        node.image.colorspace_settings.name = "Non-Color"
        node.interpolation = "Linear"
        return node.outputs["Color"]
    return height


def tangent_displaced(name, shader, scale, wave_scale, **values):
    """A material: shader into the Surface, a tangent-space Vector Displacement of (0, wave, 0)
    (Blender's y: the normal) into the Displacement; method Bump Only."""
    mat = common.material(name, shader, (0.5, 0.6, 0.7), **values)
    mat.displacement_method = "BUMP"
    tree = mat.node_tree
    out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
    combine = tree.nodes.new("ShaderNodeCombineXYZ")
    tree.links.new(_wave(tree, wave_scale), combine.inputs["Y"])
    node = tree.nodes.new("ShaderNodeVectorDisplacement")
    node.space = "TANGENT"
    node.inputs["Midlevel"].default_value = 0.0
    node.inputs["Scale"].default_value = scale
    tree.links.new(combine.outputs[0], node.inputs["Vector"])
    tree.links.new(node.outputs[0], out.inputs["Displacement"])
    return mat


def build_images(path, domes):
    scene = common.reset()
    common.setup_render(scene, (96, 48))
    common.set_world(scene, (0.02, 0.02, 0.025))
    wall("ImageWall", (-1.7, 0.0, 1.0), (math.pi / 2, 0.0, 0.25),
         bumped("ImageDiffuse", "diffuse", _image(domes), 0.08))
    wall("TangentWall", (0.0, 0.2, 1.0), (math.pi / 2, 0.0, -0.2),
         tangent_displaced("TangentDiffuse", "diffuse", 0.3, 0.6), size=1.4)
    common.uv_sphere("TangentBall", (1.6, 0.0, 1.0), 0.6,
                     tangent_displaced("TangentGlossy", "glossy", 0.15, 1.2, Roughness=0.3),
                     32, 16)
    _lamp(scene)
    common.camera(scene, (0.0, -5.2, 1.0), (0.0, 0.0, 1.0), lens=35.0)
    return common.save(path)


def build_wide(path):
    scene = common.reset()
    common.setup_render(scene, (64, 48))
    common.set_world(scene, (0.02, 0.02, 0.025))
    wall("WideWall", (0.0, 0.0, 1.0), (math.pi / 2, 0.0, 0.3),
         bumped("WideDiffuse", "diffuse", _position_sine, 0.1, filter_width=2.5), size=2.4)
    _lamp(scene)
    common.camera(scene, (0.0, -4.4, 1.0), (0.0, 0.0, 1.0), lens=35.0)
    return common.save(path)


@pytest.fixture(scope="module")
def wide(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bump")
    return Reference(build_wide(str(tmp / "wide.blend")), framing=FULL)


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bump")
    return Reference(build_images(str(tmp / "images.blend"), domes_png(tmp / "domes.png")),
                     framing=FULL)


@pytest.fixture(scope="module")
def bumps(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bump")
    return Reference(build_bumps(str(tmp / "bumps.blend")), framing=FULL)


@pytest.fixture(scope="module")
def back_faces(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bump")
    return Reference(build_back_faces(str(tmp / "back.blend")), framing=FULL)


@pytest.fixture(scope="module")
def displacement(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("bump")
    return Reference(build_displacement(str(tmp / "displacement.blend")), framing=FULL)


def with_scaled_slot(scene, names, opcode, slot, factor):
    """The scene with slot `slot` of every `opcode` instruction of the named materials'
    programs reading a new constant register: the constant it read times factor (the other
    readers of that constant unchanged)."""
    from snell.tracer.shader.program import SPECS, WIDTH
    for name in names:
        scene, mat = material_copy(scene, name)
        program = mat["program"]
        consts = program["constants"]
        old = {row[slot] for row in program["code"] if row[0] == opcode}
        assert old and all(reg < len(consts) for reg in old), (name, old)
        first_temp = len(consts)
        for row in program["code"]:
            for s, letter in enumerate(SPECS[row[0]][1], start=1):
                if letter in WIDTH and row[s] >= first_temp:
                    row[s] += len(old)
        new = {reg: first_temp + k for k, reg in enumerate(sorted(old))}
        program["constants"] = consts + [consts[reg] * factor for reg in sorted(old)]
        program["registers"] += len(old)
        for row in program["code"]:
            if row[0] == opcode:
                row[slot] = new[row[slot]]
    return scene


def _programs(ref):
    return {m["name"]: m for m in ref.scene.materials if m["kind"] == "program"}


def test_bumps_compile_to_programs_with_three_heights(bumps):
    """Every material is a program whose Bump reads its height at the hit and at two moved
    hits, with no warning."""
    from snell.tracer.shader import bump
    assert bumps.warnings == []
    programs = _programs(bumps)
    assert set(programs) == set(BUMPED)
    for mat in programs.values():
        ops = [row[0] for row in mat["program"]["code"]]
        assert ops.count(bump.BUMP) == 1
        assert ops.count(bump.OFFSET) == 2 and ops.count(bump.RESTORE) == 2


def test_bumps_match_cycles(bumps):
    """Consistent (measured at 256 spp against the stored reference: mean ratio 0.9999/
    0.9998/0.9997, mean z -0.05/-0.16/-0.22, z pass fraction 1.0, no tile failed)."""
    verdict, detail = _verdict(bumps.compare())
    assert verdict == "consistent", detail


def test_bump_distance_off_by_ten_percent_is_caught(bumps):
    """Every Bump's Distance 10% larger (measured: 21 tiles failed, mean ratio 0.987, mean z
    -9.5 to -10.8)."""
    from snell.tracer.shader import bump
    verdict, detail = _verdict(bumps.compare(
        lambda s: with_scaled_slot(s, BUMPED, bump.BUMP, 5, 1.1)))
    assert verdict == "inconsistent", detail


def test_back_faces_match_cycles(back_faces):
    """Consistent (measured: mean ratio 1.0016/1.0008/1.0003, mean z 0.85/0.55/0.23, no tile
    failed). Cycles bends a back face's normal about the normals facing the ray, and moves the
    Wave's Generated coordinates against the point (its barycentric differentials flip on a
    back face): moved with the point, the walls were 8% darker than Cycles' (5 tiles failed,
    mean z -32 to -47)."""
    assert back_faces.warnings == []
    verdict, detail = _verdict(back_faces.compare())
    assert verdict == "consistent", detail


def test_back_face_distance_off_by_ten_percent_is_caught(back_faces):
    """Both Bumps' Distance 10% larger (measured: 3 tiles failed, mean ratio 0.978, mean z
    -11.6 to -16.9)."""
    from snell.tracer.shader import bump
    verdict, detail = _verdict(back_faces.compare(
        lambda s: with_scaled_slot(s, BACK, bump.BUMP, 5, 1.1)))
    assert verdict == "inconsistent", detail


def test_displacement_compiles_to_bump_before_the_closures(displacement):
    """Bump displacement: three heights, a Bump and SET_NORMAL, before any closure; no
    warning."""
    from snell.tracer.shader import bump, closures
    assert displacement.warnings == []
    programs = _programs(displacement)
    assert set(programs) == set(DISPLACED)
    for mat in programs.values():
        ops = [row[0] for row in mat["program"]["code"]]
        assert ops.count(bump.DISPLACEMENT) == 3 and ops.count(bump.SET_NORMAL) == 1
        first_closure = min(k for k, op in enumerate(ops) if op <= closures.LAST)
        assert ops.index(bump.SET_NORMAL) < first_closure


def test_displacement_matches_cycles(displacement):
    """Consistent (measured: mean ratio 1.0008/1.0008/1.0007, mean z 0.86/0.84/0.78, z pass
    fraction 1.0, no tile failed)."""
    verdict, detail = _verdict(displacement.compare())
    assert verdict == "consistent", detail


def test_displacement_scale_off_by_ten_percent_is_caught(displacement):
    """Every Displacement node's Scale 10% larger (measured: 12 tiles failed, mean ratio
    0.976, mean z -26 to -29)."""
    from snell.tracer.shader import bump
    verdict, detail = _verdict(displacement.compare(
        lambda s: with_scaled_slot(s, DISPLACED, bump.DISPLACEMENT, 4, 1.1)))
    assert verdict == "inconsistent", detail


def test_images_compile_without_warnings(images):
    from snell.tracer.shader import bump
    assert images.warnings == []
    programs = _programs(images)
    assert set(programs) == set(IMAGED)
    for name in ("TangentDiffuse", "TangentGlossy"):
        ops = [row[0] for row in programs[name]["program"]["code"]]
        assert ops.count(bump.TANGENT_DIRECTION) == 3 and ops.count(bump.SET_NORMAL) == 1


def test_images_match_cycles(images):
    """Consistent (measured: mean ratio 1.0008/1.0008/1.0008, mean z 0.52/0.40/0.31, no tile
    failed)."""
    verdict, detail = _verdict(images.compare())
    assert verdict == "consistent", detail


@pytest.mark.parametrize("names, opcode, slot", [
    (("ImageDiffuse",), "BUMP", 5),
    (("TangentDiffuse", "TangentGlossy"), "VECTOR_DISPLACEMENT", 4)])
def test_image_distance_or_vector_scale_off_by_ten_percent_is_caught(images, names, opcode,
                                                                    slot):
    """The image Bump's Distance, or the Vector Displacements' Scale, 10% larger (measured:
    9 tiles failed and the pixel test, mean ratio 0.995-0.997; 13 tiles failed, mean ratio
    0.970-0.983, mean z -10. The Scale on a Diffuse sphere alone, slope 0.5, was not caught:
    mean z -1.1 to -1.9, no tile failed)."""
    from snell.tracer.shader import bump
    verdict, detail = _verdict(images.compare(
        lambda s: with_scaled_slot(s, names, getattr(bump, opcode), slot, 1.1)))
    assert verdict == "inconsistent", detail


def test_wide_filter_matches_cycles(wide):
    """Consistent (measured: mean ratio 1.0004, mean z 0.76, no tile failed): Snell's camera
    differentials are Cycles' (dD of each camera ray's direction, times its length)."""
    assert wide.warnings == []
    verdict, detail = _verdict(wide.compare())
    assert verdict == "consistent", detail


@pytest.mark.parametrize("factor", [1.1, 0.9, 1.2])
def test_differentials_off_are_caught(wide, factor):
    """The differentials' width times factor (the filter width, which scales the step of
    OFFSET and the BUMP's determinant, as a wider cone would). Measured: 10% wider, 2 tiles
    failed; 10% narrower, 6; 20% wider, 10 (the image means agree: the bands shift and
    flatten where the normals bend)."""
    from snell.tracer.shader import bump

    def wider(scene):
        scene = with_scaled_slot(scene, ("WideDiffuse",), bump.OFFSET, 2, factor)
        return with_scaled_slot(scene, ("WideDiffuse",), bump.BUMP, 7, factor)
    verdict, detail = _verdict(wide.compare(wider))
    assert verdict == "inconsistent", detail
