"""The value and colour nodes' formulas (tracer/shader/math_nodes.py, color_nodes.py) held
against Cycles point by point: each node is rendered by Cycles as the emission of the probe plane
(support/node_probe.py, 16 x 16 pixels, three outputs per render through Combine XYZ) with inputs
that vary over the plane, and the jitted formula, evaluated at the inputs Cycles had, must give
Cycles' value to float32 precision (support/node_compare.py: relative and absolute 1e-5, and a
pixel at a jump of the formula only if a few float32 ulps of its inputs reach Cycles' value).

Two input sets: "smooth" (a = x, b = y over [-3.75, 3.75], c = 0.5 x + 0.3 y + 0.1) and "int"
(a = x, b = floor(y) in -4..3, c = floor(x / 2) in -2..1), which reach zero divisors, negative
bases with whole exponents, empty ranges and equal arguments. Colours are 0.15 a + 0.5 and the
like (slightly outside [0, 1] at the edges), factors 0.2 a + 0.5 (in [-0.25, 1.25]).

Each test's teeth are a second comparison on the same Cycles images with a deliberate error,
which must fail; the numbers measured are in the test's docstring.
"""
from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support import node_compare as nc  # noqa: E402

from snell.addon.export.shader import color_nodes as color_export  # noqa: E402
from snell.tracer.shader import color_nodes as cn  # noqa: E402
from snell.tracer.shader import math_nodes as mn  # noqa: E402


class Probe:
    """Cycles' renders of this module, each made once."""

    def __init__(self):
        self._renders = {}
        self._inputs = {}

    def inputs(self, kind):
        if kind not in self._inputs:
            self._inputs[kind] = nc.inputs(kind)
        return self._inputs[kind]

    def render(self, key, build, kind):
        if (key, kind) not in self._renders:
            self._renders[(key, kind)] = nc.render(build, kind)
        return self._renders[(key, kind)]


@pytest.fixture(scope="module")
def probe():
    return Probe()


def _node(tree, idname, inputs=(), **props):
    """A new node with props set and inputs (index or name: socket to link or value) given."""
    node = tree.nodes.new(idname)
    for key, value in props.items():
        setattr(node, key, value)
    for key, value in inputs:
        if hasattr(value, "is_output"):
            tree.links.new(value, node.inputs[key])
        else:
            node.inputs[key].default_value = value
    return node


def _madd(tree, s, scale, offset):
    return _node(tree, "ShaderNodeMath", [(0, s), (1, scale), (2, offset)],
                 operation="MULTIPLY_ADD").outputs[0]


def _vec(tree, x, y, z):
    return _node(tree, "ShaderNodeCombineXYZ", [(0, x), (1, y), (2, z)]).outputs[0]


def _channels(tree, vector):
    sep = _node(tree, "ShaderNodeSeparateXYZ", [(0, vector)])
    return list(sep.outputs[:3])


def _assert_matches(m, what, max_jumps=0.03):
    assert m.ok(max_jumps), f"{what}: {m}"


def _assert_caught(m, what):
    assert not m.ok(), f"{what} was not caught: {m}"


# --- Math -------------------------------------------------------------------------------------

def _math_outputs(probe, kind, ops, use_clamp=False):
    def build(tree, a, b, c):
        return [_node(tree, "ShaderNodeMath", [(0, a), (1, b), (2, c)], operation=op,
                      use_clamp=use_clamp).outputs[0] for op in ops]
    return probe.render(("math", tuple(ops), use_clamp), build, kind)


def _math_formula(op, use_clamp=False):
    code = mn.MATH_OPERATIONS.index(op)
    return lambda a, b, c: mn.math_node(code, use_clamp, a, b, c)


@pytest.mark.parametrize("kind", nc.KINDS)
def test_math_operations_match_cycles(probe, kind):
    """Every Math operation, on both input sets: measured worst error 1.9e-5 (Degrees of 215,
    relative 9e-8), no pixel needing the jump allowance. Teeth: Modulo's formula for Floored
    Modulo, Trunc's for Floor, Ceil's for Round, Power with the exponent off by 0.05 and
    Smooth Min's distance off by 5%: each caught."""
    a, b, c = probe.inputs(kind)
    ops = mn.MATH_OPERATIONS
    for k in range(0, len(ops), 3):
        group = ops[k:k + 3]
        got = _math_outputs(probe, kind, group)
        for j, op in enumerate(group):
            _assert_matches(nc.match(_math_formula(op), (a, b, c), got[:, j]), f"{kind} {op}")
    got = {op: _math_outputs(probe, kind, ops[k:k + 3])[:, ops[k:k + 3].index(op)]
           for k in range(0, len(ops), 3) for op in ops[k:k + 3]}
    wrong = [("FLOORED_MODULO", _math_formula("MODULO")), ("FLOOR", _math_formula("TRUNC")),
             ("ROUND", _math_formula("CEIL"))]
    power = mn.MATH_OPERATIONS.index("POWER")
    smin = mn.MATH_OPERATIONS.index("SMOOTH_MIN")
    wrong += [("POWER", lambda a, b, c: mn.math_node(power, False, a, b + 0.05, c)),
              ("SMOOTH_MIN", lambda a, b, c: mn.math_node(smin, False, a, b, c * 1.05))]
    for op, formula in wrong:
        _assert_caught(nc.match(formula, (a, b, c), got[op]), f"{kind}: a wrong {op}")


