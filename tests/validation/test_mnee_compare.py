"""Manifold next-event estimation (tracer/mnee.py) against Cycles' shadow caustics, on the pool
of scenes/pool.py (a caustic on a floor under wavy water, seen through the water; the lamp a
caustics light, the water a caster, the floor a receiver, as the file sets them) at 30x30: under
its round lamp, a sun of angle 0 and a square area lamp; and with a checker floor of a Principled
BSDF (a node tree: a receiver whose whole BSDF, glossy lobe included, the stage evaluates).

Both render the same estimator family: a point on the lamp, the seed segment's caster chain,
Newton's walk, the generalized geometry term. Cycles clamps that term at 2 (kernel/integrator/
mnee.h, mnee_path_contribution: "it has a tendency to be unstable"), Snell does not; and for a
round lamp (a point lamp of radius > 0) Cycles' term is taken for the wrong disk, so the pool
under it is held against Cycles' plain path tracer instead. Snell's own consistency with its
path-traced reference is tests/render/test_mnee.py's.
"""
from __future__ import annotations

import copy
import importlib

import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

pool_script = importlib.import_module("pool")

SPP = 256
FRAMING = {"resolution_percentage": 12}       # 256 x 12% = 30 pixels a side
PLAIN_SPP = 65536          # Cycles' path tracer: 8 seeds x 8192
PLAIN_SNELL_SPP = 4096     # Snell's MNEE against it


@pytest.fixture(scope="module")
def plain_pool_reference(tmp_path_factory):
    """Cycles' plain path tracer on the pool without the shadow-caustics flags, and its export."""
    blend = pool_script.build(str(tmp_path_factory.mktemp("mnee") / "pool_plain.blend"),
                              caustics=False)
    return Reference(blend, framing=FRAMING, spp=PLAIN_SPP)


def with_shadow_caustics(scene):
    """A copy of the pool's scene with the flags scenes/pool.py sets (the lamp a caustics light,
    the water a caster, the floor a receiver)."""
    scene = copy.copy(scene)
    scene.objects, scene.lights = copy.deepcopy(scene.objects), copy.deepcopy(scene.lights)
    roles = {"Water": "caustics_caster", "Floor": "caustics_receiver"}
    for obj in scene.objects:
        obj[roles[obj["name"]]] = True
    for light in scene.lights:
        light["caustics_light"] = True
    return scene


def brighter_lamp(scene):
    """A deliberate error: the lamp 5% brighter (a copy of the scene)."""
    scene = copy.copy(scene)
    scene.lights = copy.deepcopy(scene.lights)
    light = scene.lights[0]
    field = {"point": "intensity", "sun": "irradiance", "area": "radiance"}[light["kind"]]
    light[field] = [1.05 * c for c in light[field]]
    return scene


CYCLES_CLAMP = 2.0          # Cycles' clamp of the generalized geometry term (mnee.h)


def clamped_like_cycles(monkeypatch):
    """Snell's MNEE with its geometry term clamped at CYCLES_CLAMP, as Cycles' (the stage's
    deliver, each delivered chain's transfer determinant scaled down where the term exceeds
    it); returns the list of the unclamped terms it saw."""
    from snell.tracer import manifold, mnee
    deliver, seen = mnee.deliver, []

    def clamped(lights, mats, tables, has_normals, fresnel_model, chains, m, blocked, radiance,
                without, scratch):
        for c in chains.owner[:m][blocked[:m] != 0]:
            g = manifold.geometry_term(tuple(chains.x0[c]), tuple(chains.pos[c, 0]),
                                       tuple(chains.ng[c, 0]), chains.transfer[c])
            seen.append(g)
            if g > CYCLES_CLAMP:
                chains.transfer[c] *= CYCLES_CLAMP / g
        deliver(lights, mats, tables, has_normals, fresnel_model, chains, m, blocked, radiance,
                without, scratch)
    monkeypatch.setattr(mnee, "deliver", clamped)
    return seen


