"""The value and colour node families' rows (tracer/shader/math_nodes.py, color_nodes.py): SPECS
are well formed and inside each family's opcode range, and execute wires every opcode's slots
to its formula (each row run on random registers gives what the scalar function gives on the
same values). The formulas themselves are held against Cycles in
tests/validation/test_value_nodes.py."""
from __future__ import annotations

import numpy as np
import pytest

from snell.tracer.shader import color_nodes as cn
from snell.tracer.shader import math_nodes as mn

FAMILIES = ((mn, range(100, 200)), (cn, range(200, 300)))
WIDTH = {"f": 1, "v": 3}


@pytest.mark.parametrize("family,codes", FAMILIES)
def test_specs_are_well_formed(family, codes):
    """Each opcode is in its family's range, named, with 7 slots of 'fvid-' (a 'd' followed by
    its count, an 'i'), every enum's literal bounded; execute leaves a row of an unknown opcode
    alone."""
    for code, spec in family.SPECS.items():
        name, slots = spec[:2]
        limits = spec[2] if len(spec) > 2 else {}
        assert code in codes
        assert ":" in name and len(slots) == 7 and set(slots) <= set("fvid-"), (code, slots)
        counts = {k + 2 for k, s in enumerate(slots) if s == "d"}
        assert all(slots[k - 1] == "i" for k in counts)
        assert {k + 1 for k, s in enumerate(slots) if s == "i"} - counts == set(limits), name
    regs = np.arange(8.0)
    family.execute(np.array([codes[-1], 0, 1, 2, 3, 4, 5, 6], np.int64), regs, regs)
    assert np.array_equal(regs, np.arange(8.0))


def _row(rng, code, slots, literals, data_offset=0):
    """A row of opcode code: literal ints from `literals` in the 'i' slots (a data count too),
    the data offset in 'd', and registers for 'f'/'v' slots laid out without overlap."""
    row = np.zeros(8, np.int64)
    row[0] = code
    nxt, lit = 0, iter(literals)
    for k, s in enumerate(slots, start=1):
        if s == "i":
            row[k] = next(lit)
        elif s == "d":
            row[k] = data_offset
        elif s in WIDTH:
            row[k] = nxt
            nxt += WIDTH[s]
    return row, nxt


def _values(regs, row, slots):
    """The row's register values: a float per 'f', a 3-tuple per 'v'."""
    out = []
    for k, s in enumerate(slots, start=1):
        if s == "f":
            out.append(float(regs[row[k]]))
        elif s == "v":
            out.append(tuple(float(v) for v in regs[row[k]:row[k] + 3]))
    return out


# opcode: (literal ints to try, the formula of (literals, input values) -> output values); the
# inputs are the row's f/v slots but the last (or last two for two outputs).
def _ramp_data():
    rng = np.random.default_rng(3)
    return np.concatenate([[-0.2, 1.3], rng.random(4 * 257)])


DATA = _ramp_data()
CASES = {
    mn.MATH: ([(op, cl) for op in range(len(mn.MATH_OPERATIONS)) for cl in (0, 1)], 1,
              lambda L, a, b, c: [mn.math_node(L[0], L[1] != 0, a, b, c)]),
    mn.VECTOR_MATH: ([(op,) for op in range(len(mn.VECTOR_MATH_OPERATIONS))], 2,
                     lambda L, a, b, c, s: list(mn.vector_math(L[0], a, b, c, s))),
    mn.CLAMP: ([(0,), (1,)], 1, lambda L, v, lo, hi: [mn.clamp_node(L[0], v, lo, hi)]),
    mn.MAP_RANGE: ([(t, cl) for t in range(4) for cl in (0, 1)], 1,
                   lambda L, p, q: [mn.map_range(L[0], L[1] != 0, *p, *q)]),
    mn.VECTOR_MAP_RANGE: ([(t,) for t in range(4)], 1, lambda L, v, lo, hi, st: [tuple(
        mn.map_range_factor(L[0], v[k], lo[k], hi[k], st[k]) for k in range(3))]),
    mn.VECTOR_MAP_APPLY: ([(0,), (1,)], 1, lambda L, f, lo, hi: [tuple(
        mn.map_range_apply(L[0] != 0, f[k], lo[k], hi[k]) for k in range(3))]),
    mn.MAPPING: ([(t,) for t in range(4)], 1, lambda L, v, lo, r, s: [mn.mapping(L[0], v, lo,
                                                                                 r, s)]),
    mn.SEPARATE_XYZ: ([()], 3, lambda L, v: list(v)),
    mn.COMBINE_XYZ: ([()], 1, lambda L, x, y, z: [(x, y, z)]),
    cn.MIX_COLOR: ([(k, cf, cr) for k in range(len(cn.BLEND_TYPES)) for cf in (0, 1)
                    for cr in (0, 1)], 1,
                   lambda L, t, a, b: [cn.mix_color(L[0], L[1] != 0, L[2] != 0, t, a, b)]),
    cn.MIX_FLOAT: ([(0,), (1,)], 1, lambda L, t, a, b: [cn.mix_float(L[0] != 0, t, a, b)]),
    cn.MIX_VECTOR: ([(0,), (1,)], 1, lambda L, t, a, b: [cn.mix_vector(L[0] != 0, t, a, b)]),
    cn.MIX_VECTOR_NONUNIFORM: ([(0,), (1,)], 1, lambda L, t, a, b: [
        cn.mix_vector_nonuniform(L[0] != 0, t, a, b)]),
    cn.INVERT: ([()], 1, lambda L, f, c: [cn.invert(f, c)]),
    cn.HUE_SAT: ([()], 1, lambda L, h, s, v, f, c: [cn.hue_saturation_value(h, s, v, f, c)]),
    cn.GAMMA: ([()], 1, lambda L, g, c: [cn.gamma(c, g)]),
    cn.BRIGHT_CONTRAST: ([()], 1, lambda L, b, k, c: [cn.bright_contrast(c, b, k)]),
    cn.SEPARATE_COLOR: ([(m,) for m in range(3)], 3, lambda L, c: list(cn.separate_color(L[0],
                                                                                         c))),
    cn.COMBINE_COLOR: ([(m,) for m in range(3)], 1, lambda L, r, g, b: [
        cn.combine_color(L[0], (r, g, b))]),
    cn.RGB_TO_BW: ([()], 1, lambda L, c: [cn.rgb_to_bw(c)]),
    cn.BLACKBODY: ([()], 1, lambda L, t: [cn.blackbody(t)]),
    cn.WAVELENGTH: ([()], 1, lambda L, w: [cn.wavelength(w)]),
    cn.COLOR_RAMP: ([(i, 4 * 257) for i in (0, 1)], 2, lambda L, f: list(
        cn.color_ramp(DATA, 2, 257, L[0] != 0, f))),
    cn.RGB_CURVES: ([(e, 2 + 3 * 257) for e in (0, 1)], 1, lambda L, f, c: [
        cn.rgb_curves(DATA, 0, 257, L[0] != 0, f, c)]),
    cn.FLOAT_CURVE: ([(e, 2 + 257) for e in (0, 1)], 1, lambda L, f, v: [
        cn.float_curve(DATA, 0, 257, L[0] != 0, f, v)]),
}


