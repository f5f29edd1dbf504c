"""The manifold formulas of manifold next-event estimation (tracer/manifold.py): the constraint's
derivatives against finite differences, the chain's block solve against numpy, and on a flat
interface (where Snell's law is the answer) the Newton walk's solution and the generalized
geometry term against finite differences of the solved map from the lamp point (or a sun's
direction) to x0's direction."""
from __future__ import annotations

import math

import numpy as np
import pytest

from snell.tracer import manifold
from snell.tracer.fresnel import fresnel_dielectric
from snell.tracer.sampling import orthonormal_basis

RNG = np.random.default_rng(34)
STILL = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))      # a next vertex that does not move with p


def _triangle():
    """A small tilted triangle with distinct, smoothly varying vertex normals."""
    corners = np.array([[0.0, 0.0, 0.0], [0.3, 0.02, 0.05], [0.04, 0.25, -0.03]])
    normals = np.array([[0.1, -0.05, 1.0], [-0.15, 0.1, 1.0], [0.05, 0.2, 1.0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return corners, normals


def _ng(corners):
    c = np.cross(corners[1] - corners[0], corners[2] - corners[0])
    return c / np.linalg.norm(c)


def _barycentrics(corners, p):
    e1, e2 = corners[1] - corners[0], corners[2] - corners[0]
    g = np.array([[e1 @ e1, e1 @ e2], [e1 @ e2, e2 @ e2]])
    return np.linalg.solve(g, [e1 @ (p - corners[0]), e2 @ (p - corners[0])])


def _normal_at(corners, normals, p, a, b):
    b1, b2 = _barycentrics(corners, p)
    return manifold.normal_derivatives(corners, normals, b1, b2, tuple(a), tuple(b))


def test_normal_derivatives_match_finite_differences():
    corners, normals = _triangle()
    a, b = orthonormal_basis(tuple(_ng(corners)))
    p = corners[0] + 0.3 * (corners[1] - corners[0]) + 0.25 * (corners[2] - corners[0])
    n, dn_da, dn_db = _normal_at(corners, normals, p, a, b)
    h = 1e-6
    for e, analytic in ((a, dn_da), (b, dn_db)):
        plus = np.array(_normal_at(corners, normals, p + h * np.array(e), a, b)[0])
        minus = np.array(_normal_at(corners, normals, p - h * np.array(e), a, b)[0])
        assert np.allclose((plus - minus) / (2 * h), analytic, atol=1e-7)
    assert abs(np.linalg.norm(n) - 1.0) < 1e-12


def _constraint_at(corners, normals, ior, prev, p, nxt, fixed=False):
    a, b = orthonormal_basis(tuple(_ng(corners)))
    n, _, _ = _normal_at(corners, normals, p, a, b)
    return np.array(manifold.constraint(tuple(prev), tuple(p), tuple(nxt), n, a,
                                        tuple(_ng(corners)), ior, fixed))


@pytest.mark.parametrize("below", [False, True])
@pytest.mark.parametrize("fixed", [False, True])
def test_constraint_derivatives_match_finite_differences(below, fixed):
    """Each of the three 2x2 blocks against central differences, the path entering the glass
    from above (eta = ior) and leaving it (eta = 1 / ior); with the next end a fixed direction
    (a sun's: p's own moves do not turn it, and its coordinates are the direction's along two
    unit tangents)."""
    corners, normals = _triangle()
    ng = _ng(corners)
    a, b = orthonormal_basis(tuple(ng))
    p = corners[0] + 0.4 * (corners[1] - corners[0]) + 0.3 * (corners[2] - corners[0])
    prev = p + (1.0 if not below else -1.0) * np.array([0.2, -0.1, 0.9])
    nxt = p - (1.0 if not below else -1.0) * np.array([-0.3, 0.25, 1.4])
    prev_ab = tuple(map(tuple, np.linalg.qr(RNG.normal(size=(3, 2)))[0].T))
    next_ab = tuple(map(tuple, np.linalg.qr(RNG.normal(size=(3, 2)))[0].T))
    if fixed:
        nxt = (nxt - p) / np.linalg.norm(nxt - p)
        next_ab = orthonormal_basis(tuple(nxt))
    n, dn_da, dn_db = _normal_at(corners, normals, p, a, b)
    ior = 1.45
    before, here, after = manifold.constraint_derivatives(
        tuple(prev), tuple(p), tuple(nxt), n, dn_da, dn_db, a, b, tuple(ng), ior, prev_ab,
        next_ab, fixed, STILL)
    h = 1e-6

    def block(move):
        cols = []
        for e in range(2):
            plus = _constraint_at(corners, normals, ior, *move(e, h), fixed)
            minus = _constraint_at(corners, normals, ior, *move(e, -h), fixed)
            cols.append((plus - minus) / (2 * h))
        return np.array([cols[0][0], cols[1][0], cols[0][1], cols[1][1]])

    def moved(which, ab):
        def move(e, step):
            pts = [prev.copy(), p.copy(), nxt.copy()]
            pts[which] = pts[which] + step * np.array(ab[e])
            if fixed and which == 2:
                pts[2] /= np.linalg.norm(pts[2])
            return pts
        return move

    assert np.allclose(block(moved(0, prev_ab)), before, atol=1e-6)
    assert np.allclose(block(moved(1, (a, b))), here, atol=1e-6)
    assert np.allclose(block(moved(2, next_ab)), after, atol=1e-6)


def _system(m, k):
    """The dense Jacobian (2k x 2k) and right-hand sides (2k x 3) of fill_system's block layout
    in m."""
    a = np.zeros((2 * k, 2 * k))
    for i in range(k):
        r = slice(2 * i, 2 * i + 2)
        if i > 0:
            a[r, 2 * i - 2:2 * i] = m[r, manifold.BEFORE:manifold.BEFORE + 2]
        a[r, 2 * i:2 * i + 2] = m[r, manifold.HERE:manifold.HERE + 2]
        if i < k - 1:
            a[r, 2 * i + 2:2 * i + 4] = m[r, manifold.AFTER:manifold.AFTER + 2]
    return a, m[:2 * k, manifold.DY:].copy()


@pytest.mark.parametrize("k", [1, 2, 4, manifold.MAX_CASTERS])
def test_solve_blocks_matches_numpy(k):
    """The block LU's solutions and determinant against numpy's dense solve of the same block
    tridiagonal system (the blocks outside the band, a first vertex's BEFORE and a last one's
    AFTER, hold garbage the solve must not read)."""
    m = RNG.normal(size=(2 * manifold.MAX_CASTERS, manifold.SYSTEM_COLUMNS))
    for i in range(k):
        m[2 * i:2 * i + 2, manifold.HERE:manifold.HERE + 2] += 4 * np.eye(2)
    a, rhs = _system(m, k)
    det = manifold.solve_blocks(m, k)
    assert np.allclose(m[:2 * k, manifold.DY:], np.linalg.solve(a, rhs), atol=1e-12)
    assert det == pytest.approx(np.linalg.det(a), rel=1e-10)
    singular = np.zeros((12, manifold.SYSTEM_COLUMNS))
    singular[:2, manifold.HERE:manifold.HERE + 2] = [[1.0, 2.0], [2.0, 4.0]]
    assert manifold.solve_blocks(singular, 1) == 0.0


# -- a flat interface: the plane z = 0, glass below ------------------------------------------

IOR = 1.33
UP = (0.0, 0.0, 1.0)


def _lamp_tangents(y, fixed):
    """The lamp's tangents: the world's x and y at a point, a sun direction's own."""
    return orthonormal_basis(tuple(y)) if fixed else ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def _flat_system(x0, y, x1, fixed=False):
    """fill_system for one vertex x1 on the plane z = 0 (flat normals, glass below); y a lamp
    point, or a sun's direction where fixed."""
    m = np.zeros((12, manifold.SYSTEM_COLUMNS))
    a, b = orthonormal_basis(UP)
    rows = lambda v: np.array([v], np.float64)   # noqa: E731
    worst = manifold.fill_system(m, 1, tuple(x0), tuple(y), _lamp_tangents(y, fixed), fixed,
                                 rows(x1), rows(UP), np.zeros((1, 3)), np.zeros((1, 3)), rows(a),
                                 rows(b), rows(UP), np.array([IOR]), STILL)
    return m, worst, a, b


def _solve_flat(x0, y, iterations=30, fixed=False):
    """Newton's walk from the straight segment's crossing of the plane (what mnee.py does, the
    projection onto a plane being exact)."""
    x0, y = np.asarray(x0, float), np.asarray(y, float)
    d = y if fixed else y - x0
    x1 = x0 + d * (-x0[2] / d[2])
    for _ in range(iterations):
        m, worst, a, b = _flat_system(x0, y, x1, fixed)
        if worst < 1e-13:
            break
        assert manifold.solve_blocks(m, 1) != 0.0
        x1 = x1 - m[0, manifold.C] * np.array(a) - m[1, manifold.C] * np.array(b)
    return x1


def test_newton_on_a_flat_interface_obeys_snells_law():
    x0, y = (0.1, -0.2, -0.7), (1.2, 0.5, 2.0)
    x1 = _solve_flat(x0, y)
    _, worst, _, _ = _flat_system(x0, y, x1)
    assert worst < 1e-12
    w_in = (x1 - np.array(x0)) / np.linalg.norm(x1 - np.array(x0))   # in the glass
    w_out = (np.array(y) - x1) / np.linalg.norm(np.array(y) - x1)     # in the air
    sin_glass = np.linalg.norm(np.cross(w_in, UP))
    sin_air = np.linalg.norm(np.cross(w_out, UP))
    assert IOR * sin_glass == pytest.approx(sin_air, rel=1e-10)
    # Coplanar with the normal: both directions' horizontal parts point the same way.
    assert np.cross(w_in[:2], w_out[:2]) == pytest.approx(0.0, abs=1e-12)


def _direction(x0, y, fixed=False):
    x1 = _solve_flat(x0, y, fixed=fixed)
    w = x1 - np.array(x0)
    return w / np.linalg.norm(w), x1


def test_geometry_term_is_the_solid_angle_per_lamp_area():
    """dw0/dA(y) from the transfer matrix against the solid angle that a small square of the
    lamp's plane maps to (finite differences of the solved chain)."""
    x0, y = np.array([0.1, -0.2, -0.7]), np.array([1.2, 0.5, 2.0])
    w, x1 = _direction(x0, y)
    m, _, _, _ = _flat_system(x0, y, x1)
    manifold.solve_blocks(m, 1)
    g = manifold.geometry_term(tuple(x0), tuple(x1), UP, manifold.transfer_determinant(m))
    h = 1e-5
    wx = (_direction(x0, y + [h, 0, 0])[0] - _direction(x0, y - [h, 0, 0])[0]) / (2 * h)
    wy = (_direction(x0, y + [0, h, 0])[0] - _direction(x0, y - [0, h, 0])[0]) / (2 * h)
    solid_angle = abs(np.dot(np.cross(wx, wy), w))
    assert g == pytest.approx(solid_angle, rel=1e-5)
    # Without the interface (ior 1) it is the plain cos / d^2 of a lamp facing up.
    d = y - x0
    assert solid_angle != pytest.approx(abs(d[2]) / np.linalg.norm(d) ** 3, rel=0.05)


# -- a point lamp's disk, which faces the vertex that sees it (lights/point.py) ---------------

CENTRE = np.array([1.2, 0.5, 2.0])
FACING_X0 = np.array([0.1, -0.2, -0.7]) - CENTRE
FACING_X0 /= np.linalg.norm(FACING_X0)


def _disk_offset(s, t):
    """The offset s a + t b on the disk facing x0 (a, b its tangents)."""
    a, b = (np.array(e) for e in orthonormal_basis(tuple(FACING_X0)))
    return s * a + t * b


def _facing_point(q, p):
    """facing_disk's point of offset q for the disk of centre CENTRE facing p."""
    return manifold.facing_disk(tuple(CENTRE), tuple(q), tuple(FACING_X0), p, UP, UP)[0]


def test_the_facing_disks_point_turns_with_the_vertex_and_keeps_its_offset():
    """facing_disk's point: on the disk facing p at |q| from its centre, q itself where p is on
    q's own disk's axis; its normal the direction to p; its motion against finite
    differences."""
    q = tuple(_disk_offset(0.3, -0.2))
    on_axis = tuple(CENTRE + 2.5 * FACING_X0)
    assert _facing_point(q, on_axis) == \
        pytest.approx(tuple(CENTRE + q), abs=1e-12)
    p = np.array([0.4, 0.1, 0.0])
    y = np.array(_facing_point(q, tuple(p)))
    normal = (p - CENTRE) / np.linalg.norm(p - CENTRE)
    assert manifold.facing_disk(tuple(CENTRE), q, tuple(FACING_X0), tuple(p), UP, UP)[1] == \
        pytest.approx(tuple(normal), abs=1e-12)
    assert np.dot(y - CENTRE, normal) == pytest.approx(0.0, abs=1e-12)
    assert np.linalg.norm(y - CENTRE) == pytest.approx(np.linalg.norm(q), rel=1e-12)
    assert np.linalg.norm(y - CENTRE - q) > 0.01            # it turned
    h = 1e-6
    for e in np.eye(3):
        moved = [np.array(_facing_point(q, tuple(p + sign * h * e))) for sign in (1, -1)]
        motion = manifold.facing_disk(tuple(CENTRE), q, tuple(FACING_X0), tuple(p), tuple(e),
                                      tuple(e))[2]
        assert motion == pytest.approx(tuple((moved[0] - moved[1]) / (2 * h)), abs=1e-8)


def _facing_system(x0, q, x1, turning=True):
    """fill_system for one vertex x1 on the plane z = 0 and the lamp point of offset q on the
    disk of centre CENTRE that faces x1 (turning: the point moves with x1)."""
    m = np.zeros((12, manifold.SYSTEM_COLUMNS))
    a, b = orthonormal_basis(UP)
    y, normal, along_a, along_b = manifold.facing_disk(tuple(CENTRE), tuple(q),
                                                       tuple(FACING_X0), tuple(x1), a, b)
    motion = (along_a, along_b) if turning else STILL
    rows = lambda v: np.array([v], np.float64)   # noqa: E731
    worst = manifold.fill_system(m, 1, tuple(x0), y, orthonormal_basis(tuple(normal)), False,
                                 rows(x1), rows(UP), np.zeros((1, 3)), np.zeros((1, 3)), rows(a),
                                 rows(b), rows(UP), np.array([IOR]), motion)
    return m, worst, a, b


def _solve_facing(x0, q, iterations=40):
    """x0's unit direction to x1 and x1 of the chain to the facing disk's point of offset q."""
    x0 = np.asarray(x0, float)
    d = CENTRE + q - x0
    x1 = x0 + d * (-x0[2] / d[2])
    for _ in range(iterations):
        m, worst, a, b = _facing_system(x0, q, x1)
        if worst < 1e-13:
            break
        assert manifold.solve_blocks(m, 1) != 0.0
        x1 = x1 - m[0, manifold.C] * np.array(a) - m[1, manifold.C] * np.array(b)
    w = x1 - x0
    return w / np.linalg.norm(w), x1


def test_a_facing_disks_geometry_term_is_the_solid_angle_per_disk_area():
    """The chain to a point lamp's disk that faces its last vertex (the disk the path tracer's
    ray from that vertex finds): the walk converges with the lamp point moving with x1, and
    the geometry term is x0's solid angle per unit of the disk's area, against finite
    differences of the solved chain over the offset. With the disk held facing x0 instead
    (the lamp point not moving with x1) it is not."""
    x0 = np.array([0.1, -0.2, -0.7])
    q = _disk_offset(0.6, -0.4)
    w, x1 = _solve_facing(x0, q)
    m, worst, _, _ = _facing_system(x0, q, x1)
    assert worst < 1e-12
    manifold.solve_blocks(m, 1)
    g = manifold.geometry_term(tuple(x0), tuple(x1), UP, manifold.transfer_determinant(m))
    h = 1e-5
    ws = (_solve_facing(x0, q + _disk_offset(h, 0))[0] -
          _solve_facing(x0, q - _disk_offset(h, 0))[0]) / (2 * h)
    wt = (_solve_facing(x0, q + _disk_offset(0, h))[0] -
          _solve_facing(x0, q - _disk_offset(0, h))[0]) / (2 * h)
    solid_angle = abs(np.dot(np.cross(ws, wt), w))
    assert g == pytest.approx(solid_angle, rel=1e-5)
    m, _, _, _ = _facing_system(x0, q, x1, turning=False)
    manifold.solve_blocks(m, 1)
    still = manifold.geometry_term(tuple(x0), tuple(x1), UP, manifold.transfer_determinant(m))
    assert still != pytest.approx(solid_angle, rel=1e-3)


def _sun_solid_angle(direction, solve):
    """|dw0 x dw0| . w0 per unit of the sun's solid angle: finite differences of solve (a sun
    direction to x0's unit direction) along the direction's two unit tangents."""
    a, b = (np.array(e) for e in orthonormal_basis(tuple(direction)))
    h = 1e-5

    def turned(e, step):
        v = direction + step * e
        return solve(v / np.linalg.norm(v))

    wx = (turned(a, h) - turned(a, -h)) / (2 * h)
    wy = (turned(b, h) - turned(b, -h)) / (2 * h)
    return abs(np.dot(np.cross(wx, wy), solve(direction)))


def test_a_suns_geometry_term_is_the_solid_angle_per_sun_solid_angle():
    """A fixed direction (a sun's) at the end of the chain: the walk's x1 sends the light on
    along the sun's direction by Snell's law, and the geometry term is dw0/dw(sun), against
    finite differences of the solved chain. Through a flat interface the map is a rotation-
    free refraction, so it is not 1 (cos ratios times eta^2), which the test checks too."""
    x0 = np.array([0.1, -0.2, -0.7])
    sun = np.array([0.4, 0.2, 1.0]) / np.linalg.norm([0.4, 0.2, 1.0])
    w, x1 = _direction(x0, sun, fixed=True)
    # Leaving the glass along the sun's direction: Snell's law between w and sun.
    sin_glass, sin_air = np.linalg.norm(np.cross(w, UP)), np.linalg.norm(np.cross(sun, UP))
    assert IOR * sin_glass == pytest.approx(sin_air, rel=1e-10)
    m, _, _, _ = _flat_system(x0, sun, x1, fixed=True)
    manifold.solve_blocks(m, 1)
    g = manifold.geometry_term(tuple(x0), tuple(x1), UP, manifold.transfer_determinant(m))
    expected = _sun_solid_angle(sun, lambda s: _direction(x0, s, fixed=True)[0])
    assert g == pytest.approx(expected, rel=1e-5)
    assert g != pytest.approx(1.0, rel=0.05)


def test_refraction_weight_is_one_minus_fresnel_through_glass_on_opposite_sides():
    n = UP
    wi = (0.3, 0.0, math.sqrt(1 - 0.09))            # from above: entering the glass
    wo = (-0.2, 0.0, -math.sqrt(1 - 0.04))
    f, _ = fresnel_dielectric(math.sqrt(1 - 0.09), IOR)
    weight = manifold.refraction_weight(0, wi, wo, n, n, IOR, (1.0, 0.5, 0.25), True)
    assert weight == pytest.approx(((1 - f), 0.5 * (1 - f), 0.25 * (1 - f)))
    assert manifold.refraction_weight(0, wi, wi, n, n, IOR, (1.0, 1.0, 1.0), True) == \
        (0.0, 0.0, 0.0)
    # A refraction-only surface (Cycles' Refraction BSDF) has no Fresnel: its tint alone.
    assert manifold.refraction_weight(0, wi, wo, n, n, IOR, (1.0, 0.5, 0.25), False) == \
        (1.0, 0.5, 0.25)
    assert manifold.refraction_weight(0, wi, wi, n, n, IOR, (1.0, 1.0, 1.0), False) == \
        (0.0, 0.0, 0.0)


# -- a slab: two flat interfaces (a chain of two vertices) -----------------------------------

DOWN = (0.0, 0.0, -1.0)
SLAB = 0.2                 # the slab's thickness below z = 0; its bottom faces down


def _slab_system(x0, y, x1, x2, fixed=False):
    """fill_system for the chain x0 (below the slab), x2 on its bottom, x1 on its top, y (a
    sun's direction where fixed)."""
    m = np.zeros((12, manifold.SYSTEM_COLUMNS))
    a_top, b_top = orthonormal_basis(UP)
    a_bottom, b_bottom = orthonormal_basis(DOWN)
    worst = manifold.fill_system(
        m, 2, tuple(x0), tuple(y), _lamp_tangents(y, fixed), fixed, np.array([x2, x1]),
        np.array([DOWN, UP]), np.zeros((2, 3)), np.zeros((2, 3)), np.array([a_bottom, a_top]),
        np.array([b_bottom, b_top]), np.array([DOWN, UP]), np.array([IOR, IOR]), STILL)
    return m, worst, (a_bottom, b_bottom), (a_top, b_top)


def _solve_slab(x0, y, iterations=40, fixed=False):
    x0, y = np.asarray(x0, float), np.asarray(y, float)
    d = y if fixed else y - x0
    x2 = x0 + d * ((-SLAB - x0[2]) / d[2])
    x1 = x0 + d * (-x0[2] / d[2])
    c = manifold.C
    for _ in range(iterations):
        m, worst, (a2, b2), (a1, b1) = _slab_system(x0, y, x1, x2, fixed)
        if worst < 1e-13:
            break
        assert manifold.solve_blocks(m, 2) != 0.0
        x2 = x2 - m[0, c] * np.array(a2) - m[1, c] * np.array(b2)
        x1 = x1 - m[2, c] * np.array(a1) - m[3, c] * np.array(b1)
    return x1, x2, m


def test_a_chain_of_two_interfaces_refracts_at_both():
    """Newton's walk on a slab converges to the path that bends by Snell's law at both faces
    and leaves parallel to the direction it entered with (a slab shifts, never turns, a
    ray)."""
    x0, y = np.array([0.1, -0.2, -0.9]), np.array([1.0, 0.6, 1.5])
    x1, x2, _ = _solve_slab(x0, y)
    _, worst, _, _ = _slab_system(x0, y, x1, x2)
    assert worst < 1e-12
    unit = lambda v: v / np.linalg.norm(v)      # noqa: E731
    below, inside, above = unit(x2 - x0), unit(x1 - x2), unit(y - x1)
    assert np.allclose(below, above, atol=1e-10)
    sin_air = np.linalg.norm(np.cross(above, UP))
    assert IOR * np.linalg.norm(np.cross(inside, UP)) == pytest.approx(sin_air, rel=1e-10)


def test_a_chains_geometry_term_is_the_solid_angle_per_lamp_area():
    """The two-vertex chain's transfer determinant gives dw0/dA(y) as finite differences of
    the solved chain do."""
    x0, y = np.array([0.1, -0.2, -0.9]), np.array([1.0, 0.6, 1.5])

    def direction(y):
        _, x2, _ = _solve_slab(x0, y)
        return (x2 - x0) / np.linalg.norm(x2 - x0), x2

    w, x2 = direction(y)
    x1, _, _ = _solve_slab(x0, y)
    m, _, _, _ = _slab_system(x0, y, x1, x2)
    manifold.solve_blocks(m, 2)
    g = manifold.geometry_term(tuple(x0), tuple(x2), DOWN, manifold.transfer_determinant(m))
    h = 1e-5
    wx = (direction(y + [h, 0, 0])[0] - direction(y - [h, 0, 0])[0]) / (2 * h)
    wy = (direction(y + [0, h, 0])[0] - direction(y - [0, h, 0])[0]) / (2 * h)
    assert g == pytest.approx(abs(np.dot(np.cross(wx, wy), w)), rel=1e-5)


def test_a_slab_under_the_sun_passes_it_unturned_and_its_geometry_term_is_one():
    """Two vertices and a fixed direction: a slab shifts, never turns, the sun's light, so x0's
    direction is the sun's (Snell's law at both faces) and dw0/dw(sun) is exactly 1, as finite
    differences also give."""
    x0 = np.array([0.1, -0.2, -0.9])
    sun = np.array([0.5, 0.3, 1.0]) / np.linalg.norm([0.5, 0.3, 1.0])

    def solve(direction):
        _, x2, _ = _solve_slab(x0, direction, fixed=True)
        return (x2 - x0) / np.linalg.norm(x2 - x0)

    assert np.allclose(solve(sun), sun, atol=1e-10)
    x1, x2, _ = _solve_slab(x0, sun, fixed=True)
    m, _, _, _ = _slab_system(x0, sun, x1, x2, fixed=True)
    manifold.solve_blocks(m, 2)
    g = manifold.geometry_term(tuple(x0), tuple(x2), DOWN, manifold.transfer_determinant(m))
    assert g == pytest.approx(1.0, rel=1e-8)
    assert _sun_solid_angle(sun, solve) == pytest.approx(1.0, rel=1e-5)