@pytest.fixture(scope="module", params=["sun", "area"])
def other_lamp_reference(request, tmp_path_factory):
    """Cycles and the exported pool under a sun of angle 0 or an area lamp (scenes/pool.py)."""
    path = str(tmp_path_factory.mktemp("mnee") / f"pool_{request.param}.blend")
    return Reference(pool_script.build(path, light=request.param), framing=FRAMING, spp=SPP)


def checker_floor():
    """The pool's floor as a node tree: a Checker Texture into a Principled BSDF's Base Color,
    roughness 0.3 (a glossy lobe over the Lambert one)."""
    return pool_script.common.checker_material("Floor", (0.8, 0.8, 0.8), (0.15, 0.15, 0.15),
                                               4.0, "principled", Roughness=0.3)


@pytest.fixture(scope="module", params=["point", "sun"])
def checker_floor_reference(request, tmp_path_factory):
    """Cycles and the exported pool with the checker floor, under its round lamp or a sun of
    angle 0."""
    path = str(tmp_path_factory.mktemp("mnee") / f"pool_checker_{request.param}.blend")
    return request.param, Reference(pool_script.build(path, light=request.param,
                                                      floor=checker_floor),
                                    framing=FRAMING, spp=SPP)


def test_a_node_tree_receiver_is_consistent_with_cycles(checker_floor_reference, monkeypatch):
    """The pool's floor a checker Principled BSDF (a shader program), under the round lamp and
    a sun of angle 0 (Snell's geometry term clamped at 2 as Cycles', clamped_like_cycles; 8
    Cycles seeds x 256 spp, Snell 256 spp): consistent with Cycles (measured: mean ratio 0.9997,
    mean z -0.02 under the lamp; 0.998, z -2.6 under the sun; every test passed), and the lamp
    5% brighter is caught (1.050, 4 tiles failed; 1.048, z 73); so is the stage without the
    receiver's glossy lobe, whose light the path tracer leaves it (0.78, z -18; 0.64, z -594).
    Before, MNEE took diffuse receivers only: under the sun the image was black (mean 0.0008
    against 0.46 now: no other technique renders a delta lamp's light seen through the water);
    under the round lamp the path tracer found it through the water by rare paths."""
    from snell.tracer import mnee
    light, reference = checker_floor_reference
    assert {m["name"]: m["kind"] for m in reference.scene.materials}["Floor"] == "program"
    if light == "sun":
        clamped_like_cycles(monkeypatch)
    _assert_consistent_and_brighter_lamp_caught(reference)
    deliver = mnee.deliver

    def without_glossy(lights, mats, tables, has_normals, fresnel_model, chains, *rest):
        chains.room_glossy[:] = -1          # no room after a glossy reflection: none evaluated
        deliver(lights, mats, tables, has_normals, fresnel_model, chains, *rest)
    monkeypatch.setattr(mnee, "deliver", without_glossy)
    verdict, detail = _verdict(reference.compare())
    assert verdict != "consistent", detail


def test_pool_with_shadow_caustics_is_consistent_with_cycles_path_tracer(plain_pool_reference):
    """Snell's MNEE on the pool under its round lamp (the file's flags, Snell 4096 spp) against
    Cycles' plain path tracer (the same file without the flags, 8 seeds x 8192 spp, stored):
    consistent, and a lamp 5% brighter is caught. Against Cycles' own shadow caustics it is
    not: Cycles keeps the lamp point on the disk that faces the receiver and takes its
    Jacobian across the last segment, 0.75% too bright here (+9% for a lamp of radius 1 m;
    docs/measurements.md), where Snell's disk faces the chain's last vertex as the path
    tracer's does (manifold.facing_disk). Measured: mean ratio 1.0008 (mean z 0.41),
    every test passed; the lamp 5% brighter 1.051 (mean z 25, 7 tiles failed); against Cycles'
    shadow caustics (8 seeds x 256 spp, Snell 256 spp) 0.9955, 3 tiles failed. Snell at 4096
    spp: at 256 and 1024 its MNEE's heavy tail (the Jacobian near the caustic's folds)
    under-states a few pixels' variances against a reference this converged (pixels failed at
    256, one tile at 1024; mean ratios 1.006 and 0.996)."""
    report = _assert_consistent_and_brighter_lamp_caught(
        plain_pool_reference, with_shadow_caustics, spp=PLAIN_SNELL_SPP)
    # The report names the round lamp whose light Cycles' shadow caustics overstate.
    assert len(report["cycles_caveats"]) == 1 and "'Lamp'" in report["cycles_caveats"][0]