def test_math_clamp_matches_cycles(probe):
    """Math's Clamp option (Cycles adds a Clamp node to [0, 1]) on three operations whose results
    leave [0, 1]. Teeth: the unclamped formula is caught."""
    a, b, c = probe.inputs("smooth")
    group = ("MULTIPLY", "SINE", "EXPONENT")
    got = _math_outputs(probe, "smooth", group, use_clamp=True)
    for j, op in enumerate(group):
        _assert_matches(nc.match(_math_formula(op, True), (a, b, c), got[:, j]), op)
        _assert_caught(nc.match(_math_formula(op, False), (a, b, c), got[:, j]),
                       f"{op} unclamped")


# --- Vector Math --------------------------------------------------------------------------------

def _vector_args(a, b, c):
    """Vector Math's inputs in these tests: A = (a, b, c), B = (c, a, b), C = (b, c, a),
    Scale = c."""
    return (np.stack([a, b, c], 1), np.stack([c, a, b], 1), np.stack([b, c, a], 1), c)


def _vector_math_render(probe, kind, op):
    def build(tree, a, b, c):
        node = _node(tree, "ShaderNodeVectorMath",
                     [(0, _vec(tree, a, b, c)), (1, _vec(tree, c, a, b)), (2, _vec(tree, b, c, a)),
                      (3, c)], operation=op)
        if op in ("DOT_PRODUCT", "DISTANCE", "LENGTH"):
            return [node.outputs["Value"]]
        return node.outputs["Vector"]
    return probe.render(("vmath", op), build, kind)


def _vector_formula(op, channel, value_out=False, scale_error=1.0):
    code = mn.VECTOR_MATH_OPERATIONS.index(op)

    def formula(A, B, C, s):
        value, vector = mn.vector_math(code, A, B, C, s * scale_error)
        return value if value_out else vector[channel]
    return formula


@pytest.mark.parametrize("kind", nc.KINDS)
def test_vector_math_operations_match_cycles(probe, kind):
    """Every Vector Math operation, each output channel, on both input sets (Refract's ratio is
    c, so its total reflection is reached). Teeth: Refract with the ratio off by 5%, Project's
    formula for Reflect, and Snap's for Modulo: each caught."""
    a, b, c = probe.inputs(kind)
    args = _vector_args(a, b, c)
    for op in mn.VECTOR_MATH_OPERATIONS:
        got = _vector_math_render(probe, kind, op)
        if op in ("DOT_PRODUCT", "DISTANCE", "LENGTH"):
            _assert_matches(nc.match(_vector_formula(op, 0, True), args, got[:, 0]),
                            f"{kind} {op}")
            continue
        for ch in range(3):
            _assert_matches(nc.match(_vector_formula(op, ch), args, got[:, ch]),
                            f"{kind} {op} channel {ch}")
    refract = _vector_math_render(probe, kind, "REFRACT")
    _assert_caught(nc.match(_vector_formula("REFRACT", 0, scale_error=1.05), args,
                            refract[:, 0]), "refract ratio off by 5%")
    reflect = _vector_math_render(probe, kind, "REFLECT")
    _assert_caught(nc.match(_vector_formula("PROJECT", 1), args, reflect[:, 1]),
                   "project for reflect")
    modulo = _vector_math_render(probe, kind, "MODULO")
    _assert_caught(nc.match(_vector_formula("SNAP", 0), args, modulo[:, 0]),
                   "snap for modulo")


# --- Clamp, Map Range, Mapping, Separate/Combine XYZ ----------------------------------------------

