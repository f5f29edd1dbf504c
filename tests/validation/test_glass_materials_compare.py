"""Glass as Blender users build it (issue 34), against Cycles: tinted smooth Principled glass,
and glass built from nodes as a Mix Shader of a Refraction and a Glossy BSDF weighted by a
Fresnel node.

The Principled BSDF with full transmission, roughness 0 and nothing on top is how most Blender
users make glass, usually with a base colour: the node's default 0.8 grey, or a tint. Cycles
renders it as smooth glass whose transmission is tinted by the square root of the base colour
(the light passes the surface twice) and whose reflection is not. Older files build glass from
nodes: Cycles' smooth Refraction and Glossy BSDFs weighted by 1 - F and F of the Fresnel node
of the refraction's IOR are exactly its Glass BSDF, reflection tinted by the Glossy colour and
transmission by the Refraction's. The exporter writes both as that glass (addon/export/bsdfs.py,
mixes.py), so that the light tracer carries their caustic instead of leaving it to the path
tracer's fireflies, which a Principled surface or a shader program would (light paths end on
one).

Scene: a glass sphere over a white floor under a point lamp of radius 5 cm, seen from above;
the caustic on the floor is rendered by light paths through the sphere.
"""
from __future__ import annotations

import importlib

import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict
from support.programs import material_copy
from support.shader_trees import mix_nodes

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")
graphs = importlib.import_module("node_materials")

SPP = 256
BASE = (0.3, 0.8, 0.5)
# The node glass's Refraction and Glossy colours.
TRANSMISSION, REFLECTION = (0.5, 0.8, 0.9), (1.0, 0.75, 0.4)


def principled_glass(level=0.5):
    """Tinted Principled glass (level: its Specular IOR Level)."""
    return common.material("TintedGlass", "principled", BASE, **{
        "Transmission Weight": 1.0, "Roughness": 0.0, "IOR": 1.5, "Specular IOR Level": level})


def node_glass():
    """Mix(Fresnel 1.45, Refraction 1.45, Glossy), tinted differently in each, as tutorials
    build it: one Value node gives both IORs, an RGB node the Glossy colour (constants that
    Cycles folds, and so does the exporter)."""
    mat = graphs.fresnel_glass(0.0, name="NodeGlass", transmission=TRANSMISSION)
    tree = mat.node_tree
    _, fresnel, refraction, glossy = mix_nodes(mat)
    ior = tree.nodes.new("ShaderNodeValue")
    ior.outputs[0].default_value = 1.45
    for node in (fresnel, refraction):
        tree.links.new(ior.outputs[0], node.inputs["IOR"])
    rgb = tree.nodes.new("ShaderNodeRGB")
    rgb.outputs[0].default_value = (*REFLECTION, 1.0)
    tree.links.new(rgb.outputs[0], glossy.inputs["Color"])
    return mat


