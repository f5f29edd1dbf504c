"""Light paths onto textured floors (issue 34, tracer/receivers.py) against Cycles.

A glass sphere (smooth normals) over a floor whose colour is a Checker Texture, into a Diffuse
BSDF or into a Principled BSDF's Base Color (roughness 0.5: a Lambert lobe under a glossy one),
lit by a small sphere lamp that Cycles' path tracer finds through the glass: the caustic on the
checker is carried by Snell's light paths (the floor a node-tree material, which before issue
34's receivers got none: the path tracer alone rendered it, by fireflies), and the image must be
consistent with Cycles'. Power: the render without its light-traced part (the light tracer's
paths still skipped by its path tracer: the caustic rendered by nothing) is caught. A light
tracer too bright is not something a path tracer's reference can catch (the validator's light
allowance, validation/metrics.py): tests/render/test_caustics_receivers.py holds the same floors
against Snell's path tracer alone, doubled and texture-blind light parts included, and the delta
lamps' caustics on the checker against pure light tracing.
"""
from __future__ import annotations

import importlib

import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict
from support.cycles_reference import without_light_tracer

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}
SPP = 256
FLOORS = {"diffuse": {}, "principled": {"Roughness": 0.5}}


def build(path, kind):
    """The glass sphere over a checker floor of this shader kind, under a 10 cm sphere lamp."""
    scene = common.reset()
    common.setup_render(scene, (48, 48), max_bounces=3)
    checker = common.checker_material("Checker", (0.8, 0.8, 0.8), (0.1, 0.1, 0.1), 6.0, kind,
                                      **FLOORS[kind])
    common.floor("Floor", 1.5, checker)
    glass = common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5)
    common.uv_sphere("GlassSphere", (0.0, 0.0, 0.6), 0.3, glass)
    common.camera(scene, (0.0, -1.0, 1.6), (0.05, 0.1, 0.1), lens=35.0)
    common.point_lamp("Lamp", (0.1, 0.05, 1.6), 3.0, 0.1)
    return common.save(path)


@pytest.fixture(scope="module", params=sorted(FLOORS))
def checker(request, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("checker_caustic")
    return request.param, Reference(build(str(tmp / f"{request.param}.blend"), request.param),
                                    framing=FULL, spp=SPP)


def test_checker_floor_caustic_is_consistent_with_cycles(checker):
    """The caustic on the checker by light paths ending on the node-tree floor, the rest path
    traced, against Cycles; the same render without its light paths is caught."""
    from snell.validation import compare
    kind, reference = checker
    assert not reference.warnings, reference.warnings
    result = compare.snell_render(reference.scene, SPP)
    assert result.stages["light tracing"][1].endswith("onto 'Checker' (node tree)"), \
        result.stages["light tracing"]
    assert result.stats["caustic_splats"] > 0
    verdict, detail = _verdict(reference.compare())
    assert verdict == "consistent", (kind, detail)
    wrong = compare.compare_renders(without_light_tracer(result), reference.cycles,
                                    scene=reference.scene)
    verdict, detail = _verdict(wrong)
    assert verdict == "inconsistent", (kind, detail)
