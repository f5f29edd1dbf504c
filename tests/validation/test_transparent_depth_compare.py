"""Transparent surfaces and the depth limits, against Cycles (#29): passing through a
transparent surface is no bounce (Cycles' path_state_next counts it as a transparent bounce,
with its own limit), and a path whose bounces are spent still passes through transparent
surfaces to the light behind them (PATH_RAY_TERMINATE_AFTER_TRANSPARENT).

Veils: a Cornell box seen through three stacked veils (Principled BSDFs with Alpha 0.5), with
two more between the floor and the ceiling light. At max depth 3 a path that counted its
crossings as bounces would end before the back wall; at max depth 1 (Cycles' max bounces 0)
the light that a BSDF-sampled ray finds through a veil is still counted (its MIS partner, the
shadow ray, passes the veil). Both are consistent; one bounce fewer is caught.

Limit: fully transparent panes before an emissive wall: with Transparent max bounces K the
wall is seen through K panes and not through K + 1, in Cycles as in Snell.
"""
from __future__ import annotations

import importlib

import numpy as np
import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")
graphs = importlib.import_module("node_materials")

FULL = {"resolution_percentage": 100}
ALPHA = 0.5
PANES = 3
WALL = 2.0     # the emissive wall's strength behind the panes


def veil(name, color):
    """A Principled BSDF with Alpha ALPHA."""
    return common.material(name, "principled", color, Alpha=ALPHA, Roughness=0.6)


def build_veils(path):
    scene = common.reset()
    common.setup_render(scene, (40, 40))
    common.cornell_box(light_size=0.8)
    for k in range(PANES):
        y = -0.2 + 0.25 * k
        common.quad(f"Veil{k}", [(-0.7, y, 0.2), (0.7, y, 0.2), (0.7, y, 1.6), (-0.7, y, 1.6)],
                    veil(f"Veil{k}", (0.3 + 0.2 * k, 0.7, 0.4)))
    for k in range(2):
        z = 1.2 + 0.3 * k
        common.quad(f"Canopy{k}", [(-0.8, -0.8, z), (0.8, -0.8, z), (0.8, 0.8, z),
                                   (-0.8, 0.8, z)], veil(f"Canopy{k}", (0.8, 0.5, 0.3)))
    common.cornell_camera(scene)
    return common.save(path)


def clear_pane():
    """A Transparent BSDF of colour 1."""
    mat, tree, out = graphs.node_tree("Clear")
    tree.links.new(graphs.node(tree, "ShaderNodeBsdfTransparent").outputs[0],
                   out.inputs["Surface"])
    return mat


def build_panes(path):
    scene = common.reset()
    common.setup_render(scene, (8, 8))
    glow = common.material("Glow", "emission", (1.0, 1.0, 1.0), Strength=WALL)
    common.quad("Wall", [(-4, 3, -4), (4, 3, -4), (4, 3, 4), (-4, 3, 4)], glow)
    pane = clear_pane()
    for k in range(PANES):
        y = 0.5 * k
        common.quad(f"Pane{k}", [(-2, y, -2), (2, y, -2), (2, y, 2), (-2, y, 2)], pane)
    common.camera(scene, (0.0, -3.0, 0.0), (0.0, 0.0, 0.0), lens=50.0)
    return common.save(path)


@pytest.fixture(scope="module")
def veils_blend(tmp_path_factory):
    return build_veils(str(tmp_path_factory.mktemp("veils") / "veils.blend"))


@pytest.fixture(scope="module")
def deep(veils_blend):
    return Reference(veils_blend, framing=FULL, max_depth=3)


@pytest.fixture(scope="module")
def spent(veils_blend):
    return Reference(veils_blend, framing=FULL, max_depth=1)


def test_veils_are_transparent_programs(deep):
    programs = [m for m in deep.scene.materials if m["kind"] == "program"]
    assert len(programs) == PANES + 2, [m["name"] for m in deep.scene.materials]


def test_crossings_are_no_bounces(deep):
    v, detail = _verdict(deep.compare())
    assert v == "consistent", detail


def test_spent_paths_pass_transparent_surfaces(spent):
    v, detail = _verdict(spent.compare())
    assert v == "consistent", detail


def test_one_bounce_fewer_is_caught(deep):
    """What counting one crossing as a bounce costs a path: measured inconsistent."""
    v, detail = _verdict(deep.compare(modify=lambda s: s.with_render(max_depth=2)))
    assert v == "inconsistent", detail


@pytest.mark.parametrize("limit", [PANES, PANES - 1])
def test_transparent_max_bounces_as_cycles(tmp_path, limit):
    """The wall (emission WALL) is seen through PANES panes with the limit PANES, and not with
    one fewer, in both renderers (deterministic: every path crosses the same panes)."""
    from snell.tracer.integrator import Renderer
    from snell.validation import compare, cycles
    blend = build_panes(str(tmp_path / "panes.blend"))
    cyc = cycles.render_seeds(blend, spp=4, max_depth=2, seeds=(1, 2),
                              overrides={"cycles.transparent_max_bounces": limit})
    scene, _ = compare.load_snell_scene(blend)
    settings = scene.settings(spp=4, max_depth=2, transparent_max_bounces=limit, denoise=False)
    ours = Renderer(scene, settings).render().mean()
    expected = WALL if limit >= PANES else 0.0
    np.testing.assert_allclose(cyc.mean, expected, atol=1e-4)
    np.testing.assert_allclose(ours, expected, atol=1e-4)
