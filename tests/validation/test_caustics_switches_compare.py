"""Cycles' Light Paths > Caustics switches in Snell, against Cycles (tracer/path_limits.py).

A floor lit by a small emitter, with a glass sphere's refractive caustic and a flat mirror's
reflective caustic on it, seen directly, and a rough Principled sphere (coat, metallic,
specular) beside them. With a switch off, Cycles drops that kind of lobe at every surface a
diffuse bounce reaches: the floor loses that caustic (the light tracer's paths and the path
tracer's alike) and the Principled sphere's light on the floor loses those layers. Each case is
consistent with Cycles given the file's switches; Snell ignoring the switch, or dropping the
other kind of lobe, is caught.
"""
from __future__ import annotations

import importlib

import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}
# (reflective, refractive) of each case's file.
CASES = {"reflective off": (False, True), "refractive off": (True, False),
         "both off": (False, False)}


def build(path, reflective, refractive):
    scene = common.reset()
    common.setup_render(scene, (40, 40))
    scene.cycles.caustics_reflective, scene.cycles.caustics_refractive = reflective, refractive
    common.floor("Floor", 2.0, common.material("Floor", "diffuse", (0.8, 0.8, 0.8)))
    # Raised so that its focus is above the floor: the caustic spreads over a few pixels.
    common.uv_sphere("Glass", (-0.6, 0.0, 0.9), 0.45,
                     common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5),
                     segments=32, rings=16)
    # A vertical mirror facing the lamp: its reflection lands on the floor at x 0.1 .. 1.1.
    common.quad("Mirror", [(1.2, -0.5, 0.2), (1.2, -0.5, 1.2), (1.2, 0.5, 1.2), (1.2, 0.5, 0.2)],
                common.material("Mirror", "glossy", (0.9, 0.9, 0.9)))
    common.uv_sphere("Principled", (-0.3, 1.1, 0.35), 0.35,
                     common.material("Principled", "principled", (0.8, 0.5, 0.2),
                                     Metallic=0.5, Roughness=0.2,
                                     **{"Coat Weight": 0.5, "Coat Roughness": 0.1}),
                     segments=32, rings=16)
    corners = [(0.15 * x, 0.15 * y, 2.5) for x, y in ((-1, -1), (-1, 1), (1, 1), (1, -1))]
    common.quad("Light", corners,
                common.material("Light", "emission", (1.0, 1.0, 1.0), Strength=200.0))
    common.camera(scene, (0.0, -2.6, 2.3), (0.1, 0.2, 0.2), lens=35.0)
    return common.save(path)


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request, tmp_path_factory):
    reflective, refractive = CASES[request.param]
    blend = build(str(tmp_path_factory.mktemp("switches") / "switches.blend"), reflective,
                  refractive)
    return Reference(blend, framing=FULL), (reflective, refractive)


def test_the_files_switches_reach_both_renderers(case):
    from snell.validation import cycles
    ref, switches = case
    render = ref.scene.render
    assert (render["caustics_reflective"], render["caustics_refractive"]) == switches
    assert cycles.scene_caustics(ref.scene) == switches
    forced = {k: v for k, v, _ in cycles.forced_settings(8, 4, 0, caustics=switches)}
    assert (forced["cycles.caustics_reflective"], forced["cycles.caustics_refractive"]) == switches


def test_the_light_tracer_runs_while_a_kind_is_left(case):
    from snell.tracer.integrator import Renderer
    ref, switches = case
    renderer = Renderer(ref.scene, ref.scene.settings())
    assert (renderer.caustics is not None) == any(switches)
    if not any(switches):
        assert "reflective and refractive caustics off" in renderer.stages()["light tracing"][1]


def test_the_switches_as_cycles(case):
    ref, _ = case
    v, detail = _verdict(ref.compare())
    assert v == "consistent", detail


def test_the_switch_ignored_is_caught(case):
    """Snell before the switches: every caustic rendered. By the path tracer alone: the
    verdict calls Snell too bright where its light tracer carries light only if it is so
    without that light (validation/metrics.py), so a light tracer that ignored the switch is
    held by tests/render/test_caustics_switches.py instead."""
    ref, _ = case
    v, detail = _verdict(ref.compare(
        modify=lambda s: s.with_render(caustics_reflective=True, caustics_refractive=True,
                                       caustics=False)))
    assert v == "inconsistent", detail


def test_the_other_lobe_dropped_is_caught(case):
    """The switches swapped: the wrong kind of lobe dropped (both off has no other kind)."""
    ref, (reflective, refractive) = case
    if reflective == refractive:
        pytest.skip("both off: no other kind to drop")
    v, detail = _verdict(ref.compare(
        modify=lambda s: s.with_render(caustics_reflective=refractive,
                                       caustics_refractive=reflective)))
    assert v == "inconsistent", detail
