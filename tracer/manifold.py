"""The specular manifold of a chain of smooth refractions: the formulas of manifold next-event
estimation (Hanika, Droske and Fascione 2015, "Manifold Next Event Estimation"; the stage that
uses them is mnee.py).

A chain x0 (a diffuse receiver, fixed), x1 .. xk (points on smooth refracting triangles), y (a
point on a lamp, fixed) obeys Snell's law at every xi exactly when each vertex's generalized
half vector wi + eta wo (wi towards x(i-1), wo towards x(i+1), eta the ratio of the indices on
wo's side and wi's) is parallel to its shading normal: its two components along a tangent
frame (s, t) of the shading normal vanish (the constraint). Each vertex moves in the plane of
its triangle, by two coordinates along unit tangents (a, b) of that plane; the shading normal
is the interpolated vertex normal, whose derivatives along a and b the constraint's
derivatives need. Newton's method on the constraint walks a seed chain (the straight segment
x0 y) onto the manifold; the implicit function theorem then gives how x1 moves with y, whose
determinant is the generalized geometry term that turns the lamp's area density into x0's
solid angle.

Each formula is one scalar function over tuples; the chain's linear algebra uses a scratch
matrix of 2k rows (k at most MAX_CASTERS), since compiled code allocates nothing.
"""
from __future__ import annotations

import math

from .fresnel import fresnel
from .jit import jit_inline
from .vec import add, cross, dot, madd, mul, neg, sub

MAX_CASTERS = 6          # refracting vertices in a chain (Cycles' MNEE_MAX_CAUSTIC_CASTERS)
# Below this |pivot| the chain's Jacobian counts as singular (no solution to walk to).
SINGULAR = 1e-12


