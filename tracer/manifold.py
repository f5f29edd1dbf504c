"""The specular manifold of a chain of smooth refractions: the formulas of manifold next-event
estimation (Hanika, Droske and Fascione 2015, "Manifold Next Event Estimation"; the stage that
uses them is mnee.py).

A chain x0 (a point on a rough receiver, fixed), x1 .. xk (points on smooth refracting
triangles), y (a point on a lamp, fixed) obeys Snell's law at every xi exactly when each
vertex's generalized half vector wi + eta wo (wi towards x(i-1), wo towards x(i+1), eta the
ratio of the indices on wo's side and wi's) is parallel to its shading normal: its two
components along a tangent frame (s, t) of the shading normal vanish (the constraint). Each
vertex moves in the plane of its triangle, by two coordinates along unit tangents (a, b) of that
plane; the shading normal is the interpolated vertex normal, whose derivatives along a and b the
constraint's derivatives need. Newton's method on the constraint walks a seed chain (the
straight segment x0 y) onto the manifold; the implicit function theorem then gives how x1 moves
with y, whose determinant is the generalized geometry term that turns the lamp's area density
into x0's solid angle.

A point or spot lamp of radius r > 0 is a disk that faces whoever sees it (lights/point.py),
so the last vertex's lamp point moves with it (facing_disk): its offset from the centre,
uniform on the disk, turns with the disk. The last vertex's constraint then changes through y
as well as directly (fill_system's y_motion), and the transfer determinant is per unit of the
disk's area as that vertex sees it, the measure of the path tracer's ray that finds the lamp.
Cycles' shadow caustics keep the point on the disk that faces the receiver and take the
Jacobian in the plane across the last segment (kernel/light/point.h,
point_light_mnee_sample_update), which overstates the light (docs/measurements.md).

A sun's chain ends in a fixed direction instead of a point y (Cycles' light_fixed_direction):
the last vertex's wo is that direction whatever the vertex does, and the lamp's two coordinates
are the direction's own along two unit tangents of it, so the transfer determinant is per unit
of the sun's solid angle and the geometry term dw0/dw(sun).

Each formula is one scalar function over tuples. The chain's Jacobian is block tridiagonal (a
vertex's constraint depends on its neighbours only): a scratch of 2k rows (k at most
MAX_CASTERS, since compiled code allocates nothing) holds each vertex's three 2x2 blocks and
right-hand sides (SYSTEM_COLUMNS), and a block LU solves it in O(k).
"""
from __future__ import annotations

import math

from .fresnel import fresnel
from .jit import jit_inline
from .vec import add, cross, dot, madd, mul, neg, sub

MAX_CASTERS = 6          # refracting vertices in a chain (Cycles' MNEE_MAX_CAUSTIC_CASTERS)
# Below this |determinant| of a block of the factorised Jacobian the chain counts as singular
# (no solution to walk to).
SINGULAR = 1e-12
# The system's columns, per vertex's two rows: the constraint's derivatives in the previous
# vertex's coordinates, its own, the next vertex's, the lamp's (last vertex only: dC/dy), and
# the constraint; solve_blocks leaves the solutions in DY's and C's columns.
BEFORE, HERE, AFTER, DY, C = 0, 2, 4, 6, 8
SYSTEM_COLUMNS = 9


@jit_inline
def unit_towards(p, q):
    """(unit direction from p to q, distance)."""
    d = sub(q, p)
    length = math.sqrt(dot(d, d))
    return mul(d, 1.0 / length), length


@jit_inline
def toward_next(p, p_next, fixed):
    """(unit direction from p to the next vertex, distance): p_next is that direction itself, at
    distance 1, where fixed (a sun's)."""
    if fixed:
        return p_next, 1.0
    return unit_towards(p, p_next)


@jit_inline
def relative_ior(wi, ng, ior):
    """eta = the index on the far side over the index on wi's side of a surface of index `ior`
    whose geometric normal ng faces out (ior beyond it when wi is outside)."""
    return ior if dot(wi, ng) > 0.0 else 1.0 / ior


