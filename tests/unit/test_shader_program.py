"""Shader programs (tracer/shader/): the loader's check of a program, the closures' weights as
Cycles gives them (svm_node_mix_closure, principled_bsdf_emission's Alpha), and the inputs'
formulas (Fresnel, Layer Weight, Light Path) against Cycles' own, written out here."""
from __future__ import annotations

import math

import numpy as np
import pytest

from snell.tracer import lobes, path_limits
from snell.tracer.materials import material_tables
from snell.tracer.microfacet_tables import shipped_tables
from snell.tracer.shader.inputs import ray_flags
from snell.tracer.lights.codes import (VISIBLE_CAMERA, VISIBLE_DIFFUSE, VISIBLE_GLOSSY,
                                       VISIBLE_TRANSMISSION)
from snell.tracer.shader import closures, inputs, program
from snell.tracer.shader.program import ProgramError, check_program

RED = [0.8, 0.1, 0.05]


def _program(code, constants, registers=None):
    rows = [row + [0] * (8 - len(row)) for row in code]
    return {"registers": registers if registers is not None else len(constants) + 16,
            "constants": constants, "code": rows}


@pytest.mark.parametrize("code, constants, message", [
    ([[999]], [], "unknown opcode 999"),
    ([[closures.DIFFUSE, -1, 40]], [0.5], "register 40 outside"),
    ([[closures.EMISSION, -1, 0, 3, 7]], [1.0, 1.0, 1.0, 2.0], "unused slot holds 7"),
    ([[inputs.IMAGE, 4, 7, 0, 3, 0, 0]], [0.0, 0.0, 0.0], "3 is not from 0 to 0"),
    ([[inputs.LIGHT_PATH, 0, 10]], [], "10 is not from 0 to 9"),
    ([[closures.GLOSSY, -1, 0, 3, 5, -1]], [0.5] * 4, "5 is not from 0 to 2"),
])
def test_check_program_names_the_bad_slot(code, constants, message):
    with pytest.raises(ProgramError, match=message):
        check_program(_program(code, constants), n_images=1, n_texcoords=0)


def test_check_program_rejects_more_constants_than_registers():
    with pytest.raises(ProgramError, match="more constants than registers"):
        check_program(_program([], [1.0, 2.0], registers=1), 0, 0)


def _run(code, constants, entering=True, flags=1 << inputs.LP_CAMERA, depth=0, length=1.0):
    """Run a program at a hit on a one-triangle scene: (lobes, count, registers)."""
    mat = {"name": "P", "kind": "program", "program": _program(code, constants)}
    check_program(mat["program"], 0, 0)
    mats = material_tables([mat], np.zeros(1, np.int32))
    regs = program.new_registers()
    scratch = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
    n = (0.0, 0.0, 1.0)
    view = (0.0, math.sin(0.6), math.cos(0.6))
    hit = ((0.0, 0.0, 0.0), n, n, view, entering, 0, 0.2, 0.3, flags, depth, length)
    count = program.run(mats, 0, regs, hit, scratch, shipped_tables(), False)
    return scratch, count, regs


def test_mix_shader_weights_its_sides_by_one_minus_fac_and_fac():
    """Mix(0.25, red Diffuse, Mix(1.7 -> clamped 1, Emission, Diffuse)): 0.75 red Lambert, the
    inner mix's first side 0 (no emission) and second 0.25 (Cycles clamps Fac to [0, 1])."""
    consts = [0.25, *RED, 1.7, 1.0, 1.0, 1.0, 3.0]
    w1, w2, w3, w4 = 9, 10, 11, 12
    code = [[closures.MIX_CLOSURE, w1, w2, -1, 0],
            [closures.DIFFUSE, w1, 1, -1],
            [closures.MIX_CLOSURE, w3, w4, w2, 4],
            [closures.EMISSION, w3, 5, 8],
            [closures.DIFFUSE, w4, 5, -1]]
    lobe, count, regs = _run(code, consts)
    assert count == 2
    assert lobe[0, lobes.WEIGHT:lobes.WEIGHT + 3] == pytest.approx([0.75 * c for c in RED])
    assert lobe[1, lobes.WEIGHT:lobes.WEIGHT + 3] == pytest.approx([0.25] * 3)
    assert lobe[1, lobes.SAMPLE_WEIGHT] == pytest.approx(0.25)
    assert program.total(regs, closures.TOTAL_EMISSION) == pytest.approx((0.0, 0.0, 0.0))


