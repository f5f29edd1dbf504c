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
    Smooth Min's distance off by 5%: each caught (measured: 128/128/128/128/40 of 256 pixels
    wrong on the smooth set, 112/128/128/256/12 on the int set)."""
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
    leave [0, 1]. Teeth: the unclamped formula is caught (220, 128, 128 pixels wrong)."""
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
    formula for Reflect, and Snap's for Modulo: each caught (245/256/256 pixels wrong on the
    smooth set, 182/248/192 on the int set)."""
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
    plane. Teeth: Min Max's formula for Range is caught (116 and 108 pixels wrong)."""
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
    To Max off by 0.05, and Smooth Step's formula for Smoother Step: caught (252/16 pixels
    wrong on the smooth set, 224/56 on the int set)."""
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
    (c, a, b) steps. One pixel of the 512 x 6 compared needed the jump allowance (Stepped, a
    factor at a step). Teeth: To Min off by 0.05 is caught (229 and 224 pixels wrong)."""
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
    rotation off by 0.05 rad: caught (256/253 pixels wrong on the smooth set, 256/168 on the
    int set)."""
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
    execute rows of both give the same. Teeth: a swapped order is caught (256 pixels)."""
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


# --- colour nodes -------------------------------------------------------------------------------

def _colour_sockets(tree, a, b, c):
    """The colour tests' inputs: colours A = 0.15 (a, b, c) + 0.5 and B = (0.13 b + 0.45,
    0.25 c + 0.5, 0.12 a + 0.55) (zero on the int set), the wide colour W = 0.3 (a, b, c) + 0.5,
    and factors F = 0.2 (a, b, c) + 0.5 (F[0] the factor, all three the non-uniform one)."""
    return {
        "A": _vec(tree, *[_madd(tree, s, 0.15, 0.5) for s in (a, b, c)]),
        "B": _vec(tree, _madd(tree, b, 0.13, 0.45), _madd(tree, c, 0.25, 0.5),
                  _madd(tree, a, 0.12, 0.55)),
        "W": _vec(tree, *[_madd(tree, s, 0.3, 0.5) for s in (a, b, c)]),
        "F": _vec(tree, *[_madd(tree, s, 0.2, 0.5) for s in (a, b, c)]),
    }


def _colour_inputs(probe, kind):
    """Cycles' values of A, B, W and F, each (N, 3)."""
    return {name: probe.render(("colour input", name),
                               lambda tree, a, b, c, name=name:
                               _colour_sockets(tree, a, b, c)[name],
                               kind)
            for name in ("A", "B", "W", "F")}


def _colour_render(probe, kind, key, make):
    """Cycles' (N, 3) output of make(tree, sockets, a, b, c) -> a socket."""
    def build(tree, a, b, c):
        return make(tree, _colour_sockets(tree, a, b, c), a, b, c)
    return probe.render(key, build, kind)


def _check_channels(formula, args, got, what, max_jumps=0.03):
    for ch in range(3):
        _assert_matches(nc.match(lambda *x, ch=ch: formula(*x)[ch], args, got[:, ch]),
                        f"{what} channel {ch}", max_jumps)


def _mix_node(tree, s, blend, clamp_factor=False, clamp_result=False):
    n = _node(tree, "ShaderNodeMix", data_type="RGBA", blend_type=blend,
              clamp_factor=clamp_factor, clamp_result=clamp_result)
    tree.links.new(_channels(tree, s["F"])[0], n.inputs[0])
    tree.links.new(s["A"], n.inputs[6])  # A_Color
    tree.links.new(s["B"], n.inputs[7])  # B_Color
    return n.outputs[2]  # Result_Color