@jit_inline
def shading_frame(n, a):
    """(s, t, |a - n (n . a)|): s the tangent a made orthogonal to the shading normal n, t = n x
    s."""
    sv = madd(a, -dot(n, a), n)
    length = math.sqrt(dot(sv, sv))
    s = mul(sv, 1.0 / length)
    return s, cross(n, s), length


@jit_inline
def half_vector(wi, wo, eta):
    """(the unit generalized half vector of unit directions wi and wo, the length of wi + eta
    wo): parallel to the shading normal where Snell's law holds."""
    h = madd(wi, eta, wo)
    length = math.sqrt(dot(h, h))
    return mul(h, 1.0 / length), length


@jit_inline
def constraint(p_prev, p, p_next, n, a, ng, ior, fixed):
    """The constraint at vertex p (shading normal n, tangent a of its triangle, geometric normal
    ng, index ior) between p_prev and p_next (a direction where fixed): the half vector's
    components (along s, along t) of the shading frame; (0, 0) where the path refracts by
    Snell's law."""
    wi, _ = unit_towards(p, p_prev)
    wo, _ = toward_next(p, p_next, fixed)
    h, _ = half_vector(wi, wo, relative_ior(wi, ng, ior))
    s, t, _ = shading_frame(n, a)
    return dot(h, s), dot(h, t)


@jit_inline
def _unit_derivative(w, length, e):
    """The derivative of the unit direction w (of a segment of this length) when its far end
    moves along e."""
    return mul(madd(e, -dot(w, e), w), 1.0 / length)


@jit_inline
def _half_derivative(h, h_length, dh):
    """The derivative of the unit half vector h when the unnormalised one changes by dh."""
    return mul(madd(dh, -dot(h, dh), h), 1.0 / h_length)


@jit_inline
def _frame_derivative(n, dn, a, s, s_length):
    """(ds, dt): how shading_frame(n, a)'s s and t change when the normal changes by dn (a
    fixed)."""
    na = dot(n, a)
    d_sv = add(mul(dn, -na), mul(n, -dot(dn, a)))
    ds = mul(madd(d_sv, -dot(s, d_sv), s), 1.0 / s_length)
    return ds, add(cross(dn, s), cross(n, ds))


@jit_inline
def _moved_end(wi, li, wo, lo, eta, h, h_length, s, t, ei, eo):
    """(dC0, dC1) when wi's far end moves by ei and wo's by eo, the frame fixed."""
    dh = _half_derivative(h, h_length, madd(_unit_derivative(wi, li, ei), eta,
                                            _unit_derivative(wo, lo, eo)))
    return dot(dh, s), dot(dh, t)


