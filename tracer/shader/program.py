"""Shader programs: a material's node tree compiled (by addon/export/shader/) into a flat list
of instructions that one compiled interpreter runs at every hit, as Cycles compiles shader nodes
to its SVM (kernel/svm/svm.h): no Python per hit and no kernel compile per material.

A program, in the scene file: {"registers": R, "constants": [...], "code": [[op, s1, ..., s7],
...], "data": [...]}. Registers are float64; the first len(constants) hold the constants when
the program starts. A float is one register, a vector or colour three in a row. An instruction
is an opcode and seven slots; what each slot is, the family's SPECS says, a letter per slot:

  f  a float register          v  a vector or colour register (3 wide)
  w  a mix weight register, or -1 (weight 1)
  n  a normal register, or -1 (the hit's shading normal)
  P  a Principled BSDF's block of closures.PRINCIPLED_BLOCK registers
  i  a literal integer         d  an offset into the program's data, the next slot (an i)
                                  the number of values read from there
  -  unused (0)

A SPECS entry is (what it computes, slots) or (what, slots, {slot: limit}): literal slot s must
be from 0 to limit - 1 (limit "images" or "texcoords": the scene's counts).

Families of instructions, by opcode range: closures.py (0-19: the closures and the Mix Shader),
inputs.py (20-39: what reads the hit), object_inputs.py (40-99: the object, camera and mesh
attributes), math_nodes.py (100-199), color_nodes.py (200-299), procedural_textures.py
(300-399), normals.py (400-449: shading normals) and bump.py (450-479: the Bump node and bump
displacement, which move the hit the instructions between OFFSET and RESTORE read, and
SET_NORMAL, which changes its shading normal). The scene loader checks every instruction
against its family's SPECS (check_program), so the interpreter trusts its indices.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..jit import jit
from . import (bump, closures, color_nodes, inputs, math_nodes, normals, object_inputs,
               procedural_textures)

SLOTS = 7
MAX_REGISTERS = 1024
MAX_INSTRUCTIONS = 100000
FAMILIES = (closures, inputs, object_inputs, math_nodes, color_nodes, procedural_textures,
            normals, bump)
SPECS = {op: spec for family in FAMILIES for op, spec in family.SPECS.items()}
WIDTH = {"f": 1, "v": 3, "w": 1, "n": 3, "P": closures.PRINCIPLED_BLOCK}
# What the tracer needs to know of a program without running it (Programs.flags).
MAY_BE_TRANSPARENT = 1     # it has a Transparent closure or a Principled BSDF's Alpha < 1
EMISSION_VARIES = 2        # its emission is not the material's constant "emission"
HAS_HOLDOUT = 4            # it has a Holdout closure: the film's alpha is rendered


class Programs(NamedTuple):
    """Every material's program in one set of tables (rows of material m: start[m] ..
    start[m] + length[m]; length 0: no program)."""
    code: np.ndarray          # (N, 8) int64 instructions
    consts: np.ndarray        # (K,) float64 every program's constants in turn
    data: np.ndarray          # (D,) float64 every program's data in turn (offsets rebased)
    start: np.ndarray         # (M,) int64
    length: np.ndarray        # (M,) int64
    const_start: np.ndarray   # (M,) int64
    const_length: np.ndarray  # (M,) int64
    flags: np.ndarray         # (M,) int64 MAY_BE_TRANSPARENT | EMISSION_VARIES | HAS_HOLDOUT
    # What bump differentials read besides Materials.camera (bump.with_view sets them for a
    # render; by default none: a bump moves no barycentrics, and pixels are 0.001 wide at
    # distance 1, about a 50 mm lens's at 700 pixels).
    corners: np.ndarray       # (T, 3, 3) float64 the scene's triangle corners
    pixel: np.ndarray         # (2,) float64 a pixel's size on the view plane (bump.pixel_size)


class ProgramError(ValueError):
    """A program that does not follow SPECS: the text names the instruction and slot."""


def check_program(program: dict, n_images: int, n_texcoords: int) -> None:
    """Raise ProgramError unless every instruction's opcode is known and its slots are in
    range (registers, data, the scene's images and texture coordinates)."""
    if not isinstance(program, dict):
        raise ProgramError("expected an object")
    registers = program.get("registers")
    if not isinstance(registers, int) or isinstance(registers, bool) \
            or not 0 <= registers <= MAX_REGISTERS:
        raise ProgramError(f"registers: expected an integer from 0 to {MAX_REGISTERS}")
    for key in ("constants", "data"):
        values = program.get(key, [])
        if not isinstance(values, list) or not all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x)
                for x in values):
            raise ProgramError(f"{key}: expected a list of finite numbers")
    if len(program.get("constants", [])) > registers:
        raise ProgramError("more constants than registers")
    code = program.get("code")
    if not isinstance(code, list) or len(code) > MAX_INSTRUCTIONS:
        raise ProgramError(f"code: expected a list of at most {MAX_INSTRUCTIONS} instructions")
    n_data = len(program.get("data", []))
    for k, ins in enumerate(code):
        if not isinstance(ins, list) or len(ins) != SLOTS + 1 or not all(
                isinstance(x, int) and not isinstance(x, bool) for x in ins):
            raise ProgramError(f"code[{k}]: expected {SLOTS + 1} integers")
        if ins[0] not in SPECS:
            raise ProgramError(f"code[{k}]: unknown opcode {ins[0]} (a newer Snell's?)")
        name, slots = SPECS[ins[0]][:2]
        for s, (letter, value) in enumerate(zip(slots, ins[1:]), start=1):
            where = f"code[{k}] ({name.split(':')[0]}) slot {s}"
            _check_slot(where, letter, value, registers, n_data,
                        _literal_limit(ins[0], s, n_images, n_texcoords))
            if letter == "d" and not (s < SLOTS and slots[s] == "i" and ins[s + 1] >= 0
                                      and value + ins[s + 1] <= n_data):
                raise ProgramError(f"{where}: data offset {value} and the count after it "
                                   f"reach past the program's {n_data} values")