@pytest.mark.parametrize("kind", nc.KINDS)
def test_mix_color_blend_modes_match_cycles(probe, kind):
    """The Mix node (Color), every blend mode, factor in [-0.25, 1.25] unclamped; Clamp Factor
    and Clamp Result on three modes; the legacy MixRGB (factor always clamped) with and without
    Clamp. Teeth: the factor off by 0.05 on Overlay, Screen's formula for Soft Light, and MixRGB
    without its factor clamp: caught (252/256/96 pixels wrong on the smooth set, 192/256/96 on
    the int set)."""
    col = _colour_inputs(probe, kind)
    args = (col["F"][:, 0], col["A"], col["B"])
    for k, blend in enumerate(cn.BLEND_TYPES):
        got = _colour_render(probe, kind, ("mix", blend),
                             lambda tree, s, *_, blend=blend: _mix_node(tree, s, blend))
        _check_channels(lambda f, A, B, k=k: cn.mix_color(k, False, False, f, A, B), args, got,
                        f"{kind} {blend}")
    for blend in ("LINEAR_LIGHT", "DODGE", "ADD"):
        k = cn.BLEND_TYPES.index(blend)
        got = _colour_render(probe, kind, ("mix clamped", blend),
                             lambda tree, s, *_, blend=blend: _mix_node(tree, s, blend, True, True))
        _check_channels(lambda f, A, B, k=k: cn.mix_color(k, True, True, f, A, B), args, got,
                        f"{kind} {blend} clamped")
    for blend, use_clamp in (("LINEAR_LIGHT", False), ("SUBTRACT", True)):
        k = cn.BLEND_TYPES.index(blend)

        def make(tree, s, *_, blend=blend, use_clamp=use_clamp):
            n = _node(tree, "ShaderNodeMixRGB", blend_type=blend, use_clamp=use_clamp)
            tree.links.new(_channels(tree, s["F"])[0], n.inputs[0])
            tree.links.new(s["A"], n.inputs[1])
            tree.links.new(s["B"], n.inputs[2])
            return n.outputs[0]
        got = _colour_render(probe, kind, ("mixrgb", blend, use_clamp), make)
        _check_channels(lambda f, A, B, k=k, u=use_clamp: cn.mix_color(k, True, u, f, A, B),
                        args, got, f"{kind} MixRGB {blend} clamp={use_clamp}")
        if not use_clamp:
            _assert_caught(nc.match(lambda f, A, B, k=k: cn.mix_color(k, False, False, f, A, B)[0],
                                    args, got[:, 0]), "MixRGB without its factor clamp")
    overlay = cn.BLEND_TYPES.index("OVERLAY")
    got = _colour_render(probe, kind, ("mix", "OVERLAY"), None)
    _assert_caught(nc.match(lambda f, A, B: cn.mix_color(overlay, False, False, f + 0.05, A, B)[1],
                            args, got[:, 1]), "Overlay's factor off by 0.05")
    got = _colour_render(probe, kind, ("mix", "SOFT_LIGHT"), None)
    screen = cn.BLEND_TYPES.index("SCREEN")
    _assert_caught(nc.match(lambda f, A, B: cn.mix_color(screen, False, False, f, A, B)[0],
                            args, got[:, 0]), "Screen for Soft Light")


@pytest.mark.parametrize("kind", nc.KINDS)
def test_mix_float_and_vector_match_cycles(probe, kind):
    """The Mix node's Float (factor clamped and not), Vector with a uniform factor and with a
    factor per component (clamped and not). Teeth: the unclamped formula where Cycles clamps,
    caught (96 pixels wrong on each set)."""
    col = _colour_inputs(probe, kind)
    F, A, B = col["F"], col["A"], col["B"]

    def make_float(tree, s, *_):
        out = []
        for clamp in (False, True):
            n = _node(tree, "ShaderNodeMix", data_type="FLOAT", clamp_factor=clamp)
            tree.links.new(_channels(tree, s["F"])[0], n.inputs[0])
            tree.links.new(_channels(tree, s["A"])[1], n.inputs[2])
            tree.links.new(_channels(tree, s["B"])[2], n.inputs[3])
            out.append(n.outputs[0])
        return _vec(tree, *out, out[0])
    got = _colour_render(probe, kind, "mix float", make_float)
    for j, clamp in enumerate((False, True)):
        _assert_matches(nc.match(lambda f, a, b, clamp=clamp: cn.mix_float(clamp, f, a, b),
                                 (F[:, 0], A[:, 1], B[:, 2]), got[:, j]), f"float clamp={clamp}")
    _assert_caught(nc.match(lambda f, a, b: cn.mix_float(False, f, a, b),
                            (F[:, 0], A[:, 1], B[:, 2]), got[:, 1]), "unclamped float factor")
    for mode in ("UNIFORM", "NON_UNIFORM"):
        for clamp in (False, True):
            def make(tree, s, *_, mode=mode, clamp=clamp):
                n = _node(tree, "ShaderNodeMix", data_type="VECTOR", factor_mode=mode,
                          clamp_factor=clamp)
                if mode == "UNIFORM":
                    tree.links.new(_channels(tree, s["F"])[0], n.inputs[0])
                else:
                    tree.links.new(s["F"], n.inputs[1])
                tree.links.new(s["A"], n.inputs[4])
                tree.links.new(s["B"], n.inputs[5])
                return n.outputs[1]
            got = _colour_render(probe, kind, ("mix vector", mode, clamp), make)
            if mode == "UNIFORM":
                def formula(f, a, b, clamp=clamp):
                    return cn.mix_vector(clamp, f[0], a, b)
            else:
                def formula(f, a, b, clamp=clamp):
                    return cn.mix_vector_nonuniform(clamp, f, a, b)
            _check_channels(formula, (F, A, B), got, f"{kind} vector {mode} clamp={clamp}")