@jit_inline
def constraint_derivatives(p_prev, p, p_next, n, dn_da, dn_db, a, b, ng, ior, prev_ab, next_ab,
                           fixed, follow):
    """The constraint's derivatives at vertex p (constraint's arguments; dn_da, dn_db the
    shading normal's derivatives along its triangle's unit tangents a and b) with respect to
    the tangent coordinates of p_prev (along prev_ab = (a', b')), of p itself and of p_next
    (along next_ab; where fixed, p_next is a direction and next_ab its unit tangents): three
    2x2 blocks, each (dC0/du, dC0/dv, dC1/du, dC1/dv). follow: how p_next moves when p moves
    along a and along b (zero but for a lamp point that faces p, facing_disk)."""
    wi, li = unit_towards(p, p_prev)
    wo, lo = toward_next(p, p_next, fixed)
    # A fixed direction does not turn when p moves (its far end is at infinity).
    lo_self = math.inf if fixed else lo
    eta = relative_ior(wi, ng, ior)
    h, h_length = half_vector(wi, wo, eta)
    s, t, s_length = shading_frame(n, a)
    zero = (0.0, 0.0, 0.0)
    # The previous vertex moves wi only, the next one wo only; the frame stays.
    pu = _moved_end(wi, li, wo, lo, eta, h, h_length, s, t, prev_ab[0], zero)
    pv = _moved_end(wi, li, wo, lo, eta, h, h_length, s, t, prev_ab[1], zero)
    nu = _moved_end(wi, li, wo, lo, eta, h, h_length, s, t, zero, next_ab[0])
    nv = _moved_end(wi, li, wo, lo, eta, h, h_length, s, t, zero, next_ab[1])
    # p itself moves both directions' near ends (their far ends by -e, wo's by its own motion
    # with p less e), the normal and frame.
    su = _moved_end(wi, li, wo, lo_self, eta, h, h_length, s, t, neg(a), sub(follow[0], a))
    sv = _moved_end(wi, li, wo, lo_self, eta, h, h_length, s, t, neg(b), sub(follow[1], b))
    dsu, dtu = _frame_derivative(n, dn_da, a, s, s_length)
    dsv, dtv = _frame_derivative(n, dn_db, a, s, s_length)
    return ((pu[0], pv[0], pu[1], pv[1]),
            (su[0] + dot(h, dsu), sv[0] + dot(h, dsv), su[1] + dot(h, dtu), sv[1] + dot(h, dtv)),
            (nu[0], nv[0], nu[1], nv[1]))


@jit_inline
def normal_derivatives(corners, normals, b1, b2, a, b):
    """(unit shading normal, its derivatives along the in-plane unit directions a and b) of a
    triangle (corner positions and vertex normals, 3x3 rows) at barycentrics (b1, b2): the
    normalised interpolation of the vertex normals, barycentrics being affine in position."""
    c0 = (corners[0, 0], corners[0, 1], corners[0, 2])
    e1 = sub((corners[1, 0], corners[1, 1], corners[1, 2]), c0)
    e2 = sub((corners[2, 0], corners[2, 1], corners[2, 2]), c0)
    n0 = (normals[0, 0], normals[0, 1], normals[0, 2])
    d1 = sub((normals[1, 0], normals[1, 1], normals[1, 2]), n0)
    d2 = sub((normals[2, 0], normals[2, 1], normals[2, 2]), n0)
    big_n = madd(madd(n0, b1, d1), b2, d2)
    length = math.sqrt(dot(big_n, big_n))
    n = mul(big_n, 1.0 / length)
    # The barycentrics' change along a direction e of the plane: Gram matrix of (e1, e2).
    g11, g12, g22 = dot(e1, e1), dot(e1, e2), dot(e2, e2)
    det = g11 * g22 - g12 * g12
    return (n, _normal_change(n, length, d1, d2, e1, e2, g11, g12, g22, det, a),
            _normal_change(n, length, d1, d2, e1, e2, g11, g12, g22, det, b))


@jit_inline
def _normal_change(n, length, d1, d2, e1, e2, g11, g12, g22, det, e):
    """The unit normal's derivative along e (normal_derivatives' terms)."""
    r1, r2 = dot(e1, e), dot(e2, e)
    db1 = (g22 * r1 - g12 * r2) / det
    db2 = (g11 * r2 - g12 * r1) / det
    dn_raw = madd(mul(d1, db1), db2, d2)
    return mul(madd(dn_raw, -dot(n, dn_raw), n), 1.0 / length)


@jit_inline
def _block(m, row, col):
    """The 2x2 block at m[row:row + 2, col:col + 2] (row-major 4-tuple)."""
    return m[row, col], m[row, col + 1], m[row + 1, col], m[row + 1, col + 1]


@jit_inline
def _times(x, y):
    """The product of 2x2 blocks x y."""
    return (x[0] * y[0] + x[1] * y[2], x[0] * y[1] + x[1] * y[3],
            x[2] * y[0] + x[3] * y[2], x[2] * y[1] + x[3] * y[3])