def _check_slot(where, letter, value, registers, n_data, limit):
    if letter in "wn" and value == -1:
        return
    if letter in WIDTH:
        if not 0 <= value <= registers - WIDTH[letter]:
            raise ProgramError(f"{where}: register {value} outside the program's {registers}")
    elif letter == "d":
        if not 0 <= value <= n_data:
            raise ProgramError(f"{where}: data offset {value} outside its {n_data} values")
    elif letter == "-":
        if value != 0:
            raise ProgramError(f"{where}: unused slot holds {value}")
    elif letter == "i":
        if limit is not None and not 0 <= value < limit:
            raise ProgramError(f"{where}: {value} is not from 0 to {limit - 1}")


def _literal_limit(op, slot, n_images, n_texcoords):
    """The bound on an instruction's literal from its SPECS entry's limits (None: any integer
    is safe)."""
    spec = SPECS[op]
    limit = spec[2].get(slot) if len(spec) > 2 else None
    return {"images": n_images, "texcoords": n_texcoords}.get(limit, limit)


def program_flags(program: dict) -> int:
    """A program's Programs.flags."""
    flags = 0
    consts = program.get("constants", [])
    for ins in program["code"]:
        if ins[0] == closures.TRANSPARENT_BSDF:
            flags |= MAY_BE_TRANSPARENT
        elif ins[0] == closures.HOLDOUT:
            flags |= HAS_HOLDOUT
        elif ins[0] == closures.PRINCIPLED:
            # Alpha is a constant of the block unless an instruction writes it (a link).
            alpha = ins[2] + closures.P_ALPHA
            written = any(other[1] == alpha for other in program["code"]
                          if other[0] != closures.PRINCIPLED)
            if written or not (alpha < len(consts) and consts[alpha] >= 1.0):
                flags |= MAY_BE_TRANSPARENT
    if program.get("emission_varies"):
        flags |= EMISSION_VARIES
    return flags


def has_holdout(materials: list) -> bool:
    """Whether any of a scene's materials (scene format) is a program with a Holdout."""
    return any(m.get("kind") == "program" and program_flags(m["program"]) & HAS_HOLDOUT
               for m in materials)


