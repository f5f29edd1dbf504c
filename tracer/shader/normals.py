"""The shading-normal instructions of a shader program: the Normal Map node in tangent, object
and world space (Cycles' svm_node_normal_map, kernel/svm/tex_coord.h of Blender 5.0).

Cycles builds a tangent-space normal in object space, N = x T + y B + z n with T the UV map's
MikkTSpace tangent and n the mesh normal interpolated (not normalised) at the hit and B = sign
(n x T), then brings N to world space with the object's normal matrix A = M^-T. The exporter
(addon/export/meshes.py) stores each corner's A T and A n as the scene's texture coordinates of
kinds "tangent" and "tangent_normal", and of kind "tangent_sign" the corners' signs and the
matrix G = det(M) (M M^T)^-1, with which A (n x T) = G (A n x A T): interpolating A T and A n
and crossing them at the hit gives Cycles' frame times A exactly, unequal scale and mirrors
included. An object-space map reads A itself, its columns as the constant coordinates of kind
"normal_matrix".

The hit is program.run's tuple (inputs.py's docstring): its shading normal hit[2] faces the
ray, as Cycles' sd->N does, and hit[4] is False on a back face.
"""
from __future__ import annotations

import math

from ..jit import jit
from ..lobes import SMOOTH_NORMAL
from ..vec import add, cross, madd, mul, normalize, sub
from .inputs import interpolate, store3

# Opcodes 400-449.
NORMAL_MAP_TANGENT, NORMAL_MAP_OBJECT, NORMAL_MAP_WORLD = range(400, 403)
FIRST, LAST = 400, 449

# The Normal Map node's spaces as Cycles numbers them (NODE_NORMAL_MAP_*): object and world
# (NORMAL_MAP_OBJECT's and NORMAL_MAP_WORLD's literal) and Blender's own conventions of both.
SPACE_TANGENT, SPACE_OBJECT, SPACE_WORLD, SPACE_BLENDER_OBJECT, SPACE_BLENDER_WORLD = range(5)
SPACES = 5

SPECS = {
    NORMAL_MAP_TANGENT: ("Normal Map (tangent space): the normal of colour v at strength f in "
                         "the frame of the scene's coordinates i (tangent), i (tangent_sign), "
                         "i (tangent_normal)", "vvfiii-",
                         {4: "texcoords", 5: "texcoords", 6: "texcoords"}),
    NORMAL_MAP_OBJECT: ("Normal Map (object space): the normal of colour v at strength f, space "
                        "i, through the object's normal matrix, the scene's coordinates i, i, i "
                        "(its columns)", "vvfiiii",
                        {4: SPACES, 5: "texcoords", 6: "texcoords", 7: "texcoords"}),
    NORMAL_MAP_WORLD: ("Normal Map (world space): the normal of colour v at strength f, space i",
                       "vvfi---", {4: SPACES}),
}


@jit
def decode(color):
    """A normal map's colour as a vector: 2 (c - 0.5) per component."""
    return (2.0 * (color[0] - 0.5), 2.0 * (color[1] - 0.5), 2.0 * (color[2] - 0.5))


@jit
def tangent_strength(c, strength):
    """A decoded tangent-space vector at a strength: x and y scaled, z mixed from 1 towards z
    by the strength clamped to [0, 1] (Cycles applies strength before the frame)."""
    s = min(max(strength, 0.0), 1.0)
    return (c[0] * strength, c[1] * strength, (1.0 - s) + s * c[2])


@jit
def blender_convention(c, space):
    """Blender's object and world spaces have y and z negated (Cycles' "strange blender
    convention")."""
    if space == SPACE_BLENDER_OBJECT or space == SPACE_BLENDER_WORLD:
        return (c[0], -c[1], -c[2])
    return c


@jit
def from_frame(c, t, b, n):
    """c's components along the frame (t, b, n), normalised (zero stays zero)."""
    return normalize(madd(madd(mul(t, c[0]), c[1], b), c[2], n))


@jit
def finite_nonzero(v):
    """Whether v is finite and not zero."""
    for k in range(3):
        if not math.isfinite(v[k]):
            return False
    return v[0] != 0.0 or v[1] != 0.0 or v[2] != 0.0