@jit_inline
def _sub4(x, y):
    """x - y of 2x2 blocks."""
    return x[0] - y[0], x[1] - y[1], x[2] - y[2], x[3] - y[3]


@jit_inline
def _apply(m, row, block, col):
    """block times the 2-vector m[row:row + 2, col]."""
    return (block[0] * m[row, col] + block[1] * m[row + 1, col],
            block[2] * m[row, col] + block[3] * m[row + 1, col])


@jit_inline
def solve_blocks(m, k):
    """Solve the block tridiagonal system that fill_system left in m[:2k] (block LU, no
    pivoting across blocks: the Thomas algorithm on 2x2 blocks), its three right-hand sides
    (DY's two, C) replaced by the solutions; returns the Jacobian's determinant (0 where a
    factorised block is singular)."""
    det = 1.0
    for i in range(k):
        r = 2 * i
        if i > 0:
            # Eliminate the block before the diagonal with the previous row, whose diagonal
            # block holds its inverse by now: L = before inv(D), D -= L after', rhs -= L rhs'.
            ell = _times(_block(m, r, BEFORE), _block(m, r - 2, HERE))
            shift = _times(ell, _block(m, r - 2, AFTER))
            put_block(m, r, HERE, _sub4(_block(m, r, HERE), shift))
            for col in range(DY, SYSTEM_COLUMNS):
                x = _apply(m, r - 2, ell, col)
                m[r, col] -= x[0]
                m[r + 1, col] -= x[1]
        d = _block(m, r, HERE)
        block_det = d[0] * d[3] - d[1] * d[2]
        if abs(block_det) < SINGULAR:
            return 0.0
        det *= block_det
        inv = 1.0 / block_det
        put_block(m, r, HERE, (d[3] * inv, -d[1] * inv, -d[2] * inv, d[0] * inv))
    for i in range(k - 1, -1, -1):
        r = 2 * i
        for col in range(DY, SYSTEM_COLUMNS):
            if i < k - 1:
                x = _apply(m, r + 2, _block(m, r, AFTER), col)
                m[r, col] -= x[0]
                m[r + 1, col] -= x[1]
            x = _apply(m, r, _block(m, r, HERE), col)
            m[r, col], m[r + 1, col] = x[0], x[1]
    return det


@jit_inline
def put_block(m, row, col, block):
    """Write the 2x2 block (row-major 4-tuple) at m[row:row + 2, col:col + 2]."""
    m[row, col], m[row, col + 1] = block[0], block[1]
    m[row + 1, col], m[row + 1, col + 1] = block[2], block[3]


@jit_inline
def vertex_row(a, i):
    """Row i of an (n, 3) array as a tuple."""
    return (a[i, 0], a[i, 1], a[i, 2])


