"""Cycles' Light Paths settings in Snell, against Cycles: the bounce limits of each kind and
clamping (tracer/path_limits.py).

Limits: a Cornell box with a glass and a mirror sphere, rendered with Cycles' Diffuse 1, Glossy 0
and Transmission 1 (Max Bounces 7): the mirror shows only the lamp, the glass only the lamp and
what one more surface adds, the walls two diffuse bounces. The validator gives Cycles the scene's
limits (validation.cycles.scene_bounces); Snell is consistent with them, and each limit one
higher is caught, as is the old Snell that limited the total only.

Clamping: four scenes whose every sample is the same (an emitter seen directly or in a mirror, a
sun-lit surface seen directly or in a mirror), so that a clamp changes both renderers' values
alike and the expected pixel is known: Cycles and Snell each equal it. They hold the limit (3 x
the setting on r + g + b) and which light is direct: seen by the camera or its first bounce's
ray, or a light sample of the first hit.
"""
from __future__ import annotations

import importlib
import math

import numpy as np
import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}
LIMITS = {"diffuse_bounces": 1, "glossy_bounces": 0, "transmission_bounces": 1}


def build_limits(path):
    scene = common.reset()
    common.setup_render(scene, (40, 40))
    c = scene.cycles
    c.diffuse_bounces, c.glossy_bounces = LIMITS["diffuse_bounces"], LIMITS["glossy_bounces"]
    c.transmission_bounces = LIMITS["transmission_bounces"]
    common.cornell_box(light_size=0.8)
    common.uv_sphere("Glass", (-0.45, 0.1, 0.4), 0.38,
                     common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5),
                     segments=32, rings=16)
    common.uv_sphere("Mirror", (0.45, -0.15, 0.32), 0.3,
                     common.material("Mirror", "glossy", (0.9, 0.9, 0.9)), segments=32, rings=16)
    common.cornell_camera(scene)
    return common.save(path)


@pytest.fixture(scope="module")
def limits(tmp_path_factory):
    blend = build_limits(str(tmp_path_factory.mktemp("limits") / "limits.blend"))
    return Reference(blend, framing=FULL)


def test_the_files_limits_reach_both_renderers(limits):
    from snell.validation import cycles
    render = limits.scene.render
    assert {k: render[k] for k in LIMITS} == LIMITS
    assert cycles.scene_bounces(limits.scene) == (1, 0, 1)


def test_limits_of_each_kind_as_cycles(limits):
    v, detail = _verdict(limits.compare())
    assert v == "consistent", detail


@pytest.mark.parametrize("kind", sorted(LIMITS))
def test_a_limit_one_higher_is_caught(limits, kind):
    """Each kind's limit matters in this scene: one more bounce of it is measured."""
    v, detail = _verdict(limits.compare(
        modify=lambda s: s.with_render(**{kind: LIMITS[kind] + 1})))
    assert v == "inconsistent", detail


def test_the_total_alone_is_caught(limits):
    """Snell before the limits of each kind: the total limited paths alone."""
    v, detail = _verdict(limits.compare(
        modify=lambda s: s.with_render(**dict.fromkeys(LIMITS, 1024))))
    assert v == "inconsistent", detail


def build_caustic(path):
    """A glass sphere's caustic on a floor under a small emitter, with Cycles' Transmission 0:
    a camera path from the floor ends inside the sphere, so Cycles renders no caustic, and
    Snell's light tracer must drop its paths at their second (non-last) transmission."""
    scene = common.reset()
    common.setup_render(scene, (32, 32))
    scene.cycles.transmission_bounces = 0
    common.quad("Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)],
                common.material("Floor", "diffuse", (0.8, 0.8, 0.8)))
    common.uv_sphere("Glass", (0.0, 0.0, 0.6), 0.5,
                     common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5),
                     segments=32, rings=16)
    s = 0.15
    common.quad("Light", [(-s, -s, 2.5), (-s, s, 2.5), (s, s, 2.5), (s, -s, 2.5)],
                common.material("Light", "emission", (1.0, 1.0, 1.0), Strength=200.0))
    common.camera(scene, (0.0, -3.0, 2.5), (0.0, 0.0, 0.2), lens=35.0)
    return common.save(path)


@pytest.fixture(scope="module")
def caustic(tmp_path_factory):
    blend = build_caustic(str(tmp_path_factory.mktemp("caustic") / "caustic.blend"))
    return Reference(blend, framing=FULL)


def test_the_light_tracer_keeps_the_limits(caustic):
    """Snell's light tracer renders the caustic's paths only as far as the limits let a camera
    path go (light_tracer.count_scattering)."""
    from snell.tracer.integrator import Renderer
    assert Renderer(caustic.scene, caustic.scene.settings()).caustics is not None
    v, detail = _verdict(caustic.compare())
    assert v == "consistent", detail