@jit
def finish(n, ns, backfacing, strength, mix_strength):
    """The last steps Cycles takes on a mapped normal n: reversed on a back face, mixed
    linearly from the shading normal ns by the strength (object and world space, strength not
    1), and ns instead of a zero or non-finite result."""
    if backfacing:
        n = mul(n, -1.0)
    if mix_strength and strength != 1.0:
        s = max(strength, 0.0)
        n = normalize(add(ns, mul(sub(n, ns), s)))
    return n if finite_nonzero(n) else ns


@jit
def bitangent(signs, tri, b1, b2, t, n):
    """sign (n x t) in world space at barycentrics (b1, b2) of triangle tri, from the
    "tangent_sign" coordinates (T, 3, 3): per corner its sign, an entry of G's diagonal and one
    of (G_xy, G_xz, G_yz); t and n the interpolated A T and A n."""
    c = signs[tri]
    b0 = 1.0 - b1 - b2
    sign = b0 * c[0, 0] + b1 * c[1, 0] + b2 * c[2, 0]
    cr = cross(n, t)
    gxx, gyy, gzz, gxy, gxz, gyz = c[0, 1], c[1, 1], c[2, 1], c[0, 2], c[1, 2], c[2, 2]
    return (sign * (gxx * cr[0] + gxy * cr[1] + gxz * cr[2]),
            sign * (gxy * cr[0] + gyy * cr[1] + gyz * cr[2]),
            sign * (gxz * cr[0] + gyz * cr[1] + gzz * cr[2]))


@jit
def normal_map_tangent(color, strength, t, b, n, ns, backfacing):
    """The tangent-space Normal Map: colour at strength in the world-space frame (t, b, n)
    interpolated at the hit (each Cycles' object-space vector times the normal matrix); ns the
    shading normal facing the ray."""
    c = tangent_strength(decode(color), strength)
    return finish(from_frame(c, t, b, n), ns, backfacing, strength, False)


@jit
def normal_map_space(color, strength, space, x, y, z, ns, backfacing):
    """The object- or world-space Normal Map: x, y, z the object's normal matrix's columns
    (object spaces) or the world's axes (world spaces)."""
    c = blender_convention(decode(color), space)
    return finish(from_frame(c, x, y, z), ns, backfacing, strength, True)


WORLD_X, WORLD_Y, WORLD_Z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


@jit
def execute(ins, regs, hit, mats):
    """Run one shading-normal instruction at a hit (program.run's `hit`; mats: the scene's
    Materials, whose coords hold the frames)."""
    op = ins[0]
    ns, backfacing, tri, b1, b2 = hit[2], not hit[4], hit[5], hit[6], hit[7]
    color = (regs[ins[2]], regs[ins[2] + 1], regs[ins[2] + 2])
    strength = regs[ins[3]]
    if op == NORMAL_MAP_TANGENT:
        t = interpolate(mats.coords[ins[4]], tri, b1, b2)
        n = interpolate(mats.coords[ins[6]], tri, b1, b2)
        b = bitangent(mats.coords[ins[5]], tri, b1, b2, t, n)
        store3(regs, ins[1], normal_map_tangent(color, strength, t, b, n, ns, backfacing))
    elif op == NORMAL_MAP_OBJECT:
        x = interpolate(mats.coords[ins[5]], tri, b1, b2)
        y = interpolate(mats.coords[ins[6]], tri, b1, b2)
        z = interpolate(mats.coords[ins[7]], tri, b1, b2)
        store3(regs, ins[1], normal_map_space(color, strength, ins[4], x, y, z, ns, backfacing))
    elif op == NORMAL_MAP_WORLD:
        store3(regs, ins[1], normal_map_space(color, strength, ins[4], WORLD_X, WORLD_Y,
                                              WORLD_Z, ns, backfacing))


@jit
def mark_smooth_normal(lobes, count, ns):
    """Record the hit's shading normal ns (facing the ray) in its lobes, for the bump shadowing
    of those whose normal a Normal Map bent (lobes.bump_shadowing)."""
    for k in range(count):
        for c in range(3):
            lobes[k, SMOOTH_NORMAL + c] = ns[c]