@pytest.mark.parametrize("kind", nc.KINDS)
def test_colour_adjustments_match_cycles(probe, kind):
    """Invert (factor F), Hue/Saturation/Value (hue 0.15 (F1 - 0.5) / 0.2, saturation and value
    about 1), Gamma (0.5 b: zero and negative on the int set), Bright/Contrast, RGB to BW.
    Teeth: HSV's hue off by 0.05, Gamma 1.05 times, contrast's offset halved, and RGB to BW with
    Rec.601's weights: caught (77/176/188/256 pixels wrong on the smooth set, 80/154/140/256 on
    the int set)."""
    col = _colour_inputs(probe, kind)
    F, A, W = col["F"], col["A"], col["W"]
    a, b, c = probe.inputs(kind)

    def make_invert(tree, s, *_):
        n = _node(tree, "ShaderNodeInvert")
        tree.links.new(_channels(tree, s["F"])[0], n.inputs[0])
        tree.links.new(s["W"], n.inputs[1])
        return n.outputs[0]
    got = _colour_render(probe, kind, "invert", make_invert)
    _check_channels(lambda f, w: cn.invert(f[0], w), (F, W), got, f"{kind} invert")

    def make_hsv(tree, s, *_):
        f = _channels(tree, s["F"])
        n = _node(tree, "ShaderNodeHueSaturation")
        tree.links.new(_madd(tree, f[1], 0.75, -0.375), n.inputs[0])  # hue
        tree.links.new(_madd(tree, f[2], 2.0, 0.0), n.inputs[1])  # saturation
        tree.links.new(_madd(tree, f[0], 1.0, 0.5), n.inputs[2])  # value
        tree.links.new(f[0], n.inputs[3])
        tree.links.new(s["W"], n.inputs[4])
        return n.outputs[0]
    hsv_got = _colour_render(probe, kind, "hsv", make_hsv)
    hsv_params = probe.render("hsv params", lambda tree, a_, b_, c_: [
        _madd(tree, f, m, o) for f, (m, o) in
        zip(_channels(tree, _colour_sockets(tree, a_, b_, c_)["F"]),
            ((1.0, 0.5), (0.75, -0.375), (2.0, 0.0)))], kind)
    # hsv_params: value, hue, saturation (the first F channel also the factor)

    def hsv(p, f, w, hue_error=0.0):
        return cn.hue_saturation_value(p[1] + hue_error, p[2], p[0], f[0], w)
    _check_channels(hsv, (hsv_params, F, W), hsv_got, f"{kind} hsv")
    _assert_caught(nc.match(lambda p, f, w: hsv(p, f, w, 0.05)[0], (hsv_params, F, W),
                            hsv_got[:, 0]), "hue off by 0.05")

    def make_gamma(tree, s, a_, b_, c_):
        n = _node(tree, "ShaderNodeGamma")
        tree.links.new(s["W"], n.inputs[0])
        tree.links.new(_madd(tree, b_, 0.5, 0.0), n.inputs[1])
        return n.outputs[0]
    got = _colour_render(probe, kind, "gamma", make_gamma)
    _check_channels(lambda w, b: cn.gamma(w, 0.5 * b), (W, b), got, f"{kind} gamma")
    _assert_caught(nc.match(lambda w, b: cn.gamma(w, 0.525 * b)[0], (W, b), got[:, 0]),
                   "gamma 1.05 times")

    def make_bc(tree, s, a_, b_, c_):
        n = _node(tree, "ShaderNodeBrightContrast")
        tree.links.new(s["W"], n.inputs[0])
        tree.links.new(_madd(tree, b_, 0.1, 0.0), n.inputs[1])
        tree.links.new(_madd(tree, c_, 0.2, 0.0), n.inputs[2])
        return n.outputs[0]
    got = _colour_render(probe, kind, "bright contrast", make_bc)
    _check_channels(lambda w, b, c: cn.bright_contrast(w, 0.1 * b, 0.2 * c), (W, b, c), got,
                    f"{kind} bright/contrast")
    _assert_caught(nc.match(lambda w, b, c: cn.bright_contrast(w, 0.1 * b + 0.05 * c, 0.2 * c)[0],
                            (W, b, c), got[:, 0]), "contrast's offset halved")

    def make_bw(tree, s, *_):
        return [_node(tree, "ShaderNodeRGBToBW", [(0, s["W"])]).outputs[0]]
    got = _colour_render(probe, kind, "rgb to bw", make_bw)
    _assert_matches(nc.match(cn.rgb_to_bw, (W,), got[:, 0]), f"{kind} rgb to bw")
    _assert_caught(nc.match(lambda w: 0.299 * w[0] + 0.587 * w[1] + 0.114 * w[2], (W,),
                            got[:, 0]), "Rec.601 weights")