@jit_inline
def unit_towards(p, q):
    """(unit direction from p to q, distance)."""
    d = sub(q, p)
    length = math.sqrt(dot(d, d))
    return mul(d, 1.0 / length), length


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
def constraint(p_prev, p, p_next, n, a, ng, ior):
    """The constraint at vertex p (shading normal n, tangent a of its triangle, geometric normal
    ng, index ior) between p_prev and p_next: the half vector's components (along s, along t)
    of the shading frame; (0, 0) where the path refracts by Snell's law."""
    wi, _ = unit_towards(p, p_prev)
    wo, _ = unit_towards(p, p_next)
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
def constraint_derivatives(p_prev, p, p_next, n, dn_da, dn_db, a, b, ng, ior, prev_ab, next_ab):
    """The constraint's derivatives at vertex p (constraint's arguments; dn_da, dn_db the
    shading normal's derivatives along its triangle's unit tangents a and b) with respect to
    the tangent coordinates of p_prev (along prev_ab = (a', b')), of p itself and of p_next
    (along next_ab): three 2x2 blocks, each (dC0/du, dC0/dv, dC1/du, dC1/dv)."""
    wi, li = unit_towards(p, p_prev)
    wo, lo = unit_towards(p, p_next)
    eta = relative_ior(wi, ng, ior)
    h, h_length = half_vector(wi, wo, eta)
    s, t, s_length = shading_frame(n, a)
    zero = (0.0, 0.0, 0.0)
    # The previous vertex moves wi only, the next one wo only; the frame stays.
    pu = _moved_end(wi, li, wo, lo, eta, h, h_length, s, t, prev_ab[0], zero)
    pv = _moved_end(wi, li, wo, lo, eta, h, h_length, s, t, prev_ab[1], zero)
    nu = _moved_end(wi, li, wo, lo, eta, h, h_length, s, t, zero, next_ab[0])
    nv = _moved_end(wi, li, wo, lo, eta, h, h_length, s, t, zero, next_ab[1])
    # p itself moves both directions' near ends (their far ends by -e), the normal and frame.
    su = _moved_end(wi, li, wo, lo, eta, h, h_length, s, t, neg(a), neg(a))
    sv = _moved_end(wi, li, wo, lo, eta, h, h_length, s, t, neg(b), neg(b))
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
def solve_in_place(m, rows, columns):
    """Gaussian elimination with partial pivoting of the system in m[:rows, :rows] with
    right-hand sides m[:rows, rows:columns], the solutions left there; returns the
    determinant of the square part (0 where singular)."""
    det = 1.0
    for c in range(rows):
        pivot = c
        for r in range(c + 1, rows):
            if abs(m[r, c]) > abs(m[pivot, c]):
                pivot = r
        if abs(m[pivot, c]) < SINGULAR:
            return 0.0
        if pivot != c:
            det = -det
            for j in range(columns):
                m[c, j], m[pivot, j] = m[pivot, j], m[c, j]
        det *= m[c, c]
        inv = 1.0 / m[c, c]
        for r in range(rows):
            if r != c and m[r, c] != 0.0:
                f = m[r, c] * inv
                for j in range(c, columns):
                    m[r, j] -= f * m[c, j]
    for r in range(rows):
        inv = 1.0 / m[r, r]
        for j in range(rows, columns):
            m[r, j] *= inv
        m[r, r] = 1.0
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
def fill_system(m, k, x0, y, y_ab, pos, n, dn_da, dn_db, ta, tb, ng, ior):
    """Fill m[:2k, :2k + 3] for the chain x0, pos[0 .. k), y (vertex i: shading normal n[i]
    and its derivatives, tangents ta[i], tb[i] of its triangle, geometric normal ng[i], index
    ior[i]; y_ab the lamp's tangents at y): columns 0 .. 2k the constraint's Jacobian in the
    vertices' tangent coordinates (block tridiagonal), 2k and 2k + 1 its derivatives in y's,
    2k + 2 the constraint itself. Returns the largest |constraint| of a vertex."""
    cols = 2 * k + 3
    for r in range(2 * k):
        for j in range(cols):
            m[r, j] = 0.0
    worst = 0.0
    for i in range(k):
        p = vertex_row(pos, i)
        p_prev = x0 if i == 0 else vertex_row(pos, i - 1)
        p_next = y if i == k - 1 else vertex_row(pos, i + 1)
        # x0 is fixed: its tangents are never used (y_ab stands in).
        prev_ab = (vertex_row(ta, i - 1), vertex_row(tb, i - 1)) if i > 0 else y_ab
        next_ab = (vertex_row(ta, i + 1), vertex_row(tb, i + 1)) if i < k - 1 else y_ab
        a, b, ngi = vertex_row(ta, i), vertex_row(tb, i), vertex_row(ng, i)
        ni = vertex_row(n, i)
        c = constraint(p_prev, p, p_next, ni, a, ngi, ior[i])
        worst = max(worst, math.sqrt(c[0] * c[0] + c[1] * c[1]))
        m[2 * i, 2 * k + 2], m[2 * i + 1, 2 * k + 2] = c[0], c[1]
        before, here, after = constraint_derivatives(
            p_prev, p, p_next, ni, vertex_row(dn_da, i), vertex_row(dn_db, i), a, b, ngi,
            ior[i], prev_ab, next_ab)
        if i > 0:
            put_block(m, 2 * i, 2 * i - 2, before)
        put_block(m, 2 * i, 2 * i, here)
        # The last vertex's next is the lamp point: its block lands in dC/dy's columns.
        put_block(m, 2 * i, 2 * i + 2, after)
    return worst


@jit_inline
def transfer_determinant(m, k):
    """|det dx1/dy| from a solved system (solve_in_place) whose last two columns were dC/dy:
    the rows of x1's coordinates hold -dx1/dy (the implicit function theorem)."""
    return abs(m[0, 2 * k] * m[1, 2 * k + 1] - m[0, 2 * k + 1] * m[1, 2 * k])


@jit_inline
def geometry_term(x0, x1, ng1, transfer):
    """The generalized geometry term dw0/dA(y): x0's solid angle per unit of lamp area, from x1
    (on a triangle of geometric normal ng1) and |det dx1/dy| (transfer_determinant)."""
    w, distance = unit_towards(x0, x1)
    return abs(dot(w, ng1)) / (distance * distance) * transfer


@jit_inline
def refraction_weight(fresnel_model, wi, wo, n, ng, ior, tint):
    """What the path tracer's smooth refraction carries, on average, from wo's side to wi's at a
    vertex (shading normal n): tint x (1 - F), and 0 unless wi and wo are on opposite sides
    of both normals (as specular.sample_specular's validity)."""
    ci = dot(wi, n)
    if not (ci * dot(wo, n) < 0.0 and dot(wi, ng) * dot(wo, ng) < 0.0):
        return (0.0, 0.0, 0.0)
    f, _ = fresnel(fresnel_model, abs(ci), relative_ior(wi, ng, ior))
    return mul(tint, max(1.0 - f, 0.0))
