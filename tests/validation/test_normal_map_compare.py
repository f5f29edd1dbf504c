"""Normal maps in shader programs (#29, "Shading normals") against Cycles: brick walls whose
normal map (a PNG written here: bricks with bevelled edges and a gentle bulge) feeds a Diffuse
and a Glossy BSDF in tangent space and a Diffuse BSDF in object space, on walls rotated and
scaled unequally (the normal matrix matters), and a Principled BSDF on a smooth UV sphere (the
tangent frame varies over each triangle), lit by a lamp at a grazing angle.

A second scene shows two such walls from behind (Cycles inverts the mapped normal on a back
face), a third Suzanne, smooth and coarse, with its own UV map (the frame varies strongly over
each triangle, and MikkTSpace over its non-planar quads differs from Cycles' over triangles). Each scene must be `snell compare` consistent, and the Normal Maps' strength off by 10%
must be caught.
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
STRENGTH = 1.0
MATERIALS = ("BrickDiffuse", "BrickGlossy", "BrickObject", "BrickPrincipled")


def bricks_png(path, width=64, height=32, rows=4, cols=4):
    """A tangent-space normal map of bricks: each brick's top bulges gently, its edges bevel
    down into the mortar (8-bit, (n + 1) / 2 per component)."""
    y, x = np.mgrid[0:height, 0:width].astype(np.float64) + 0.5
    bh, bw = height / rows, width / cols
    row = np.floor(y / bh)
    u = (x / bw + 0.5 * (row % 2)) % 1.0          # position inside the brick, 0..1
    v = (y / bh) % 1.0
    # Height: a bevel over 15% of the brick's size at each edge, and a bulge on top.
    edge = np.minimum(np.minimum(u, 1 - u) * bw, np.minimum(v, 1 - v) * bh) / (0.15 * bh)
    h = np.clip(edge, 0.0, 1.0) + 0.3 * np.sin(math.pi * u) * np.sin(math.pi * v)
    dx = np.gradient(h, axis=1) * 0.6
    dy = np.gradient(h, axis=0) * 0.6
    # Image rows go down in the PNG, v up in Blender: the y slope is reversed.
    n = np.stack([-dx, dy, np.ones_like(h)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return textured.write_png(path, np.round((n + 1.0) * 0.5 * 255.0).astype(np.uint8))


def normal_mapped(name, image_path, shader, space="TANGENT", **values):
    """A material: shader (Diffuse or Glossy) with its Normal from a Normal Map of the image."""
    mat = common.material(name, shader, (0.7, 0.45, 0.35), **values)
    tree = mat.node_tree
    bsdf = next(n for n in tree.nodes if n.bl_idname.startswith("ShaderNodeBsdf"))
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(str(image_path))
    tex.image.colorspace_settings.name = "Non-Color"
    tex.interpolation = "Linear"
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    normal_map.space = space
    normal_map.inputs["Strength"].default_value = STRENGTH
    tree.links.new(tex.outputs["Color"], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs["Normal"], bsdf.inputs["Normal"])
    return mat


def wall(name, location, rotation, scale, mat):
    """A plane (2 x 2 before scale) with mat, rotated (Euler XYZ) and scaled."""
    obj = textured.plane(name, location, 2.0, mat)
    obj.rotation_euler = rotation
    obj.scale = scale
    return obj


def ball(name, location, radius, mat):
    """A smooth UV sphere (32 x 16) with a UV map of longitude and latitude (its corners on the
    seam and at the poles moved to their face's side)."""
    obj = common.uv_sphere(name, location, radius, mat, 32, 16)
    mesh = obj.data
    layer = mesh.uv_layers.new(name="UVMap")
    for poly in mesh.polygons:
        co = [mesh.vertices[mesh.loops[k].vertex_index].co for k in poly.loop_indices]
        uvs = [[0.5 - math.atan2(p.x, p.y) / (2 * math.pi),
                1.0 - math.acos(max(-1.0, min(1.0, p.z / p.length))) / math.pi] for p in co]
        if max(u for u, _ in uvs) - min(u for u, _ in uvs) > 0.5:
            for uv in uvs:
                uv[0] += 1.0 if uv[0] < 0.5 else 0.0
        poles = [k for k, p in enumerate(co) if abs(p.x) < 1e-6 and abs(p.y) < 1e-6]
        others = [uv[0] for k, uv in enumerate(uvs) if k not in poles]
        for k in poles:
            uvs[k][0] = sum(others) / len(others)
        for k, uv in zip(poly.loop_indices, uvs):
            layer.data[k].uv = uv
    return obj


def build_walls(path, bricks):
    scene = common.reset()
    common.setup_render(scene, (96, 48))
    common.set_world(scene, (0.02, 0.02, 0.025))
    # Upright walls facing -y (the plane's +z turned to -y), each scaled unequally.
    wall("DiffuseWall", (-1.9, 0.0, 1.0), (math.pi / 2, 0.0, 0.25), (0.5, 1.0, 1.6),
         normal_mapped("BrickDiffuse", bricks, "diffuse"))
    wall("GlossyWall", (-0.6, 0.2, 1.0), (math.pi / 2, 0.0, -0.25), (0.55, 0.6, 1.0),
         normal_mapped("BrickGlossy", bricks, "glossy", Roughness=0.35))
    # The plane's UVs run along its x and y: the same image is its object-space normal map.
    wall("ObjectWall", (0.7, 0.0, 1.0), (math.pi / 2, 0.0, 0.2), (0.5, 0.9, 1.0),
         normal_mapped("BrickObject", bricks, "diffuse", space="OBJECT"))
    # A smooth sphere, where the tangent frame varies over each triangle.
    ball("BrickBall", (2.0, 0.0, 1.0), 0.55,
         normal_mapped("BrickPrincipled", bricks, "principled", Roughness=0.45))
    # The lamp grazes the walls from in front and above.
    light = bpy.data.lights.new("Lamp", "AREA")
    light.energy = 600.0
    light.size = 0.5
    lamp = bpy.data.objects.new("Lamp", light)
    lamp.location = (0.0, -1.2, 2.8)
    lamp.rotation_euler = (0.4, 0.0, 0.0)
    scene.collection.objects.link(lamp)
    common.camera(scene, (0.0, -5.2, 1.0), (0.0, 0.0, 1.0), lens=35.0)
    return common.save(path)


def build_back_faces(path, bricks):
    scene = common.reset()
    common.setup_render(scene, (48, 48))
    common.set_world(scene, (0.02, 0.02, 0.025))
    # Walls facing +y: the camera at -y sees their back faces.
    wall("BackDiffuse", (-0.55, 0.0, 1.0), (-math.pi / 2, 0.0, 0.2), (0.5, 1.0, 1.0),
         normal_mapped("BackBrickDiffuse", bricks, "diffuse"))
    wall("BackGlossy", (0.55, 0.0, 1.0), (-math.pi / 2, 0.0, -0.2), (0.5, 1.0, 1.0),
         normal_mapped("BackBrickGlossy", bricks, "glossy", Roughness=0.35))
    light = bpy.data.lights.new("Lamp", "AREA")
    light.energy = 400.0
    light.size = 0.5
    lamp = bpy.data.objects.new("Lamp", light)
    lamp.location = (0.0, -1.2, 2.8)
    lamp.rotation_euler = (0.4, 0.0, 0.0)
    scene.collection.objects.link(lamp)
    common.camera(scene, (0.0, -4.0, 1.0), (0.0, 0.0, 1.0), lens=35.0)
    return common.save(path)


def build_suzanne(path, bricks):
    scene = common.reset()
    common.setup_render(scene, (48, 48))
    common.set_world(scene, (0.02, 0.02, 0.025))
    bpy.ops.mesh.primitive_monkey_add(size=1.4, location=(0.0, 0.0, 1.0),
                                      rotation=(0.0, 0.0, math.pi))
    monkey = bpy.context.active_object
    monkey.data.shade_smooth()
    monkey.data.materials.append(normal_mapped("BrickMonkey", bricks, "diffuse"))
    light = bpy.data.lights.new("Lamp", "AREA")
    light.energy = 600.0
    light.size = 0.5
    lamp = bpy.data.objects.new("Lamp", light)
    lamp.location = (-2.0, -1.2, 2.8)
    lamp.rotation_euler = (0.4, -0.5, 0.0)
    scene.collection.objects.link(lamp)
    common.camera(scene, (0.0, -3.0, 1.0), (0.0, 0.0, 1.0), lens=50.0)
    return common.save(path)


@pytest.fixture(scope="module")
def suzanne(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("normal_maps")
    return Reference(build_suzanne(str(tmp / "suzanne.blend"), bricks_png(tmp / "bricks.png")),
                     framing=FULL)


@pytest.fixture(scope="module")
def back_faces(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("normal_maps")
    return Reference(build_back_faces(str(tmp / "back.blend"), bricks_png(tmp / "bricks.png")),
                     framing=FULL)


@pytest.fixture(scope="module")
def walls(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("normal_maps")
    return Reference(build_walls(str(tmp / "walls.blend"), bricks_png(tmp / "bricks.png")),
                     framing=FULL)


def _programs(ref):
    return {m["name"]: m for m in ref.scene.materials if m["kind"] == "program"}


def with_strength(scene, name, factor):
    """The scene with material `name`'s Normal Map strength (its constant) times factor."""
    from snell.tracer.shader import normals
    scene, mat = material_copy(scene, name)
    program = mat["program"]
    for reg in {row[3] for row in program["code"] if row[0] in normals.SPECS}:
        program["constants"][reg] *= factor
    return scene


def test_walls_compile_to_programs(walls):
    """Every material becomes a program with its Normal Map, with no warning."""
    from snell.tracer.shader import normals
    assert walls.warnings == []
    programs = _programs(walls)
    assert set(programs) == set(MATERIALS)
    for name, mat in programs.items():
        opcode = (normals.NORMAL_MAP_OBJECT if name == "BrickObject"
                  else normals.NORMAL_MAP_TANGENT)
        assert any(row[0] == opcode for row in mat["program"]["code"])


def test_walls_match_cycles(walls):
    """Consistent (measured: mean ratio 0.9994/0.9996/0.9996, z -0.5/-0.4/-0.4, no tile failed;
    by quarter of the image, diffuse wall, glossy wall, object-space wall, sphere: 1.0004,
    0.990, 1.000, 1.000; the glossy wall's 1% is noise: at 1024 spp, 0.5526 against Cycles'
    0.5512 +- 0.0018). Without Cycles' bump shadowing of bent diffuse normals
    (lobes.bump_shadowing) the diffuse wall was brighter than Cycles' by 1-3% towards its
    bottom, where the lamp grazes it: 2 tiles failed (z 6.1, 4.8)."""
    verdict, detail = _verdict(walls.compare())
    assert verdict == "consistent", detail


def test_strength_off_by_ten_percent_is_caught(walls):
    """Every Normal Map's strength 0.9 instead of 1 (measured: 11 tiles failed; the glossy
    wall's quarter of the image 8% darker)."""
    def weaker(scene):
        for name in MATERIALS:
            scene = with_strength(scene, name, 0.9)
        return scene
    verdict, detail = _verdict(walls.compare(weaker))
    assert verdict == "inconsistent", detail


def test_back_faces_match_cycles(back_faces):
    """Consistent (measured: mean ratio 0.998/0.998/0.998, z -0.4, no tile failed; diffuse half
    1.0003, glossy half 0.994)."""
    assert back_faces.warnings == []
    verdict, detail = _verdict(back_faces.compare())
    assert verdict == "consistent", detail


def test_back_face_strength_off_by_ten_percent_is_caught(back_faces):
    """Both Normal Maps' strength 0.9 instead of 1 (measured: 6 tiles failed)."""
    def weaker(scene):
        for name in ("BackBrickDiffuse", "BackBrickGlossy"):
            scene = with_strength(scene, name, 0.9)
        return scene
    verdict, detail = _verdict(back_faces.compare(weaker))
    assert verdict == "inconsistent", detail


def test_suzanne_matches_cycles(suzanne):
    """Consistent (measured: mean ratio 0.998, z -1.8, no tile failed; with strength 0, 0.998
    and z -1.3: Suzanne's own). Tangents from MikkTSpace over Suzanne's quads (Blender's
    calc_tangents on the mesh as it is) failed a tile; so did the corners' crosses n x t
    interpolated instead of Cycles' cross of the interpolated n and t (z -5.3)."""
    assert suzanne.warnings == []
    verdict, detail = _verdict(suzanne.compare())
    assert verdict == "consistent", detail