def test_compare_notes_where_cycles_shadow_caustics_are_biased():
    """compare.cycles_caveats: a round caustics lamp and a sun get a note (Cycles' disk facing
    the receiver, Cycles' clamp) where the stage runs; an area lamp, or no flags, none."""
    from snell.tracer.integrator import Renderer
    from snell.validation.compare import cycles_caveats
    from support.sds_scenes import pool, pool_area, pool_sun, shadow_caustics

    def caveats(scene):
        return cycles_caveats(scene, Renderer(scene).stages())
    round_lamp = caveats(shadow_caustics(pool(resolution=(8, 8))))
    assert len(round_lamp) == 1 and "'Lamp'" in round_lamp[0] and "disk" in round_lamp[0]
    sun = caveats(shadow_caustics(pool(resolution=(8, 8), lamp=pool_sun(0.0))))
    assert len(sun) == 1 and "'Sun'" in sun[0] and "clamp" in sun[0]
    assert caveats(shadow_caustics(pool(resolution=(8, 8), lamp=pool_area()))) == []
    assert caveats(pool(resolution=(8, 8))) == []
    # A render that ran no shadow caustics (its stages say so) gets no note.
    assert cycles_caveats(shadow_caustics(pool(resolution=(8, 8))),
                          {"shadow caustics": (False, "shadow caustics off")}) == []


def _assert_consistent_and_brighter_lamp_caught(reference, modify=lambda s: s, spp=SPP):
    """The shadow-caustics stage runs in Snell's render (of the scene `modify` makes, at spp
    whatever Cycles' count), which is consistent with Cycles', and with the lamp 5% brighter is
    not. Returns the consistent render's report."""
    from snell.tracer.integrator import Renderer
    # The water is an open sheet: its warning says so, and nothing else is replaced.
    assert all("not closed" in w for w in reference.warnings), reference.warnings
    assert Renderer(modify(reference.scene)).stages()["shadow caustics"][0]
    report = reference.compare(modify, spp=spp)
    verdict, detail = _verdict(report)
    assert verdict == "consistent", detail
    verdict, detail = _verdict(reference.compare(lambda s: brighter_lamp(modify(s)), spp=spp))
    assert verdict != "consistent", detail
    return report


def test_suns_and_area_lamps_with_shadow_caustics_are_consistent_with_cycles(
        other_lamp_reference, monkeypatch):
    """Snell's MNEE against Cycles' under a sun of angle 0 (a fixed direction: Cycles'
    light_fixed_direction) and a square area lamp (8 Cycles seeds x 256 spp; Snell 256 spp),
    Snell's geometry term clamped at 2 as Cycles' (clamped_like_cycles): consistent, and the
    lamp 5% brighter is caught. Under the sun that term is per unit of the sun's solid angle,
    about 1 where the water does not focus (median 0.54, 1% of chains above 2, at most 3.4):
    unclamped, Snell's image is 1.009 +- 0.001 of Cycles' (mean z 11, inconsistent), the 1%
    of MNEE's light the clamp takes off by these terms; Cycles' clamp is the difference.
    Clamped: 0.999 +- 0.001 (mean z -1.3, every test passed), the sun 5% brighter 1.049 (z 62,
    9 tiles failed). Under the area lamp the term is per unit of lamp area (dw0/dA, at most
    0.87 here): clamped or not 1.013 +- 0.010 (mean z 1.2)."""
    seen = clamped_like_cycles(monkeypatch)
    _assert_consistent_and_brighter_lamp_caught(other_lamp_reference)
    assert len(seen) > 0