@pytest.mark.parametrize("family,codes", FAMILIES)
def test_execute_wires_every_opcode_to_its_formula(family, codes):
    """Every opcode of SPECS, with each literal tried, on random registers: execute's outputs are
    the formula's. Teeth: execute writing Vector Math's Value 1e-9 off, or reading MIX_COLOR's
    clamp-result flag from its clamp-factor slot, fails this test (tried, both caught)."""
    rng = np.random.default_rng(7)
    for code, spec in family.SPECS.items():
        name, slots = spec[:2]
        literal_sets, n_out, formula = CASES[code]
        data_offset = 2 if code == cn.COLOR_RAMP else 0
        for literals in literal_sets:
            row, n_regs = _row(rng, code, slots, literals, data_offset)
            for _ in range(5):
                regs = rng.uniform(-1.5, 1.5, n_regs + 2)
                if code == cn.BLACKBODY:  # temperatures and wavelengths in their ranges
                    regs[row[1]] = abs(regs[row[1]]) * 8000.0
                elif code == cn.WAVELENGTH:
                    regs[row[1]] = regs[row[1]] * 100.0 + 500.0
                values = _values(regs, row, slots)
                inputs = values[:-n_out]
                expected = formula(literals, *inputs)
                family.execute(row, regs, DATA)
                got = _values(regs, row, slots)[-n_out:]
                for e, g in zip(expected, got):
                    assert np.allclose(e, g, rtol=1e-12, atol=1e-12, equal_nan=True), \
                        (name, literals, e, g)


class _Recorder:
    """A stand-in Compiler that records rows and warnings (inputs are fresh registers)."""

    def __init__(self):
        self.rows, self.warnings, self.size = [], [], 0

    def alloc(self, kind):
        self.size += 1 if kind == "float" else 3
        return self.size - (1 if kind == "float" else 3)

    def input(self, node, name, kind):
        return self.alloc(kind)

    def constant(self, value):
        return self.alloc("float" if np.ndim(value) == 0 else "vector")

    def emit(self, opcode, *slots):
        self.rows.append((opcode, *slots))

    def warn(self, node, what, instead, input=None):
        self.warnings.append((node.name, what, instead))


class _Node:
    def __init__(self, **props):
        self.name, self.inputs = "Node", []
        self.__dict__.update(props)


def test_unknown_modes_compile_with_a_warning():
    """A Math operation or blend mode from a newer Blender compiles as the first one (Add, Mix)
    with one warning naming it; a Mix of rotations warns and gives no output."""
    from snell.addon.export.shader import color_nodes as ce
    from snell.addon.export.shader import math_nodes as me
    c = _Recorder()
    out = me.compile_math(c, _Node(operation="CUBE_ROOT", use_clamp=False))
    assert set(out) == {"Value"} and c.rows[-1][:3] == (mn.MATH, mn.M_ADD, 0)
    assert c.warnings == [("Node", "operation CUBE_ROOT is not evaluated", "Add")]
    c = _Recorder()
    out = ce.compile_mix(c, _Node(data_type="RGBA", blend_type="PIN_LIGHT", clamp_factor=True,
                                  clamp_result=False))
    assert set(out) == {"Result_Color"} and c.rows[-1][:4] == (cn.MIX_COLOR, cn.B_MIX, 1, 0)
    assert c.warnings == [("Node", "blend mode PIN_LIGHT is not evaluated", "Mix")]
    c = _Recorder()
    assert ce.compile_mix(c, _Node(data_type="ROTATION", clamp_factor=True)) == {}
    assert len(c.warnings) == 1 and c.rows == []
