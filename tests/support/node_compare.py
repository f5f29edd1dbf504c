"""Snell's node formulas held against Cycles point by point, on top of node_probe: a graph's
inputs and outputs are rendered with Cycles at the probe's pixels, and a scalar formula is
evaluated at the very inputs Cycles had (read back from a render of them, since sample 0 lands
up to 1.3e-4 from a pixel's centre), then compared to Cycles' output.

Cycles computes in float32, Snell in float64, so the two agree to a relative ~1e-6, except where
the formula jumps (floor, comparisons, modulo) or is ill-conditioned (tan near a pole) and one
float32 rounding moves the answer. Such a pixel is accepted only if the formula, evaluated at its
inputs moved by a few float32 ulps, reaches Cycles' value; `Match` counts them.

    inputs = NodeInputs(kind="smooth")                   # a, b, c per pixel: x, y, mixed
    got = render_outputs(lambda t, a, b, c: [sock1, sock2, sock3], kind="smooth")
    m = match(lambda a, b, c: my_formula(a, b, c), inputs, got[:, 0])
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .node_probe import probe

SIZE = 16
EXTENT = 4.0
KINDS = ("smooth", "int")


def input_sockets(tree, kind):
    """Three float sockets varying over the probe plane. smooth: x, y and 0.5 x + 0.3 y + 0.1;
    int: x, floor(y) (whole numbers -4..3, zero included) and floor(x / 2) (-2..1)."""
    tc = tree.nodes.new("ShaderNodeTexCoord")
    sep = tree.nodes.new("ShaderNodeSeparateXYZ")
    tree.links.new(tc.outputs["Object"], sep.inputs[0])
    x, y = sep.outputs[0], sep.outputs[1]

    def math(op, s, t=None, t_value=0.0, u_value=0.0):
        n = tree.nodes.new("ShaderNodeMath")
        n.operation = op
        tree.links.new(s, n.inputs[0])
        if t is not None:
            tree.links.new(t, n.inputs[1])
        else:
            n.inputs[1].default_value = t_value
        n.inputs[2].default_value = u_value
        return n.outputs[0]

    if kind == "smooth":
        c = math("MULTIPLY_ADD", x, None, 0.5, 0.1)
        c = math("ADD", c, math("MULTIPLY", y, None, 0.3))
        return x, y, c
    return x, math("FLOOR", y), math("FLOOR", math("MULTIPLY", x, None, 0.5))


def combine(tree, sockets):
    """A Combine XYZ of up to three float sockets (missing ones 0)."""
    comb = tree.nodes.new("ShaderNodeCombineXYZ")
    for i, s in enumerate(sockets):
        tree.links.new(s, comb.inputs[i])
    return comb.outputs[0]


def render(build, kind):
    """Cycles' (SIZE*SIZE, 3) output of build(tree, a, b, c) -> a socket, or a list of up to
    three float sockets (one per channel), at the probe's pixels."""
    def graph(tree):
        out = build(tree, *input_sockets(tree, kind))
        return combine(tree, out) if isinstance(out, (list, tuple)) else out

    image, _ = probe(graph, size=SIZE, extent=EXTENT)
    return image.reshape(-1, 3)


def inputs(kind):
    """Cycles' own (a, b, c) at the probe's pixels, each (SIZE*SIZE,) float64."""
    img = render(lambda tree, a, b, c: [a, b, c], kind)
    return img[:, 0], img[:, 1], img[:, 2]


@dataclasses.dataclass
class Match:
    """How a formula compared with Cycles' values: pixels within tolerance, pixels accepted only
    at a jump (see the module's docstring), pixels wrong, the largest error of the first."""
    close: int
    at_jumps: int
    wrong: int
    worst: float
    first_wrong: tuple = ()

    def ok(self, max_jumps=0.03):
        """No pixel wrong, and at most a fraction max_jumps of them only at jumps."""
        n = self.close + self.at_jumps + self.wrong
        return self.wrong == 0 and self.at_jumps <= max_jumps * n


def _close(ours, cycles, rtol, atol):
    return np.abs(ours - cycles) <= atol + rtol * np.abs(cycles)


def match(formula, args, cycles, rtol=1e-5, atol=1e-5, ulps=4, tries=48, seed=1):
    """Compare formula(*args at a pixel) -> float with cycles (one value per pixel). args is a
    sequence of per-pixel arrays ((N,) scalars or (N, 3) vectors)."""
    args = [np.asarray(a, dtype=np.float64) for a in args]
    n = len(cycles)
    ours = np.array([formula(*[_item(a, i) for a in args]) for i in range(n)])
    ok = _close(ours, cycles, rtol, atol)
    ok |= ~np.isfinite(cycles) & (ours == cycles)
    worst = float(np.max(np.abs(ours - cycles)[ok])) if ok.any() else 0.0
    rng = np.random.default_rng(seed)
    at_jumps, wrong = 0, []
    for i in np.flatnonzero(~ok):
        values = []
        for _ in range(tries):
            moved = [_item(a, i) for a in args]
            moved = [_nudge(v, rng, ulps) for v in moved]
            values.append(formula(*moved))
        values = np.array(values + [ours[i]])
        lo, hi = values.min(), values.max()
        tol = atol + rtol * abs(cycles[i])
        if lo - tol <= cycles[i] <= hi + tol:
            at_jumps += 1
        else:
            wrong.append(i)
    first = ()
    if wrong:
        i = wrong[0]
        first = (int(i), [_item(a, i) for a in args], float(ours[i]), float(cycles[i]))
    return Match(int(ok.sum()), at_jumps, len(wrong), worst, first)


def _item(a, i):
    if a.ndim == 1:
        return float(a[i])
    return tuple(float(v) for v in a[i])


def _nudge(v, rng, ulps):
    eps = ulps * np.finfo(np.float32).eps
    if isinstance(v, tuple):
        return tuple(float(x * (1.0 + rng.uniform(-eps, eps))) for x in v)
    return float(v * (1.0 + rng.uniform(-eps, eps)))