@pytest.mark.parametrize("mode", cn.COLOR_MODES)
def test_separate_and_combine_color_match_cycles(probe, mode):
    """Separate Color of W and Combine Color of W's channels, in RGB, HSV and HSL (W reaches
    below 0 and above 1). Teeth: HSV's formula for HSL, caught (242 pixels wrong)."""
    col = _colour_inputs(probe, "smooth")
    W = col["W"]
    m = cn.COLOR_MODES.index(mode)

    def make_sep(tree, s, *_):
        n = _node(tree, "ShaderNodeSeparateColor", [(0, s["W"])], mode=mode)
        return [n.outputs[0], n.outputs[1], n.outputs[2]]
    got = _colour_render(probe, "smooth", ("separate", mode), make_sep)
    _check_channels(lambda w: cn.separate_color(m, w), (W,), got, f"separate {mode}")

    def make_comb(tree, s, *_):
        n = _node(tree, "ShaderNodeCombineColor", mode=mode)
        for i, ch in enumerate(_channels(tree, s["W"])):
            tree.links.new(ch, n.inputs[i])
        return n.outputs[0]
    got = _colour_render(probe, "smooth", ("combine", mode), make_comb)
    _check_channels(lambda w: cn.combine_color(m, w), (W,), got, f"combine {mode}")
    if mode == "HSL":
        _assert_caught(nc.match(lambda w: cn.combine_color(cn.MODE_HSV, w)[0], (W,), got[:, 0]),
                       "HSV for HSL")


