"""Deliberate errors in a scene's shader programs (tracer/shader/program.py), for tests that
show a comparison with Cycles has power: a constant changed, or one slot pointed at a new
constant (the registers after the constants moved up to make room)."""
from __future__ import annotations

import copy

from snell.tracer.shader.program import SPECS, WIDTH


def material_copy(scene, name):
    """(a copy of the scene whose materials are copies, its material `name`)."""
    scene = copy.copy(scene)
    scene.materials = copy.deepcopy(scene.materials)
    return scene, next(m for m in scene.materials if m["name"] == name)


def with_constant(scene, name, old, new):
    """The scene with every constant `old` of material `name`'s program set to `new`."""
    scene, mat = material_copy(scene, name)
    consts = mat["program"]["constants"]
    hits = [k for k, value in enumerate(consts) if abs(value - old) <= 1e-6 * max(1, abs(old))]
    assert hits, f"{name}'s program has no constant {old}"
    for k in hits:
        consts[k] = new
    return scene


def with_slot_constant(scene, name, opcode, slot, value):
    """The scene with slot `slot` of material `name`'s first `opcode` instruction reading a new
    constant register holding value (a number, or three)."""
    scene, mat = material_copy(scene, name)
    program = mat["program"]
    values = [float(value)] if not hasattr(value, "__len__") else [float(v) for v in value]
    first_temp = len(program["constants"])
    shift = len(values)
    for row in program["code"]:
        for s, letter in enumerate(SPECS[row[0]][1], start=1):
            if letter in WIDTH and row[s] >= first_temp:
                row[s] += shift
    program["constants"] = program["constants"] + values
    program["registers"] += shift
    row = next(r for r in program["code"] if r[0] == opcode)
    row[slot] = first_temp
    return scene