def test_emission_and_transparency_add_up_with_their_weights():
    consts = [0.4, 1.0, 0.5, 0.25, 2.0, 0.2, 0.3, 0.4]
    code = [[closures.MIX_CLOSURE, 8, 9, -1, 0],
            [closures.EMISSION, 8, 1, 4],
            [closures.TRANSPARENT_BSDF, 9, 5]]
    lobe, count, regs = _run(code, consts)
    assert program.total(regs, closures.TOTAL_EMISSION) == pytest.approx((1.2, 0.6, 0.3))
    assert program.total(regs, closures.TOTAL_TRANSPARENCY) == pytest.approx((0.08, 0.12, 0.16))
    assert count == 1 and lobe[0, lobes.KIND] == lobes.TRANSPARENT


def test_principled_alpha_is_a_transparent_share_and_scales_the_rest():
    """Alpha 0.4 under a mix weight 0.5: a transparent lobe of weight 0.5 x 0.6, then the
    Principled BSDF's lobes at 0.5 x 0.4 of what setup_principled gives alone; its emission
    at 0.5 x 0.4 too (Cycles' principled_bsdf_emission)."""
    block = [*RED, 0.0, 0.5, 1.5, 0.5, 0.0, 0.0, 0.03, 1.5, 1, 1, 1, 1, 1, 1,
             0.4, 1.0, 1.0, 1.0, 2.0]
    assert len(block) == closures.PRINCIPLED_BLOCK
    weight = len(block)
    lobe, count, regs = _run([[closures.PRINCIPLED, weight, 0, lobes.DIST_GGX, -1]],
                             block + [0.5])
    alone = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
    n = (0.0, 0.0, 1.0)
    view = (0.0, math.sin(0.6), math.cos(0.6))
    k = lobes.setup_principled(alone, shipped_tables(), n, n, view, True, tuple(RED),
                               np.array(block[3:17]), lobes.DIST_GGX)
    assert count == k + 1
    assert lobe[0, lobes.KIND] == lobes.TRANSPARENT
    assert lobe[0, lobes.WEIGHT:lobes.WEIGHT + 3] == pytest.approx([0.3] * 3)
    for i in range(k):
        assert lobe[1 + i, lobes.WEIGHT:lobes.WEIGHT + 3] == pytest.approx(
            0.2 * alone[i, lobes.WEIGHT:lobes.WEIGHT + 3])
    assert program.total(regs, closures.TOTAL_EMISSION) == pytest.approx((0.4, 0.4, 0.4))


def _cycles_fresnel(cosi, eta):
    """Cycles' fresnel_dielectric_cos (kernel/closure/bsdf_util.h), as written there."""
    c = abs(cosi)
    g = eta * eta - 1 + c * c
    if g > 0:
        g = math.sqrt(g)
        a = (g - c) / (g + c)
        b = (c * (g + c) - 1) / (c * (g - c) + 1)
        return 0.5 * a * a * (1 + b * b)
    return 1.0


@pytest.mark.parametrize("ior", [1.0, 1.33, 1.5, 2.4, 0.7])
@pytest.mark.parametrize("entering", [True, False])
def test_fresnel_node_is_cycles(ior, entering):
    _, _, regs = _run([[inputs.FRESNEL, 1, 0, -1]], [ior], entering=entering)
    eta = ior if entering else 1.0 / ior
    assert regs[1] == pytest.approx(_cycles_fresnel(math.cos(0.6), max(eta, 1e-5)), abs=1e-12)