def test_blackbody_and_wavelength_match_cycles(probe):
    """Blackbody over 500-15500 K (all seven fitted ranges, below 800 K and above 12000 K) and
    Wavelength over 360-810 nm (both ends of the table and past them). Teeth: a temperature
    off by 5% and the wavelength off by 5 nm: caught (163 and 80 pixels wrong)."""
    a, b, c = probe.inputs("smooth")
    t = 2000.0 * (a + 3.75) + 133.0 * (b + 3.75) + 500.0  # what the graphs below compute
    lam = 60.0 * (a + 3.75) + 360.0

    def make_bb(tree, a_, b_, c_):
        temp = _node(tree, "ShaderNodeMath", [(0, _madd(tree, a_, 2000.0, 8000.0)),
                                              (1, _madd(tree, b_, 133.0, 498.75))],
                     operation="ADD").outputs[0]
        return _node(tree, "ShaderNodeBlackbody", [(0, temp)]).outputs[0]
    got_bb = probe.render("blackbody", make_bb, "smooth")
    temps = probe.render("blackbody t", lambda tree, a_, b_, c_: [_node(
        tree, "ShaderNodeMath", [(0, _madd(tree, a_, 2000.0, 8000.0)),
                                 (1, _madd(tree, b_, 133.0, 498.75))],
        operation="ADD").outputs[0]], "smooth")[:, 0]
    assert abs(temps - t).max() < 0.5 and temps.min() < 800 and temps.max() > 12000
    _check_channels(cn.blackbody, (temps,), got_bb, "blackbody")
    _assert_caught(nc.match(lambda t: cn.blackbody(t * 1.05)[2], (temps,), got_bb[:, 2]),
                   "temperature off by 5%")

    def wl(tree, a_):
        return _madd(tree, a_, 60.0, 585.0)
    got_wl = probe.render("wavelength", lambda tree, a_, b_, c_: _node(
        tree, "ShaderNodeWavelength", [(0, wl(tree, a_))]).outputs[0], "smooth")
    lams = probe.render("wavelength nm", lambda tree, a_, b_, c_: [wl(tree, a_)], "smooth")[:, 0]
    assert abs(lams - lam).max() < 0.1 and lams.min() < 380 and lams.max() > 780
    _check_channels(cn.wavelength, (lams,), got_wl, "wavelength")
    _assert_caught(nc.match(lambda x: cn.wavelength(x + 5.0)[1], (lams,), got_wl[:, 1]),
                   "wavelength off by 5 nm")


# --- Color Ramp, RGB Curves, Float Curve: tables baked by the exporter -------------------------

RAMP_STOPS = ((0.1, (0.9, 0.2, 0.1, 1.0)), (0.35, (0.2, 0.9, 0.3, 0.8)),
              (0.6, (1.0, 1.0, 0.0, 0.2)), (0.9, (0.1, 0.4, 0.8, 0.5)))


def _ramp_render(probe, interpolation, color_mode="RGB", hue="NEAR", size=None):
    """Cycles' Color Ramp of factor F[0] (colour in channels 0-2, and alpha through a second
    render), and the table the exporter baked from the same node."""
    tables = {}

    def make(tree, s, *_, output=0):
        n = _node(tree, "ShaderNodeValToRGB")
        ramp = n.color_ramp
        ramp.color_mode = color_mode
        ramp.hue_interpolation = hue
        ramp.interpolation = interpolation
        ramp.elements[0].position, ramp.elements[0].color = RAMP_STOPS[0]
        ramp.elements[1].position, ramp.elements[1].color = RAMP_STOPS[-1]
        for pos, colour in RAMP_STOPS[1:-1]:
            ramp.elements.new(pos).color = colour
        tables["ramp"] = color_export.ramp_table(ramp)
        tree.links.new(_channels(tree, s["F"])[0], n.inputs[0])
        return n.outputs[0] if output == 0 else [n.outputs[1]]
    key = ("ramp", interpolation, color_mode, hue)
    colour = _colour_render(probe, "smooth", key, make)
    alpha = _colour_render(probe, "smooth", key + ("alpha",),
                           lambda *args: make(*args, output=1))[:, 0]
    return colour, alpha, np.array(tables["ramp"])  # each key's renders are made in one test


@pytest.mark.parametrize("interpolation,color_mode,hue", [
    ("LINEAR", "RGB", "NEAR"), ("CONSTANT", "RGB", "NEAR"), ("EASE", "RGB", "NEAR"),
    ("CARDINAL", "RGB", "NEAR"), ("B_SPLINE", "RGB", "NEAR"), ("LINEAR", "HSV", "FAR"),
    ("LINEAR", "HSL", "CW")])