def test_the_light_tracer_drops_paths_past_a_limit(caustic):
    """With Transmission 0 only the glass's reflections reach the floor (a light path's first
    vertex is free: towards the light in the camera path's order); every refracted path has a
    second transmission. Measured: 76 splats at Transmission 0 against 539 at 1 and 1024 (16
    spp); with count_scattering's limit check removed, 539 at each."""
    from snell.tracer.integrator import Renderer
    splats = {}
    for limit in (0, 1, 1024):
        scene = caustic.scene.with_render(transmission_bounces=limit)
        # The same light paths at every limit: a fixed share (the pilot's follows the limit).
        result = Renderer(scene, scene.settings(spp=16, light_vertices=False,
                                                light_paths_per_camera_path=0.125)).render()
        splats[limit] = result.stats["caustic_splats"]
    assert splats[1] == splats[1024] > 0
    assert 0 < splats[0] < 0.3 * splats[1], splats


# Clamping: each scene's pixels, all alike (8 x 8, a narrow camera).
EMISSION = 5.0              # the emitter's strength: its radiance
SUN = 10.0                  # W/m^2
ALBEDO = 0.8
SUN_TILT = 60.0             # the sun on the mirror's scene's ceiling, from its normal


def sunlit(tilt_deg):
    """The radiance of an ALBEDO Lambert surface under the sun at tilt_deg from its normal."""
    return ALBEDO / math.pi * SUN * math.cos(math.radians(tilt_deg))


def sun_lamp(rotation):
    data = bpy.data.lights.new("Sun", "SUN")
    data.energy, data.angle = SUN, 0.0
    lamp = bpy.data.objects.new("Sun", data)
    lamp.rotation_euler = rotation
    bpy.context.scene.collection.objects.link(lamp)


def build_clamp(path, kind):
    """kind: "emitter" (seen directly), "sunlit" (a floor under the sun, straight down),
    "mirror_emitter" or "mirror_sunlit" (a mirror below the camera showing an emitter, or a
    ceiling lit by the sun from below at SUN_TILT)."""
    scene = common.reset()
    common.setup_render(scene, (8, 8), max_bounces=1)
    big = 10.0
    down = [(-big, -big, 4.0), (-big, big, 4.0), (big, big, 4.0), (big, -big, 4.0)]  # faces -Z
    up = [(-1, -1, 0.0), (1, -1, 0.0), (1, 1, 0.0), (-1, 1, 0.0)]                    # faces +Z
    glow = common.material("Glow", "emission", (1.0, 1.0, 1.0), Strength=EMISSION)
    white = common.material("White", "diffuse", (ALBEDO,) * 3)
    if kind == "emitter":
        common.quad("Glow", up, glow)
    elif kind == "sunlit":
        common.quad("Floor", up, white)
        sun_lamp((0.0, 0.0, 0.0))
    else:
        common.quad("Mirror", up, common.material("Mirror", "glossy", (1.0, 1.0, 1.0)))
        if kind == "mirror_emitter":
            common.quad("Glow", down, glow)
        else:
            common.quad("Ceiling", down, white)
            # The light travels up at SUN_TILT from the vertical: the ceiling's shadow rays
            # pass far beside the mirror.
            sun_lamp((math.radians(180.0 - SUN_TILT), 0.0, 0.0))
    common.camera(scene, (0.0, 0.0, 2.0), (0.0, 0.0, 0.0), lens=100.0)
    return common.save(path)


# (scene, max depth, direct clamp, indirect clamp, the expected pixel)
CLAMP_CASES = [
    ("emitter", 1, 0.0, 0.0, EMISSION),
    ("emitter", 1, 1.0, 0.0, 1.0),                      # 15 on r + g + b: to 3
    ("emitter", 1, 0.0, 0.5, EMISSION),                 # the camera's view is direct
    ("sunlit", 1, 1.0, 0.0, 1.0),                       # a light sample of the first hit
    ("sunlit", 1, 0.0, 0.5, sunlit(0.0)),
    ("mirror_emitter", 2, 1.0, 0.0, 1.0),               # found by the first bounce's ray: direct
    ("mirror_emitter", 2, 0.0, 0.5, EMISSION),
    ("mirror_sunlit", 2, 1.0, 0.0, sunlit(SUN_TILT)),   # a light sample of the second hit ...
    ("mirror_sunlit", 2, 0.0, 0.5, 0.5),                # ... is indirect
]


@pytest.mark.parametrize("kind, depth, direct, indirect, expected", CLAMP_CASES)
def test_clamping_as_cycles(tmp_path, kind, depth, direct, indirect, expected):
    from snell.tracer.integrator import Renderer
    from snell.validation import compare, cycles
    blend = build_clamp(str(tmp_path / f"{kind}.blend"), kind)
    clamps = {"cycles.sample_clamp_direct": direct, "cycles.sample_clamp_indirect": indirect}
    cyc = cycles.render_seeds(blend, spp=4, max_depth=depth, seeds=(1, 2), overrides=clamps)
    scene, _ = compare.load_snell_scene(blend)
    settings = scene.settings(spp=4, max_depth=depth, denoise=False, caustics=False,
                              light_vertices=False, sample_clamp_direct=direct,
                              sample_clamp_indirect=indirect)
    ours = Renderer(scene, settings).render().mean()
    np.testing.assert_allclose(cyc.mean, expected, rtol=1e-3)
    np.testing.assert_allclose(ours, expected, rtol=1e-3)