@pytest.mark.parametrize("kind", nc.KINDS)
def test_clamp_matches_cycles(probe, kind):
    """Clamp Min Max and Range with min = c and max = b, which cross (min > max) on part of the
    plane. Teeth: Min Max's formula for Range is caught."""
    a, b, c = probe.inputs(kind)

    def build(tree, a_, b_, c_):
        return [_node(tree, "ShaderNodeClamp", [(0, a_), (1, c_), (2, b_)],
                      clamp_type=t).outputs[0] for t in mn.CLAMP_TYPES]
    got = probe.render("clamp", build, kind)
    for j in range(2):
        _assert_matches(nc.match(lambda a, b, c, j=j: mn.clamp_node(j, a, c, b), (a, b, c),
                                 got[:, j]), mn.CLAMP_TYPES[j])
    _assert_caught(nc.match(lambda a, b, c: mn.clamp_node(mn.CLAMP_MINMAX, a, c, b), (a, b, c),
                            got[:, 1]), "Min Max for Range")


def _map_range_render(probe, kind, interpolation, use_clamp):
    """Float Map Range of value a from [c, b] to [0.5 b, -1.5] (reversed for b > -3) in 3 steps
    (int: c steps, zero and negative included); channel 2: the same with From Min = From Max."""
    def build(tree, a, b, c):
        half_b = _madd(tree, b, 0.5, 0.0)
        steps = c if kind == "int" else 3.0
        out = []
        for lo, hi in ((c, b), (b, b)):
            out.append(_node(tree, "ShaderNodeMapRange",
                             [(0, a), (1, lo), (2, hi), (3, half_b), (4, -1.5), (5, steps)],
                             interpolation_type=interpolation, clamp=use_clamp).outputs[0])
        return out
    return probe.render(("maprange", interpolation, use_clamp), build, kind)


def _map_range_formula(interpolation, use_clamp, kind, same=False, to_max=-1.5):
    t = mn.MAP_RANGE_TYPES.index(interpolation)

    def formula(a, b, c):
        steps = c if kind == "int" else 3.0
        return mn.map_range(t, use_clamp, a, b if same else c, b, 0.5 * b, to_max, steps)
    return formula


@pytest.mark.parametrize("kind", nc.KINDS)
def test_map_range_matches_cycles(probe, kind):
    """Float Map Range, every interpolation, Clamp off and on, an empty from-range too. Teeth:
    To Max off by 0.05, and Smooth Step's formula for Smoother Step: caught."""
    a, b, c = probe.inputs(kind)
    for interpolation in mn.MAP_RANGE_TYPES:
        for use_clamp in (False, True):
            got = _map_range_render(probe, kind, interpolation, use_clamp)
            what = f"{kind} {interpolation} clamp={use_clamp}"
            _assert_matches(nc.match(_map_range_formula(interpolation, use_clamp, kind),
                                     (a, b, c), got[:, 0]), what)
            _assert_matches(nc.match(_map_range_formula(interpolation, use_clamp, kind, True),
                                     (a, b, c), got[:, 1]), what + " empty range")
    got = _map_range_render(probe, kind, "LINEAR", False)
    _assert_caught(nc.match(_map_range_formula("LINEAR", False, kind, to_max=-1.45), (a, b, c),
                            got[:, 0]), "To Max off by 0.05")
    got = _map_range_render(probe, kind, "SMOOTHERSTEP", False)
    _assert_caught(nc.match(_map_range_formula("SMOOTHSTEP", False, kind), (a, b, c),
                            got[:, 0]), "smooth step for smoother step")


@pytest.mark.parametrize("kind", nc.KINDS)
def test_vector_map_range_matches_cycles(probe, kind):
    """Vector Map Range, every interpolation, Clamp off and on (which Cycles ignores for the
    smooth steps): value (a, b, c) from [(c, a, b), (b, c, a)] to [(a, b, c), (b, c, a)] in
    (c, a, b) steps. Teeth: To Min off by 0.05 is caught."""
    a, b, c = probe.inputs(kind)
    V, L, H = np.stack([a, b, c], 1), np.stack([c, a, b], 1), np.stack([b, c, a], 1)
    for t, interpolation in enumerate(mn.MAP_RANGE_TYPES):
        for use_clamp in (False, True):
            def build(tree, a_, b_, c_, interpolation=interpolation, use_clamp=use_clamp):
                n = _node(tree, "ShaderNodeMapRange", data_type="FLOAT_VECTOR",
                          interpolation_type=interpolation, clamp=use_clamp)
                lo, hi = _vec(tree, c_, a_, b_), _vec(tree, b_, c_, a_)
                # inputs 6-11: Vector, From Min, From Max, To Min, To Max, Steps (FLOAT3)
                tree.links.new(_vec(tree, a_, b_, c_), n.inputs[6])
                tree.links.new(lo, n.inputs[7])
                tree.links.new(hi, n.inputs[8])
                tree.links.new(_vec(tree, a_, b_, c_), n.inputs[9])
                tree.links.new(_vec(tree, b_, c_, a_), n.inputs[10])
                tree.links.new(lo, n.inputs[11])
                return n.outputs["Vector"]
            got = probe.render(("vmaprange", interpolation, use_clamp), build, kind)
            for ch in range(3):
                def formula(v, lo, hi, ch=ch, t=t, use_clamp=use_clamp, error=0.0):
                    f = mn.map_range_factor(t, v[ch], lo[ch], hi[ch], lo[ch])
                    clamp = use_clamp and t in (mn.RANGE_LINEAR, mn.RANGE_STEPPED)
                    return mn.map_range_apply(clamp, f, v[ch] + error, hi[ch])
                what = f"{kind} vector {interpolation} clamp={use_clamp} channel {ch}"
                _assert_matches(nc.match(formula, (V, L, H), got[:, ch]), what)
                if t == 0 and use_clamp and ch == 0:
                    _assert_caught(nc.match(lambda v, lo, hi: formula(v, lo, hi, error=0.05),
                                            (V, L, H), got[:, ch]), "To Min off by 0.05")