def test_color_ramp_matches_cycles(probe, interpolation, color_mode, hue):
    """Color Ramp (four stops, factor in [-0.25, 1.25]) for every interpolation and the HSV and
    HSL colour modes: the exporter's table (RAMP_TABLE_SIZE + 1 entries evaluated by Blender)
    looked up as Cycles does, colour and alpha. Teeth: a table of 256 entries at i / 255, and
    Linear looked up without interpolation: caught (128 pixels wrong each, the others outside
    [0, 1] where both hold the end entry)."""
    colour, alpha, table = _ramp_render(probe, interpolation, color_mode, hue)
    F = _colour_inputs(probe, "smooth")["F"]
    size = cn.RAMP_TABLE_SIZE + 1
    interpolate = interpolation != "CONSTANT"
    what = f"{interpolation} {color_mode} {hue}"
    _check_channels(lambda f: cn.color_ramp(table, 0, size, interpolate, f[0])[0], (F,), colour,
                    what)
    _assert_matches(nc.match(lambda f: cn.color_ramp(table, 0, size, interpolate, f[0])[1], (F,),
                             alpha), what + " alpha")
    if interpolation == "LINEAR" and color_mode == "RGB":
        short = table[:-4]  # entries 0..255 read as if at i / 255
        _assert_caught(nc.match(lambda f: cn.color_ramp(short, 0, size - 1, True, f[0])[0][0],
                                (F,), colour[:, 0]), "256 entries")
        _assert_caught(nc.match(lambda f: cn.color_ramp(table, 0, size, False, f[0])[0][0],
                                (F,), colour[:, 0]), "no interpolation")


@pytest.mark.parametrize("extend", ("EXTRAPOLATED", "HORIZONTAL"))
def test_curves_match_cycles(probe, extend):
    """RGB Curves (the combined curve and each channel's, over a colour in [-0.6, 1.6], factor in
    [-0.25, 1.25]), Vector Curves (over [-1, 1]) and Float Curve (end points moved in to x = 0.2
    and 0.8), extrapolated and horizontal. Teeth: the other extension mode, and a Float Curve
    table without its min_x: caught (62 and 256 pixels wrong extrapolated, 62 and 80
    horizontal)."""
    tables = {}

    def make_rgb(tree, s, *_):
        n = _node(tree, "ShaderNodeRGBCurve")
        m = n.mapping
        m.extend = extend
        m.curves[3].points.new(0.3, 0.5)
        m.curves[0].points.new(0.5, 0.8)
        m.curves[1].points[-1].location = (1.0, 0.6)
        m.curves[2].points.new(0.25, 0.1)
        m.curves[2].points.new(0.75, 0.9)
        m.update()
        tables["rgb"] = color_export.rgb_curves_table(m)
        tree.links.new(_channels(tree, s["F"])[0], n.inputs[0])
        tree.links.new(s["W"], n.inputs[1])
        return n.outputs[0]

    def make_float(tree, s, *_):
        n = _node(tree, "ShaderNodeFloatCurve")
        m = n.mapping
        m.extend = extend
        curve = m.curves[0]
        curve.points[0].location = (0.2, 0.1)
        curve.points[-1].location = (0.8, 0.9)
        curve.points.new(0.5, 0.7)
        m.update()
        tables["float"] = color_export.float_curve_table(m)
        w = _channels(tree, s["W"])
        tree.links.new(_channels(tree, s["F"])[0], n.inputs[0])
        tree.links.new(w[0], n.inputs[1])
        return [n.outputs[0]]
    def make_vector(tree, s, *_):
        n = _node(tree, "ShaderNodeVectorCurve")
        m = n.mapping
        m.extend = extend
        m.curves[0].points.new(0.2, 0.7)
        m.curves[1].points[0].location = (-0.8, 0.3)
        m.curves[2].points.new(-0.3, -0.6)
        m.update()
        tables["vector"] = color_export.rgb_curves_table(m, combined=False)
        tree.links.new(_channels(tree, s["F"])[0], n.inputs[0])
        tree.links.new(s["W"], n.inputs[1])
        return n.outputs[0]
    rgb = _colour_render(probe, "smooth", ("rgb curves", extend), make_rgb)
    vec = _colour_render(probe, "smooth", ("vector curves", extend), make_vector)
    flt = _colour_render(probe, "smooth", ("float curve", extend), make_float)[:, 0]
    col = _colour_inputs(probe, "smooth")
    F, W = col["F"], col["W"]
    size = cn.RAMP_TABLE_SIZE + 1
    extrapolate = extend == "EXTRAPOLATED"
    t_rgb, t_float = np.array(tables["rgb"]), np.array(tables["float"])
    t_vec = np.array(tables["vector"])
    assert t_vec[0] == pytest.approx(-1.0) and t_vec[1] == pytest.approx(1.0)
    assert t_float[0] == pytest.approx(0.2) and t_float[1] == pytest.approx(0.8)
    _check_channels(lambda f, w: cn.rgb_curves(t_rgb, 0, size, extrapolate, f[0], w), (F, W),
                    rgb, f"rgb curves {extend}")
    _check_channels(lambda f, w: cn.rgb_curves(t_vec, 0, size, extrapolate, f[0], w), (F, W),
                    vec, f"vector curves {extend}")
    _assert_matches(nc.match(lambda f, w: cn.float_curve(t_float, 0, size, extrapolate, f[0],
                                                         w[0]), (F, W), flt),
                    f"float curve {extend}")
    _assert_caught(nc.match(lambda f, w: cn.rgb_curves(t_rgb, 0, size, not extrapolate, f[0],
                                                       w)[2], (F, W), rgb[:, 2]),
                   "the other extension")
    no_min = t_float.copy()
    no_min[0] = 0.0
    _assert_caught(nc.match(lambda f, w: cn.float_curve(no_min, 0, size, extrapolate, f[0], w[0]),
                            (F, W), flt), "min_x left out")


