"""The closure instructions of a shader program: each BSDF node adds its lobes (lobes.py) to the
hit's, scaled by its mix weight; Emission, Transparent and Holdout add to the hit's totals.

Cycles is the model (kernel/svm/closure.h): a Mix Shader does not mix closures, it hands each
side a weight (svm_node_mix_closure: in x (1 - fac) and in x fac, fac clamped to [0, 1]), and
every closure node below it multiplies its own colour by that weight. A closure lighter than
lobes.WEIGHT_CUTOFF is left out, as Cycles' closure_alloc leaves it out.

Slots (program.py's SPECS letters): 'w' a mix weight register (-1: weight 1), 'n' a normal
register (-1: the hit's shading normal).

The totals live in the register file past program.MAX_REGISTERS (TOTALS): emitted radiance,
transparency (the sum of the Transparent closures' weights: what a shadow ray keeps) and the
holdout weight.
"""
from __future__ import annotations

from ..jit import jit
from ..lobes import (MAX_LOBES, SAMPLE_WEIGHT, TRANSLUCENT, TRANSPARENT, WEIGHT, WEIGHT_CUTOFF,
                     LAMBERT, new_lobe, setup_glass, setup_glossy, setup_principled,
                     setup_refraction)
from ..specular import valid_reflection_normal
from .inputs import DROP_SHIFT
from ..vec import mean3, mul, normalize

# Opcodes 0-19.
(DIFFUSE, GLOSSY, GLASS, REFRACTION, PRINCIPLED, EMISSION, TRANSPARENT_BSDF, TRANSLUCENT_BSDF,
 HOLDOUT, MIX_CLOSURE) = range(10)
LAST = 19

# A Principled BSDF's inputs as one block of registers: its base colour, then lobes.py's
# P_FIELDS parameters in their order, then alpha, emission colour and emission strength.
P_BASE, P_PARAMS = 0, 3
P_ALPHA = 3 + 14
P_EMISSION_COLOR, P_EMISSION_STRENGTH = P_ALPHA + 1, P_ALPHA + 4
PRINCIPLED_BLOCK = P_EMISSION_STRENGTH + 1

SPECS = {
    DIFFUSE: ("Diffuse BSDF: Lambert of colour v", "wvn----"),
    GLOSSY: ("Glossy BSDF: colour v, roughness f, distribution i", "wvfin--", {4: 3}),
    GLASS: ("Glass BSDF: colour v, roughness f, IOR f, distribution i", "wvffin-", {5: 3}),
    REFRACTION: ("Refraction BSDF: colour v, roughness f, IOR f, distribution i", "wvffin-",
                 {5: 3}),
    PRINCIPLED: ("Principled BSDF: the block of its inputs (closures.PRINCIPLED_BLOCK), "
                 "distribution i", "wPin---", {3: 3}),
    EMISSION: ("Emission: colour v x strength f", "wvf----"),
    TRANSPARENT_BSDF: ("Transparent BSDF: colour v", "wv-----"),
    TRANSLUCENT_BSDF: ("Translucent BSDF: colour v", "wvn----"),
    HOLDOUT: ("Holdout", "w------"),
    MIX_CLOSURE: ("Mix Shader: weights in (1 - fac), in fac of weight w (-1: 1) and fac f",
                  "ffwf---"),
}

# Where the totals are, past the registers: emission (3), transparency (3), holdout (1).
TOTAL_EMISSION, TOTAL_TRANSPARENCY, TOTAL_HOLDOUT = 0, 3, 6
TOTALS = 7


@jit
def mix_weight(regs, slot):
    """A closure's mix weight: the register's value, or 1 for slot -1."""
    return 1.0 if slot < 0 else regs[slot]


@jit
def vector(regs, slot):
    """Three registers from slot as a vector."""
    return (regs[slot], regs[slot + 1], regs[slot + 2])


@jit
def closure_normal(regs, slot, ns):
    """A closure's shading normal: its Normal input normalised (the hit's normal if unlinked or
    zero, Cycles' safe_normalize_fallback)."""
    if slot < 0:
        return ns
    v = vector(regs, slot)
    if v[0] * v[0] + v[1] * v[1] + v[2] * v[2] > 0.0:
        return normalize(v)
    return ns


@jit
def scale_lobes(lobes, first, last, w):
    """Multiply the colour and sampling weights of lobes first .. last - 1 by w."""
    for k in range(first, last):
        for c in range(3):
            lobes[k, WEIGHT + c] *= w
        lobes[k, SAMPLE_WEIGHT] *= w