def program_tables(programs: list) -> Programs:
    """The Programs of a scene's materials (None for a material without a program)."""
    code, consts, data = [], [], []
    m = len(programs)
    start, length = np.zeros(m, np.int64), np.zeros(m, np.int64)
    const_start, const_length = np.zeros(m, np.int64), np.zeros(m, np.int64)
    flags = np.zeros(m, np.int64)
    for i, program in enumerate(programs):
        if program is None:
            continue
        rows = np.array(program["code"], np.int64).reshape(-1, SLOTS + 1)
        # Data offsets are rebased onto the scene's one data array.
        for op, spec in SPECS.items():
            slots = spec[1]
            for s, letter in enumerate(slots, start=1):
                if letter == "d":
                    rows[rows[:, 0] == op, s] += len(data)
        start[i], length[i] = len(code), len(rows)
        const_start[i], const_length[i] = len(consts), len(program.get("constants", []))
        flags[i] = program_flags(program)
        code.extend(rows)
        consts.extend(program.get("constants", []))
        data.extend(program.get("data", []))
    return Programs(np.array(code, np.int64).reshape(-1, SLOTS + 1),
                    np.array(consts, np.float64), np.array(data, np.float64), start, length,
                    const_start, const_length, flags, np.zeros((0, 3, 3)), np.full(2, 1e-3))


def new_registers() -> np.ndarray:
    """Scratch registers for run: MAX_REGISTERS and the closures' totals."""
    return np.zeros(MAX_REGISTERS + closures.TOTALS)


@jit
def run(mats, m, regs, hit, lobes, tables, has_normals):
    """Run material m's program at a hit: its closures' lobes go into `lobes` (their number is
    returned), its emission, transparency and holdout into regs[MAX_REGISTERS:] (closures'
    TOTAL_*). regs: scratch of MAX_REGISTERS + closures.TOTALS.

    hit: (point, geometric and shading normals facing the ray, direction to the viewer,
    entering, triangle, b1, b2, Light Path flags (1 << inputs.LP_*), depth, ray length)."""
    prog = mats.programs
    c0 = prog.const_start[m]
    for k in range(prog.const_length[m]):
        regs[k] = prog.consts[c0 + k]
    for k in range(closures.TOTALS):
        regs[MAX_REGISTERS + k] = 0.0
    count = 0
    center = hit                # the hit itself, which OFFSET moves and RESTORE gives back
    first = prog.start[m]
    for k in range(first, first + prog.length[m]):
        ins = prog.code[k]
        op = ins[0]
        if op <= closures.LAST:
            count = closures.execute(ins, regs, MAX_REGISTERS, hit, lobes, count, tables,
                                     has_normals)
        elif op <= inputs.LAST:
            inputs.execute(ins, regs, hit, mats)
        elif op <= object_inputs.LAST:
            object_inputs.execute(ins, regs, hit, mats)
        elif op < 200:
            math_nodes.execute(ins, regs, prog.data)
        elif op < 300:
            color_nodes.execute(ins, regs, prog.data)
        elif op < normals.FIRST:
            procedural_textures.execute(ins, regs, prog.data)
        elif op <= normals.LAST:
            normals.execute(ins, regs, hit, mats)
        elif op == bump.OFFSET:
            hit = bump.moved_hit(center, ins[1], regs[ins[2]], mats)
        elif op == bump.RESTORE:
            hit = center
        elif op == bump.SET_NORMAL:
            hit = bump.with_normal(center, (regs[ins[1]], regs[ins[1] + 1], regs[ins[1] + 2]))
            center = hit
            # Closures bend a normal that is not the mesh's, as for a linked normal.
            has_normals = True
        else:
            bump.execute(ins, regs, hit, mats)
    normals.mark_smooth_normal(lobes, count, hit[2])
    return count


@jit
def total(regs, at):
    """One of the totals run leaves (closures.TOTAL_EMISSION or TOTAL_TRANSPARENCY) as RGB."""
    k = MAX_REGISTERS + at
    return (regs[k], regs[k + 1], regs[k + 2])
