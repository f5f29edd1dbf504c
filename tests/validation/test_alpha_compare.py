"""The film's alpha against Cycles (#30): Film > Transparent and the Holdout closure.

A product shot on a transparent film, as users set one up for compositing: a glossy sphere and a
diffuse block on a floor under a sun and a grey world, a veil (Principled BSDF, Alpha 0.5)
in front of the sky, a card that is half Holdout (Mix of Holdout and Diffuse, factor 0.5) and
a pane held out as an object (Object > Visibility > Mask > Holdout). The world lights the scene but no camera ray that reaches it
sees it; the alpha is 1 less the share of each pixel's samples that reached the world or a
holdout, through transparent surfaces only (Cycles' PATH_RAY_TRANSPARENT_BACKGROUND).

Both the image and the alpha channel are held against Cycles' RGBA EXR (compare.alpha_comparison).
The deliberate errors each test names are caught; what they measured is in their docstrings.
"""
from __future__ import annotations

import importlib

import numpy as np
import pytest

from support.cycles_reference import Reference, assert_image_and_alpha_consistent
from support.programs import material_copy, with_constant

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")
graphs = importlib.import_module("node_materials")

FULL = {"resolution_percentage": 100}
HALF = 0.5        # the card's Holdout share


def holdout_card(factor):
    """Mix(Holdout, Diffuse) by `factor` (the Diffuse's share)."""
    mat, tree, out = graphs.node_tree("Card")
    mix = graphs.node(tree, "ShaderNodeMixShader", Fac=factor)
    diffuse = graphs.node(tree, "ShaderNodeBsdfDiffuse", Color=(0.7, 0.3, 0.2, 1.0))
    tree.links.new(graphs.node(tree, "ShaderNodeHoldout").outputs[0], mix.inputs[1])
    tree.links.new(diffuse.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    return mat


def build(path):
    scene = common.reset()
    common.setup_render(scene, (48, 36), max_bounces=3)
    scene.render.film_transparent = True
    common.set_world(scene, (0.4, 0.5, 0.6), 1.0)
    floor = common.material("Floor", "diffuse", (0.6, 0.6, 0.55))
    common.quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], floor)
    common.uv_sphere("Ball", (-0.5, 0.5, 0.5), 0.5,
                     common.material("Ball", "glossy", (0.9, 0.8, 0.6), Roughness=0.2),
                     segments=24, rings=12)
    block = common.material("Block", "diffuse", (0.2, 0.5, 0.8))
    common.mesh_object("Block", [(0.3, 0.0, 0), (1.0, 0.0, 0), (1.0, 0.7, 0), (0.3, 0.7, 0),
                                 (0.3, 0.0, 0.8), (1.0, 0.0, 0.8), (1.0, 0.7, 0.8),
                                 (0.3, 0.7, 0.8)],
                       [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6),
                        (3, 0, 4, 7)], block)
    veil = common.material("Veil", "principled", (0.9, 0.9, 0.2), Alpha=0.5, Roughness=0.5)
    common.quad("Veil", [(-1.6, -0.5, 1.1), (-0.4, -0.5, 1.1), (-0.4, -0.5, 1.9),
                         (-1.6, -0.5, 1.9)], veil)
    common.quad("Card", [(0.0, -0.8, 0.1), (0.9, -0.8, 0.1), (0.9, -0.8, 0.7), (0.0, -0.8, 0.7)],
                holdout_card(HALF))
    pane = common.quad("Pane", [(0.6, -0.3, 1.0), (1.4, -0.3, 1.0), (1.4, -0.3, 1.6),
                                (0.6, -0.3, 1.6)], common.material("Pane", "diffuse"))
    pane.is_holdout = True
    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy, sun.angle = 3.0, 0.1
    lamp = bpy.data.objects.new("Sun", sun)
    lamp.rotation_euler = (0.6, 0.2, 0.8)
    bpy.context.scene.collection.objects.link(lamp)
    common.camera(scene, (0.0, -4.5, 1.6), (0.0, 0.0, 0.7), lens=35.0)
    return common.save(path)


@pytest.fixture(scope="module")
def blend(tmp_path_factory):
    return build(str(tmp_path_factory.mktemp("alpha") / "alpha.blend"))


@pytest.fixture(scope="module")
def reference(blend):
    return Reference(blend, framing=FULL)


def test_the_file_renders_a_transparent_film(reference):
    assert reference.scene.render["film_transparent"] is True
    assert any(m["name"] == "(object holdout)" for m in reference.scene.materials)
    assert reference.cycles.alpha_images, "Cycles' alpha was not read back"
    alpha = np.mean(reference.cycles.alpha_images, axis=0)
    # The sky's pixels are clear, the floor's opaque, the veil's half.
    assert alpha.min() < 0.01 and alpha.max() > 0.99


def test_image_and_alpha_are_consistent(reference):
    alpha = assert_image_and_alpha_consistent(reference.compare())
    assert abs(alpha["mean_snell"] / alpha["mean_cycles"] - 1.0) < 0.01, alpha


def test_holdout_share_off_is_caught(reference):
    """The card's Holdout share 0.45 instead of 0.5 (Mix factor 0.55): measured
    inconsistent in the alpha."""
    report = reference.compare(modify=lambda s: with_constant(s, "Card", HALF, HALF + 0.05))
    assert report["alpha_channel"]["verdict"] == "inconsistent", report["alpha_channel"]
    assert report["verdict"] == "inconsistent"


def test_opaque_film_is_caught(reference):
    """Snell's film opaque where Cycles' is transparent: the world seen in the image and alpha
    1 over the sky: measured inconsistent in both."""
    report = reference.compare(modify=lambda s: s.with_render(film_transparent=False))
    assert report["verdict"] == "inconsistent"
    assert report["alpha_channel"]["verdict"] == "inconsistent", report["alpha_channel"]


def test_object_holdout_dropped_is_caught(reference):
    """The pane rendered with its own Diffuse material instead of held out: measured
    inconsistent in the alpha."""
    def drop(scene):
        scene, mat = material_copy(scene, "(object holdout)")
        mat.clear()
        mat.update({"name": "Pane", "kind": "diffuse", "color": [0.8, 0.8, 0.8]})
        return scene
    report = reference.compare(modify=drop)
    assert report["alpha_channel"]["verdict"] == "inconsistent", report["alpha_channel"]