@jit
def add_total(regs, base, at, v):
    """Add the vector v to the total at `at` (TOTAL_*) of the totals starting at base."""
    for c in range(3):
        regs[base + at + c] += v[c]


@jit
def add_transparent(lobes, count, regs, base, n, weight):
    """A transparent lobe of this colour weight, and its weight added to the transparency."""
    add_total(regs, base, TOTAL_TRANSPARENCY, weight)
    if count < MAX_LOBES and abs(mean3(weight)) >= WEIGHT_CUTOFF:
        new_lobe(lobes[count], TRANSPARENT, n, weight)
        return count + 1
    return count


@jit
def execute(ins, regs, base, hit, lobes, count, tables, has_normals):
    """Run one closure instruction at a hit (program.run's `hit`); returns the new lobe count.
    base: where the totals start in regs."""
    op = ins[0]
    if op == MIX_CLOSURE:
        w = mix_weight(regs, ins[3])
        fac = min(max(regs[ins[4]], 0.0), 1.0)
        regs[ins[1]] = w * (1.0 - fac)
        regs[ins[2]] = w * fac
        return count
    w = mix_weight(regs, ins[1])
    if w == 0.0:
        return count
    ng, ns, view, entering = hit[1], hit[2], hit[3], hit[4]
    drop = hit[8] >> DROP_SHIFT     # the caustics this hit drops (inputs.DROP_SHIFT)
    if op == EMISSION:
        strength = regs[ins[3]]
        add_total(regs, base, TOTAL_EMISSION, mul(vector(regs, ins[2]), strength * w))
        return count
    if op == HOLDOUT:
        regs[base + TOTAL_HOLDOUT] += w
        return count
    if op == TRANSPARENT_BSDF:
        return add_transparent(lobes, count, regs, base, ns, mul(vector(regs, ins[2]), w))
    if count >= MAX_LOBES:
        return count
    if op == DIFFUSE or op == TRANSLUCENT_BSDF:
        weight = mul(vector(regs, ins[2]), w)
        if abs(mean3(weight)) < WEIGHT_CUTOFF:
            return count
        n = closure_normal(regs, ins[3], ns)
        new_lobe(lobes[count], LAMBERT if op == DIFFUSE else TRANSLUCENT, n, weight)
        return count + 1
    # The microfacet closures: their normal bent so that its mirror reflection clears the
    # surface, as scatter_lit bends the mesh's (Cycles' maybe_ensure_valid_specular_reflection).
    if op == PRINCIPLED:
        block = ins[2]
        n_diffuse = closure_normal(regs, ins[4], ns)
        n = n_diffuse
        if has_normals or ins[4] >= 0:
            n = valid_reflection_normal(ng, view, n_diffuse)
        alpha = min(max(regs[block + P_ALPHA], 0.0), 1.0)
        if alpha < 1.0:
            clear = w * (1.0 - alpha)
            count = add_transparent(lobes, count, regs, base, ns, (clear, clear, clear))
            w *= alpha
        emission = mul(vector(regs, block + P_EMISSION_COLOR),
                       regs[block + P_EMISSION_STRENGTH] * w)
        add_total(regs, base, TOTAL_EMISSION, emission)
        # setup_principled writes up to 5 lobes: a program that would pass MAX_LOBES drops it.
        if w < WEIGHT_CUTOFF or count + 5 > MAX_LOBES:
            return count
        added = setup_principled(lobes[count:], tables, n, n_diffuse, view, entering,
                                 vector(regs, block + P_BASE),
                                 regs[block + P_PARAMS:block + P_PARAMS + 14], ins[3], drop)
        scale_lobes(lobes, count, count + added, w)
        return count + added
    normal_slot = ins[5] if op == GLOSSY else ins[6]
    n = closure_normal(regs, normal_slot, ns)
    if has_normals or normal_slot >= 0:
        n = valid_reflection_normal(ng, view, n)
    color = vector(regs, ins[2])
    roughness = min(max(regs[ins[3]], 0.0), 1.0)
    if op == GLOSSY:
        added = setup_glossy(lobes[count:], tables, n, view, color, roughness, ins[4], drop)
    else:
        ior = max(regs[ins[4]], 1e-5)
        if op == GLASS:
            added = setup_glass(lobes[count:], tables, n, view, entering, color, color,
                                roughness, ins[5], ior, drop)
        else:
            added = setup_refraction(lobes[count:], n, entering, color, roughness, ins[5], ior,
                                     drop)
    if added == 0:
        return count
    scale_lobes(lobes, count, count + 1, w)
    if abs(lobes[count, SAMPLE_WEIGHT]) < WEIGHT_CUTOFF:
        return count
    return count + 1