# --- whole materials: exported, compiled and run by the shader-program interpreter -------------

from snell.addon import export  # noqa: E402
from snell.tracer import lobes  # noqa: E402
from snell.tracer.materials import material_tables  # noqa: E402
from snell.tracer.microfacet_tables import shipped_tables  # noqa: E402
from snell.tracer.shader import closures, inputs as shader_inputs, program  # noqa: E402
from support.node_probe import probe_scene  # noqa: E402


class SnellProgram:
    """The probe plane's material as Snell exports and runs it: the Emission its program gives
    at points of the plane (program.run at a camera hit there, facing +z)."""

    def __init__(self, build):
        probe_scene(build, size=nc.SIZE, extent=nc.EXTENT)
        scene, self.warnings = export.export_depsgraph(bpy.context.evaluated_depsgraph_get())
        (self.material,) = scene.materials
        self.mats = material_tables(scene.materials, scene.material_ids, scene.images,
                                    scene.texcoords)
        self.positions, self.triangles = scene.positions, scene.triangles
        self.regs = program.new_registers()
        self.scratch = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
        self.tables = shipped_tables()

    def _triangle(self, p):
        """(triangle, b1, b2) of the plane's triangle holding point p."""
        for t, tri in enumerate(self.triangles):
            v0, v1, v2 = (self.positions[i][:2] for i in tri)
            m = np.array([v1 - v0, v2 - v0]).T
            b1, b2 = np.linalg.solve(m, np.asarray(p[:2]) - v0)
            if b1 >= -1e-9 and b2 >= -1e-9 and b1 + b2 <= 1 + 1e-9:
                return t, float(b1), float(b2)
        raise AssertionError(f"{p} is off the plane")

    def emission(self, p):
        t, b1, b2 = self._triangle(p)
        n = (0.0, 0.0, 1.0)
        hit = ((float(p[0]), float(p[1]), 0.0), n, n, n, True, t, b1, b2,
               1 << shader_inputs.LP_CAMERA, 0, 1.0)
        program.run(self.mats, 0, self.regs, hit, self.scratch, self.tables, False)
        return program.total(self.regs, closures.TOTAL_EMISSION)


def _chain_value(tree, x, y):
    """x, y through Value, Math, Clamp, Map Range (stepped, clamped) and Mix (Float)."""
    s = _node(tree, "ShaderNodeMath", [(0, x), (1, y)], operation="ARCTAN2").outputs[0]
    value = _node(tree, "ShaderNodeValue")
    value.outputs[0].default_value = 1.7
    p = _node(tree, "ShaderNodeMath", [(0, x), (1, value.outputs[0])],
              operation="PINGPONG").outputs[0]
    cl = _node(tree, "ShaderNodeClamp", [(0, s), (1, -1.0), (2, p)], clamp_type="RANGE")
    mr = _node(tree, "ShaderNodeMapRange", [(0, cl.outputs[0]), (1, -2.0), (2, 2.5), (3, 0.2),
                                            (4, 1.1), (5, 6.0)],
               interpolation_type="STEPPED", clamp=True)
    mix = _node(tree, "ShaderNodeMix", [(0, y), (2, mr.outputs[0]), (3, p)], data_type="FLOAT")
    return mix.outputs[0]