@pytest.mark.parametrize("blend", [0.0, 0.2, 0.5, 0.8, 1.0])
def test_layer_weight_is_cycles(blend):
    _, _, regs = _run([[inputs.LAYER_WEIGHT, 1, 2, 0, -1]], [blend])
    c = math.cos(0.6)
    eta = 1.0 / max(1.0 - blend, 1e-5)
    facing = c
    if blend != 0.5:
        b = min(max(blend, 0.0), 1.0 - 1e-5)
        facing = c ** (2 * b if b < 0.5 else 0.5 / (1 - b))
    assert regs[1] == pytest.approx(_cycles_fresnel(c, eta), abs=1e-12)
    assert regs[2] == pytest.approx(1.0 - facing, abs=1e-12)


def test_light_path_outputs():
    flags = ray_flags(VISIBLE_GLOSSY, 0.0)
    code = [[inputs.LIGHT_PATH, k, k] for k in range(inputs.LIGHT_PATH_OUTPUTS)]
    _, _, regs = _run(code, [], flags=flags, depth=3, length=2.5)
    expect = {inputs.LP_GLOSSY: 1.0, inputs.LP_SINGULAR: 1.0, inputs.LP_REFLECTION: 1.0,
              inputs.LP_RAY_LENGTH: 2.5, inputs.LP_RAY_DEPTH: 3.0}
    assert list(regs[:inputs.LIGHT_PATH_OUTPUTS]) == [expect.get(k, 0.0)
                                                      for k in range(inputs.LIGHT_PATH_OUTPUTS)]
    # A shadow ray is one bounce further (Cycles), and a back face says so.
    _, _, regs = _run(code, [], entering=False, flags=1 << inputs.LP_SHADOW, depth=3)
    assert regs[inputs.LP_RAY_DEPTH] == 4.0 and regs[inputs.LP_SHADOW] == 1.0
    assert regs[inputs.LP_BACKFACING] == 1.0


@pytest.mark.parametrize("kind, pdf, expect", [
    (VISIBLE_CAMERA, 0.0, {inputs.LP_CAMERA}),
    (VISIBLE_DIFFUSE, 0.3, {inputs.LP_DIFFUSE, inputs.LP_REFLECTION}),
    (VISIBLE_GLOSSY, 0.3, {inputs.LP_GLOSSY, inputs.LP_REFLECTION}),
    (VISIBLE_TRANSMISSION, 0.0, {inputs.LP_GLOSSY, inputs.LP_TRANSMISSION, inputs.LP_SINGULAR}),
])
def test_ray_flags_are_cycles_path_flags(kind, pdf, expect):
    flags = ray_flags(kind, pdf)
    assert {k for k in range(7) if flags & (1 << k)} == expect


@pytest.mark.parametrize("drop, kinds", [
    (0, ("glossy", "glass")),
    (path_limits.NO_REFLECTIVE_CAUSTICS, ("refracting glass",)),
    (path_limits.NO_REFRACTIVE_CAUSTICS, ("glossy", "reflecting glass")),
    (path_limits.NO_REFLECTIVE_CAUSTICS | path_limits.NO_REFRACTIVE_CAUSTICS, ()),
])
def test_the_caustics_a_hit_drops_reach_its_closures(drop, kinds):
    """Mix(0.5, Glossy, Glass) at a hit a diffuse ray reached, the caustics switched off in the
    hit's flags from bit inputs.DROP_SHIFT (scatter_program puts them there): Cycles' closure
    nodes leave out a dropped Glossy and set a Glass closure's dropped tint to 0."""
    consts = [0.5, 0.9, 0.9, 0.9, 0.3, 1.5]
    w1, w2 = 8, 9
    code = [[closures.MIX_CLOSURE, w1, w2, -1, 0],
            [closures.GLOSSY, w1, 1, 4, lobes.DIST_GGX, -1],
            [closures.GLASS, w2, 1, 4, 5, lobes.DIST_GGX, -1]]
    flags = ray_flags(VISIBLE_DIFFUSE, 0.3) | drop << inputs.DROP_SHIFT
    lobe, count, _ = _run(code, consts, flags=flags)
    found = []
    for k in range(count):
        r, t = lobe[k, lobes.R_TINT], lobe[k, lobes.T_TINT]
        if lobe[k, lobes.TRANSMITS] == 0.0:
            found.append("glossy")
        else:
            found.append("glass" if r > 0 and t > 0 else "refracting glass" if t > 0
                         else "reflecting glass")
    assert tuple(found) == kinds
