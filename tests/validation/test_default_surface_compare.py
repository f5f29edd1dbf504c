"""Objects without a material (#29) against Cycles: Cycles 5.0 renders them with its default
surface, a Principled BSDF of base colour 0.8 (its images of "no material" and of a new default
material are equal to 8 digits), and a material whose output has nothing on Surface black.

A sphere with no material and one with an unlinked Surface, in the Cornell box under its ceiling
lamp, built here with bpy; Snell must be `snell compare` consistent, and the old fallback (grey
0.8 diffuse for the missing material) must be caught.
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


def build(path):
    """The Cornell box; a large sphere without material and a small one whose Surface is
    unlinked, seen close up."""
    scene = common.reset()
    common.setup_render(scene, (48, 48))
    common.cornell_box()
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.6,
                                         location=(-0.25, 0.1, 0.6))
    bare = bpy.context.active_object
    bare.name = "Bare"
    bare.data.shade_smooth()
    empty = common.material("Empty", "principled", (0.2, 0.9, 0.2))
    empty.node_tree.links.remove(empty.node_tree.links[0])
    common.uv_sphere("Dark", (0.3, -0.5, 0.15), 0.15, empty)
    # Close up: the sphere fills most of the frame, so that its Fresnel reflections and highlight
    # (what a diffuse surface lacks) cover many tiles.
    common.camera(scene, (-0.25, -2.2, 0.9), (-0.25, 0.1, 0.6), lens=50.0)
    return common.save(path)


@pytest.fixture(scope="module")
def spheres(tmp_path_factory):
    blend = build(str(tmp_path_factory.mktemp("default_surface") / "default_surface.blend"))
    return Reference(blend, framing=FULL)


def test_exported_as_cycles_default_surface_and_black(spheres):
    mats = {m["name"]: m for m in spheres.scene.materials}
    assert mats["(default surface)"]["kind"] == "principled"
    assert mats["Empty"] == {"name": "Empty", "kind": "diffuse", "color": [0.0, 0.0, 0.0]}
    from snell.addon import export
    assert spheres.warnings and not any(export.differs_from_cycles(w) for w in spheres.warnings)


def test_no_material_matches_cycles(spheres):
    """Consistent (measured: mean ratio 1.004/1.004/1.003, z 1.7/1.7/1.3, no tile failed)."""
    verdict, detail = _verdict(spheres.compare())
    assert verdict == "consistent", detail


def test_grey_diffuse_for_no_material_is_caught(spheres):
    """The fallback Snell used before: base colour 0.8 diffuse, no specular layer (measured:
    every test failed, mean ratio 0.98, mean z -8 to -11, 5 tiles, sharpness z -7.7)."""
    def as_diffuse(scene):
        scene = copy.copy(scene)
        scene.materials = [{"name": m["name"], "kind": "diffuse", "color": [0.8, 0.8, 0.8]}
                           if m["name"] == "(default surface)" else m for m in scene.materials]
        return scene
    verdict, detail = _verdict(spheres.compare(as_diffuse))
    assert verdict == "inconsistent", detail