def _chain_colour(tree, x, y, position):
    """A Color Ramp (B-Spline) of the value chain, mixed (Overlay) with a Mapping of the point
    through Vector Math (wrapped by an RGB node's colour) and Map Range (vector),
    Hue/Saturation and RGB Curves after it."""
    ramp = _node(tree, "ShaderNodeValToRGB", [(0, _chain_value(tree, x, y))])
    ramp.color_ramp.interpolation = "B_SPLINE"
    ramp.color_ramp.elements.new(0.4).color = (0.1, 0.8, 0.3, 1.0)
    mapping = _node(tree, "ShaderNodeMapping", [(0, position), (2, (0.3, -0.2, 0.9)),
                                                (3, (0.5, 0.25, 1.0))], vector_type="TEXTURE")
    rgb = _node(tree, "ShaderNodeRGB")
    rgb.outputs[0].default_value = (0.7, 1.3, 0.4, 1.0)
    vm = _node(tree, "ShaderNodeVectorMath", [(0, mapping.outputs[0]), (1, rgb.outputs[0])],
               operation="WRAP")
    tree.links.new(position, vm.inputs[2])
    vmr = _node(tree, "ShaderNodeMapRange", data_type="FLOAT_VECTOR",
                interpolation_type="SMOOTHERSTEP")
    tree.links.new(vm.outputs[0], vmr.inputs[6])
    mix = _node(tree, "ShaderNodeMix", [(0, x), (6, ramp.outputs[0]), (7, vmr.outputs[1])],
                data_type="RGBA", blend_type="OVERLAY", clamp_factor=False)
    hsv = _node(tree, "ShaderNodeHueSaturation", [(0, 0.6), (1, 1.4), (4, mix.outputs[2])])
    curves = _node(tree, "ShaderNodeRGBCurve", [(0, 0.8), (1, hsv.outputs[0])])
    curves.mapping.curves[3].points.new(0.4, 0.6)
    curves.mapping.update()
    return curves.outputs[0]


def test_compiled_materials_match_cycles(probe, monkeypatch):
    """Two node graphs into the probe plane's Emission, exported by Snell's exporter (its
    Compiler and these families' compile functions) and run by the shader-program interpreter
    at Cycles' own points, match Cycles: a value chain (Value, Math, Clamp, Map Range, Mix
    Float, with links converted) and a colour chain (Color Ramp, Mapping, RGB, Vector Math,
    vector Map Range, Mix Overlay, Hue/Saturation, RGB Curves). Teeth: the Color Ramp baked at
    i / 255 instead of i / 256, caught."""
    points = probe.render("object coordinates", lambda tree, a, b, c: _node(
        tree, "ShaderNodeTexCoord").outputs["Object"], "smooth")

    def build(which):
        def make(tree):
            tc = _node(tree, "ShaderNodeTexCoord")
            xy = _channels(tree, tc.outputs["Object"])
            return (_chain_value(tree, xy[0], xy[1]) if which == "value" else
                    _chain_colour(tree, xy[0], xy[1], tc.outputs["Object"]))
        return make
    for which in ("value", "colour"):
        got = probe.render(("compiled", which), lambda tree, a, b, c: build(which)(tree),
                           "smooth")
        snell = SnellProgram(build(which))
        assert snell.warnings == [] and snell.material["kind"] == "program"
        ops = {row[0] for row in snell.material["program"]["code"]}
        assert any(100 <= op < 200 for op in ops) and (which == "value" or
                                                       any(op >= 200 for op in ops))
        for ch in range(3):
            _assert_matches(nc.match(lambda p, ch=ch: snell.emission(p)[ch], (points,),
                                     got[:, ch]), f"{which} channel {ch}")
    n = cn.RAMP_TABLE_SIZE
    monkeypatch.setattr(color_export, "ramp_table", lambda ramp: [
        float(v) for i in range(n + 1) for v in ramp.evaluate(min(i / (n - 1), 1.0))])
    snell = SnellProgram(build("colour"))
    got = probe.render(("compiled", "colour"), None, "smooth")
    _assert_caught(nc.match(lambda p: snell.emission(p)[0], (points,), got[:, 0]),
                   "ramp baked at i / 255")