@jit_inline
def fill_system(m, k, x0, y, y_ab, fixed, pos, n, dn_da, dn_db, ta, tb, ng, ior, y_motion):
    """Fill m[:2k] (SYSTEM_COLUMNS) for the chain x0, pos[0 .. k), y (vertex i: shading normal
    n[i] and its derivatives, tangents ta[i], tb[i] of its triangle, geometric normal ng[i],
    index ior[i]; y_ab the lamp's tangents at y; y a direction where fixed; y_motion how y moves
    along the last vertex's tangents, zero but for a lamp that faces it, facing_disk):
    each vertex's blocks of the constraint's Jacobian in the vertices' tangent coordinates, the
    last one's derivatives in y's, and the constraint itself. Returns the largest |constraint|
    of a vertex."""
    worst = 0.0
    still = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    for i in range(k):
        p = vertex_row(pos, i)
        p_prev = x0 if i == 0 else vertex_row(pos, i - 1)
        p_next = y if i == k - 1 else vertex_row(pos, i + 1)
        # x0 is fixed: its tangents are never used (y_ab stands in).
        prev_ab = (vertex_row(ta, i - 1), vertex_row(tb, i - 1)) if i > 0 else y_ab
        next_ab = (vertex_row(ta, i + 1), vertex_row(tb, i + 1)) if i < k - 1 else y_ab
        a, b, ngi = vertex_row(ta, i), vertex_row(tb, i), vertex_row(ng, i)
        ni = vertex_row(n, i)
        last = i == k - 1
        c = constraint(p_prev, p, p_next, ni, a, ngi, ior[i], fixed and last)
        worst = max(worst, math.sqrt(c[0] * c[0] + c[1] * c[1]))
        m[2 * i, C], m[2 * i + 1, C] = c[0], c[1]
        before, here, after = constraint_derivatives(
            p_prev, p, p_next, ni, vertex_row(dn_da, i), vertex_row(dn_db, i), a, b, ngi,
            ior[i], prev_ab, next_ab, fixed and last, y_motion if last else still)
        put_block(m, 2 * i, BEFORE, before)
        put_block(m, 2 * i, HERE, here)
        # The last vertex's next is the lamp: its block is dC/dy; the others' dC/dy is zero.
        put_block(m, 2 * i, DY if last else AFTER, after)
        if not last:
            put_block(m, 2 * i, DY, (0.0, 0.0, 0.0, 0.0))
    return worst


@jit_inline
def facing_disk(c, q, u0, p, ea, eb):
    """The point of the disk of centre c that faces p (its normal u the unit direction from c
    to p) at the offset q of the disk facing u0 (q perpendicular to u0): q turned by the least
    rotation taking u0 to u, which keeps the disk's area. Returns (that point, u, how the point
    moves when p moves by ea, and by eb)."""
    u, distance = unit_towards(c, p)
    turn = 1.0 + dot(u0, u)
    g = dot(u, q) / turn
    return (madd(add(c, q), -g, add(u0, u)), u,
            _facing_motion(q, u0, u, distance, turn, g, ea),
            _facing_motion(q, u0, u, distance, turn, g, eb))


@jit_inline
def _facing_motion(q, u0, u, distance, turn, g, e):
    """facing_disk's point's motion when p moves by e (u, distance, turn and g as there)."""
    du = _unit_derivative(u, distance, e)
    dg = (dot(du, q) - g * dot(u0, du)) / turn
    return add(mul(add(u0, u), -dg), mul(du, -g))


@jit_inline
def transfer_determinant(m):
    """|det dx1/dy| from a solved system (solve_blocks): x1's rows of DY's columns hold -dx1/dy
    (the implicit function theorem)."""
    return abs(m[0, DY] * m[1, DY + 1] - m[0, DY + 1] * m[1, DY])


@jit_inline
def geometry_term(x0, x1, ng1, transfer):
    """The generalized geometry term dw0/dA(y): x0's solid angle per unit of lamp area (per unit
    of a sun's solid angle for a fixed direction), from x1 (on a triangle of geometric normal
    ng1) and |det dx1/dy| (transfer_determinant)."""
    w, distance = unit_towards(x0, x1)
    return abs(dot(w, ng1)) / (distance * distance) * transfer


@jit_inline
def refraction_weight(fresnel_model, wi, wo, n, ng, ior, tint, glass):
    """What the path tracer's smooth refraction carries, on average, from wo's side to wi's at a
    vertex (shading normal n): through glass tint x (1 - F), through a refraction-only surface
    tint alone (Cycles' Refraction BSDF has no Fresnel; specular.sample_specular), and 0
    unless wi and wo are on opposite sides of both normals (as sample_specular's validity)."""
    ci = dot(wi, n)
    if not (ci * dot(wo, n) < 0.0 and dot(wi, ng) * dot(wo, ng) < 0.0):
        return (0.0, 0.0, 0.0)
    if not glass:
        return tint
    f, _ = fresnel(fresnel_model, abs(ci), relative_ior(wi, ng, ior))
    return mul(tint, max(1.0 - f, 0.0))
