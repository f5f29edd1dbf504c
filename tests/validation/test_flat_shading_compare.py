"""Flat-shaded meshes against Cycles (#31, item 10): Cycles shades a flat face with each
triangle's own geometric normal, which on a non-planar quad is not the face's normal. Snell used
the face's normal, and flat-shaded Suzannes (whose quads are not planar) under sun lamps rendered
darker than Cycles (0.14% in a whole image with a floor, 0.5% on the heads alone; image z down to
-8, tiles at the brows and the tops of the heads).

Three flat-shaded Suzannes under two coloured suns of angle 11.4 degrees, built here with bpy;
Snell must be `snell compare` consistent, and the face's normal must be caught.
"""
from __future__ import annotations

import copy
import importlib
import math

import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}
SPP = 512


def build(path):
    """Three flat-shaded Suzannes, turned, under a warm and a cool sun, filling the frame."""
    scene = common.reset()
    common.setup_render(scene, (64, 40), max_bounces=4)
    mat = common.material("Clay", "diffuse", (0.8, 0.5, 0.3))
    for i, x in enumerate((-2.2, 0.0, 2.2)):
        bpy.ops.mesh.primitive_monkey_add(size=1.6, location=(x, 0.0, 0.9))
        monkey = bpy.context.active_object
        common.canonical_polygons(monkey)
        monkey.rotation_euler = (math.radians(-10), 0.0, math.radians(20 * (i - 1)))
        monkey.data.shade_flat()
        monkey.data.materials.append(mat)
    for name, rotation, color, strength in (("Warm", (0.6, 0.2, 0.8), (1.0, 0.9, 0.7), 3.0),
                                            ("Cool", (-0.5, -0.6, -1.2), (0.6, 0.7, 1.0), 1.5)):
        sun = bpy.data.lights.new(name, "SUN")
        sun.energy, sun.color, sun.angle = strength, color, math.radians(11.4)
        obj = bpy.data.objects.new(name, sun)
        obj.rotation_euler = rotation
        scene.collection.objects.link(obj)
    common.set_world(scene, (0.05, 0.05, 0.05))
    common.camera(scene, (0.0, -6.0, 2.2), (0.0, 0.0, 0.9), lens=40.0)
    return common.save(path)


@pytest.fixture(scope="module")
def suzannes(tmp_path_factory):
    blend = build(str(tmp_path_factory.mktemp("flat") / "flat_suzannes.blend"))
    return Reference(blend, framing=FULL, spp=SPP)


def test_flat_shaded_suzannes_match_cycles(suzannes):
    """Consistent (measured: mean ratio 1.0001/0.9995/0.9995, mean z 0.1/-0.6/-1.1)."""
    verdict, detail = _verdict(suzannes.compare())
    assert verdict == "consistent", detail


def test_the_faces_normal_on_a_flat_quad_is_caught(suzannes, monkeypatch):
    """Every flat triangle shaded with its face's normal, as Snell did before (measured: mean
    ratio 0.993/0.995/0.996, mean z -6.9/-7.4/-9.0, 4 tiles and 0.8% of pixels failed)."""
    from snell.addon.export import meshes
    from snell.validation import compare
    monkeypatch.setattr(meshes, "PLANAR", 2.0)
    before, _ = compare.load_snell_scene(suzannes.blend)
    assert len(before.triangles) == len(suzannes.scene.triangles)

    def face_normals(scene):
        scene = copy.copy(scene)
        scene.positions, scene.normals = before.positions, before.normals
        scene.triangles = before.triangles
        return scene
    verdict, detail = _verdict(suzannes.compare(face_normals))
    assert verdict == "inconsistent", detail
