"""Normal maps in shader programs (#29, "Shading normals") against Cycles: a brick wall whose
normal map (a PNG written here: bricks with bevelled edges and a gentle bulge) feeds a Diffuse
and a Glossy BSDF, lit by a lamp at a grazing angle, on walls that are rotated and scaled
unequally (the normal matrix matters), and a wall of the same map in object space.

Each must be `snell compare` consistent, and a Normal Map's strength off by 10% must be caught.
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


def build_walls(path, bricks):
    scene = common.reset()
    common.setup_render(scene, (64, 48))
    common.set_world(scene, (0.02, 0.02, 0.025))
    diffuse = normal_mapped("BrickDiffuse", bricks, "diffuse")
    glossy = normal_mapped("BrickGlossy", bricks, "glossy", Roughness=0.35)
    # Upright walls facing -y, one stretched 1.6 x along its width, one 0.6 x along its height.
    wall("DiffuseWall", (-1.05, 0.0, 1.0), (math.pi / 2, 0.0, 0.25), (0.5, 1.0, 1.6), diffuse)
    wall("GlossyWall", (1.05, 0.2, 1.0), (math.pi / 2, 0.0, -0.25), (0.8, 0.6, 1.0), glossy)
    # The lamp grazes the walls from the side and above.
    light = bpy.data.lights.new("Lamp", "AREA")
    light.energy = 400.0
    light.size = 0.5
    lamp = bpy.data.objects.new("Lamp", light)
    lamp.location = (0.0, -0.9, 2.6)
    lamp.rotation_euler = (0.35, 0.0, 0.0)
    scene.collection.objects.link(lamp)
    common.camera(scene, (0.0, -4.0, 1.0), (0.0, 0.0, 1.0), lens=35.0)
    return common.save(path)


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
    for row in program["code"]:
        if row[0] in normals.SPECS:
            program["constants"][row[3]] *= factor
    return scene


def test_walls_compile_to_programs(walls):
    """Both walls become programs with a tangent-space Normal Map, with no warning."""
    from snell.tracer.shader import normals
    assert walls.warnings == []
    programs = _programs(walls)
    assert set(programs) == {"BrickDiffuse", "BrickGlossy"}
    for mat in programs.values():
        assert any(row[0] == normals.NORMAL_MAP_TANGENT for row in mat["program"]["code"])


def test_walls_match_cycles(walls):
    """Consistent."""
    verdict, detail = _verdict(walls.compare())
    assert verdict == "consistent", detail


def test_strength_off_by_ten_percent_is_caught(walls):
    """Both Normal Maps' strength 0.9 instead of 1."""
    verdict, detail = _verdict(walls.compare(
        lambda scene: with_strength(with_strength(scene, "BrickDiffuse", 0.9), "BrickGlossy",
                                    0.9)))
    assert verdict == "inconsistent", detail