def build(path, glass=principled_glass):
    """The glass sphere (material glass()) over the floor, lit by a point lamp of radius 5
    cm."""
    scene = common.reset()
    common.setup_render(scene, (48, 48), max_bounces=5)
    white = common.material("White", "diffuse", (0.8, 0.8, 0.8))
    h = 1.5
    common.quad("Floor", [(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], white)
    common.uv_sphere("GlassSphere", (0.0, 0.0, 0.6), 0.3, glass())
    common.camera(scene, (0.0, -1.0, 1.6), (0.05, 0.1, 0.1), lens=35.0)
    data = bpy.data.lights.new("Point", "POINT")
    data.energy = 60.0
    data.shadow_soft_size = 0.05
    lamp = bpy.data.objects.new("Point", data)
    lamp.location = (0.1, 0.05, 1.6)
    scene.collection.objects.link(lamp)
    return common.save(path)


@pytest.fixture(scope="module")
def tinted(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("principled_glass")
    return Reference(build(str(tmp / "tinted_glass.blend")), framing={"resolution_percentage": 100},
                     spp=SPP)


@pytest.fixture(scope="module")
def node_built(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("node_glass")
    return Reference(build(str(tmp / "node_glass.blend"), node_glass),
                     framing={"resolution_percentage": 100}, spp=SPP)


def _transmission_scaled(factor, name="TintedGlass"):
    """The Snell scene with glass `name`'s transmission colour times factor."""
    def modify(scene):
        scene, glass = material_copy(scene, name)
        glass["transmission_color"] = [c * factor for c in glass["transmission_color"]]
        return scene
    return modify


def test_tinted_principled_glass_casts_a_caustic_consistent_with_cycles(tinted):
    """Exported as glass tinted in transmission by sqrt(base colour), its caustic by light
    paths: consistent with Cycles' Principled BSDF."""
    from snell.validation import compare
    assert not tinted.warnings
    glass = next(m for m in tinted.scene.materials if m["name"] == "TintedGlass")
    assert glass["kind"] == "glass", glass
    runs, why = compare.snell_render(tinted.scene, 16).stages["light tracing"]
    assert runs and "Point" in why, why
    verdict, detail = _verdict(tinted.compare())
    assert verdict == "consistent", detail


@pytest.mark.parametrize("factor", [0.95, 1.05])
def test_transmission_tint_off_by_5_percent_is_caught(tinted, factor):
    verdict, detail = _verdict(tinted.compare(_transmission_scaled(factor)))
    assert verdict == "inconsistent", detail


def test_specular_ior_level_leaves_full_transmission_alone(tmp_path, monkeypatch):
    """Cycles applies Specular IOR Level to the dielectric specular layer only, which full
    transmission leaves no weight: at level 0.2 (an index of about 1.29 had it entered) the
    same glass, IOR 1.5, is consistent with Cycles. Its Cycles render is made here: the stored
    references are keyed by the exported scene, which is the level 0.5 file's."""
    monkeypatch.setenv("SNELL_CYCLES_REFERENCES", "off")
    reference = Reference(build(str(tmp_path / "tinted_level.blend"),
                                lambda: principled_glass(level=0.2)),
                          framing={"resolution_percentage": 100}, spp=SPP)
    glass = next(m for m in reference.scene.materials if m["name"] == "TintedGlass")
    assert glass["kind"] == "glass" and glass["ior"] == 1.5, glass
    verdict, detail = _verdict(reference.compare())
    assert verdict == "consistent", detail


def test_node_glass_casts_a_caustic_consistent_with_cycles(node_built):
    """Mix(Fresnel, Refraction, Glossy) exported as glass (reflection the Glossy colour,
    transmission the Refraction's), its caustic by light paths: consistent with Cycles' node
    tree."""
    assert not node_built.warnings
    glass = next(m for m in node_built.scene.materials if m["name"] == "NodeGlass")
    assert glass["kind"] == "glass" and glass["ior"] == pytest.approx(1.45), glass
    assert glass["color"] == pytest.approx(REFLECTION)
    assert glass["transmission_color"] == pytest.approx(TRANSMISSION)
    from snell.validation import compare
    runs, why = compare.snell_render(node_built.scene, 16).stages["light tracing"]
    assert runs and "Point" in why, why
    verdict, detail = _verdict(node_built.compare())
    assert verdict == "consistent", detail


def _colours_swapped(scene):
    """The node glass with its reflection and transmission tints exchanged."""
    scene, glass = material_copy(scene, "NodeGlass")
    glass["color"], glass["transmission_color"] = glass["transmission_color"], glass["color"]
    return scene


@pytest.mark.parametrize("modify", [_transmission_scaled(0.95, "NodeGlass"), _colours_swapped],
                         ids=["transmission x0.95", "tints swapped"])
def test_node_glass_errors_are_caught(node_built, modify):
    verdict, detail = _verdict(node_built.compare(modify))
    assert verdict == "inconsistent", detail