@pytest.mark.parametrize("kind", nc.KINDS)
def test_mapping_matches_cycles(probe, kind):
    """Mapping, every type, with linked location (0.3 (c, a, b)), rotation (0.5 (b, c, a)) and
    scale ((a, c, b); zero on the int set). Teeth: the rotation's transpose for Point, and a
    rotation off by 0.05 rad: caught."""
    a, b, c = probe.inputs(kind)
    V = np.stack([a, b, c], 1)
    loc, rot, scale = 0.3 * np.stack([c, a, b], 1), 0.5 * np.stack([b, c, a], 1), \
        np.stack([a, c, b], 1)
    for t, vector_type in enumerate(mn.MAPPING_TYPES):
        def build(tree, a_, b_, c_, vector_type=vector_type):
            n = _node(tree, "ShaderNodeMapping", vector_type=vector_type)
            tree.links.new(_vec(tree, a_, b_, c_), n.inputs[0])
            tree.links.new(_vec(tree, *[_madd(tree, s, 0.3, 0.0) for s in (c_, a_, b_)]),
                           n.inputs[1])
            tree.links.new(_vec(tree, *[_madd(tree, s, 0.5, 0.0) for s in (b_, c_, a_)]),
                           n.inputs[2])
            tree.links.new(_vec(tree, a_, c_, b_), n.inputs[3])
            return n.outputs[0]
        got = probe.render(("mapping", vector_type), build, kind)
        for ch in range(3):
            def formula(v, lo, r, s, t=t, ch=ch):
                return mn.mapping(t, v, lo, r, s)[ch]
            _assert_matches(nc.match(formula, (V, loc, rot, scale), got[:, ch]),
                            f"{kind} {vector_type} channel {ch}")
        if vector_type == "POINT":
            _assert_caught(nc.match(lambda v, lo, r, s: mn.mapping(mn.MAPPING_TEXTURE, v, lo, r,
                                                                   s)[0],
                                    (V, loc, rot, scale), got[:, 0]), "Texture for Point")
            _assert_caught(nc.match(lambda v, lo, r, s: mn.mapping(
                mn.MAPPING_POINT, v, lo, (r[0] + 0.05, r[1], r[2]), s)[1],
                (V, loc, rot, scale), got[:, 1]), "rotation off by 0.05")


def test_separate_and_combine_xyz_match_cycles(probe):
    """Separate XYZ of Combine XYZ (b, c, a) gives back b, c, a in that order; the
    execute rows of both give the same. Teeth: a swapped order is caught."""
    a, b, c = probe.inputs("smooth")

    def build(tree, a_, b_, c_):
        return _channels(tree, _vec(tree, b_, c_, a_))
    got = probe.render("sepcomb", build, "smooth")
    regs = np.zeros(10)
    ins = np.zeros(8, np.int64)

    def through_rows(x, y, z, ch):
        regs[0:3] = (x, y, z)
        ins[:] = (mn.COMBINE_XYZ, 1, 2, 0, 3, 0, 0, 0)
        mn.execute(ins, regs, regs)
        ins[:] = (mn.SEPARATE_XYZ, 3, 6, 7, 8, 0, 0, 0)
        mn.execute(ins, regs, regs)
        return regs[6 + ch]
    for ch in range(3):
        _assert_matches(nc.match(lambda x, y, z, ch=ch: through_rows(x, y, z, ch), (a, b, c),
                                 got[:, ch]), f"channel {ch}")
    _assert_caught(nc.match(lambda x, y, z: through_rows(x, y, z, 1), (a, b, c), got[:, 0]),
                   "swapped channels")
