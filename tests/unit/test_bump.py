"""Bump mapping's formulas (tracer/shader/bump.py, Cycles' svm_node_set_bump and its
differentials) and the instructions that move the hit a Bump node's Height is read at, run
through program.run."""
from __future__ import annotations

import math

import numpy as np
import pytest

from snell.tracer import lobes
from snell.tracer.materials import material_tables
from snell.tracer.microfacet_tables import shipped_tables
from snell.tracer.shader import bump, inputs, program
from snell.tracer.shader.program import check_program


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def _frame(n):
    """A right-handed frame (t, b, n) around unit n."""
    n = _unit(n)
    t = _unit(np.cross([0.3, 0.5, 0.8], n))
    return t, np.cross(n, t), n


def _bumped(gradient, n, ng, distance, strength=1.0, invert=False, width=0.1, cone=0.01,
            point=(0.2, -0.1, 0.4)):
    """bump_normal for the linear height h(P) = gradient . P sampled as Cycles samples it."""
    dx, dy = bump.differentials(tuple(ng), cone)
    p = np.asarray(point, float)
    g = np.asarray(gradient, float)
    heights = (g @ p, g @ (p + width * np.asarray(dx)), g @ (p + width * np.asarray(dy)))
    return np.asarray(bump.bump_normal(heights, strength, distance, invert, width, tuple(n),
                                       dx, dy))


@pytest.mark.parametrize("n", [(0.0, 0.0, 1.0), (0.6, -0.48, 0.64), (-1.0, 0.0, 0.0),
                               (0.0, 0.0, -1.0)])
@pytest.mark.parametrize("distance, invert", [(0.5, False), (0.05, False), (0.5, True)])
def test_linear_height_bends_the_normal_by_its_surface_gradient(n, distance, invert):
    """A height of known gradient g: Cycles' bumped normal is normalize(n - d (g - (g.n) n))
    (d the Distance, negated when inverted), whatever the differentials' width, and on any
    side (a back face's n and Ng face the ray). (Deliberate errors, measured: the height
    differences' sign flipped (n + d g_t) puts components off by up to 0.65, and the Distance
    read 10% larger by 0.012-0.028, against a tolerance of 1e-9: every case fails.)"""
    n = _unit(n)
    g = np.array([0.3, -0.7, 0.45])
    d = -distance if invert else distance
    expect = _unit(n - d * (g - (g @ n) * n))
    for cone in (1e-4, 0.01, 1.0):
        got = _bumped(g, n, n, distance, invert=invert, cone=cone)
        assert np.allclose(got, expect, atol=1e-9), (cone, got, expect)


def test_strength_mixes_linearly_from_the_unbent_normal():
    """Strength s: normalize(s bent + (1 - s) n), clamped at 0 below (Cycles has no upper
    clamp). (Deliberate errors: the clamp at 0 left out fails at strength -1; the Distance
    10% larger fails too.)"""
    n = np.array([0.0, 0.0, 1.0])
    g = np.array([1.2, 0.4, 0.0])
    full = _unit(n - 0.5 * g)
    for s in (0.0, 0.25, 0.5, 1.0, 1.5):
        expect = _unit(s * full + (1.0 - s) * n)
        assert np.allclose(_bumped(g, n, n, 0.5, strength=s), expect, atol=1e-12)
    assert np.allclose(_bumped(g, n, n, 0.5, strength=-1.0), n, atol=1e-12)


def test_no_width_or_no_gradient_leaves_the_normal():
    """A zero differential (det 0) gives the unbent normal, as Cycles' is_zero fallback; a
    flat height too."""
    n = np.array([0.0, 0.6, 0.8])
    assert np.allclose(_bumped([1.0, 2.0, 3.0], n, n, 0.5, cone=0.0), n)
    assert np.allclose(_bumped([0.0, 0.0, 0.0], n, n, 0.5), n)


def test_heights_that_are_not_finite_leave_the_normal():
    """NaN or infinite heights or strength: the unbent normal, never NaN (Snell writes no NaN
    into an image). (Deliberate error: the finite check left out returns NaN, caught.)"""
    n = (0.0, 0.0, 1.0)
    dx, dy = bump.differentials(n, 0.01)
    for heights, strength in [((math.nan, 0.0, 0.0), 1.0), ((0.0, math.inf, 0.0), 1.0),
                              ((0.0, 0.1, 0.2), math.nan)]:
        got = bump.bump_normal(heights, strength, 0.5, False, 0.1, n, dx, dy)
        assert np.allclose(got, n), (heights, strength, got)


def test_input_normal_other_than_the_frame_normal():
    """A Normal input other than Ng (the differentials stay along Ng's frame): Cycles'
    formula written out in numpy, N' = normalize(w |det| n - d sign(det) ((h_x - h_c) Rx +
    (h_y - h_c) Ry)) with Rx = dP.dy x n, Ry = n x dP.dx, det = dP.dx . Rx. (The sign and
    Distance errors above fail here too.)"""
    ng = _unit([0.1, 0.2, 1.0])
    n = _unit([0.3, -0.1, 1.0])
    g = np.array([0.5, 0.2, -0.3])
    width, cone, distance = 0.1, 0.02, 0.3
    dx, dy = (np.asarray(v) for v in bump.differentials(tuple(ng), cone))
    rx, ry = np.cross(dy, n), np.cross(n, dx)
    det = dx @ rx
    p = np.array([0.2, 0.3, 0.1])
    hc, hx, hy = g @ p, g @ (p + width * dx), g @ (p + width * dy)
    expect = _unit(width * abs(det) * n - distance * np.sign(det) * ((hx - hc) * rx
                                                                      + (hy - hc) * ry))
    assert np.allclose(_bumped(g, n, ng, distance, width=width, cone=cone, point=p), expect,
                       atol=1e-12)


def test_make_orthonormals_is_cycles():
    """Cycles' make_orthonormals: a = normalize((1, 1, 1) x N) (or (-1, 1, 1) x N when N's
    components are equal), b = N x a."""
    for n in [(0.0, 0.0, 1.0), _unit([0.3, -0.4, 0.2]), _unit([1.0, 1.0, 1.0])]:
        n = np.asarray(n, float)
        ones = [1.0, 1.0, 1.0] if not (n[0] == n[1] == n[2]) else [-1.0, 1.0, 1.0]
        a_expect = _unit(np.cross(ones, n))
        a, b = (np.asarray(v) for v in bump.make_orthonormals(tuple(n)))
        assert np.allclose(a, a_expect, atol=1e-12)
        assert np.allclose(b, np.cross(n, a_expect), atol=1e-12)


def test_barycentric_step_moves_the_point_by_the_step():
    c = np.array([[0.1, 0.0, 0.2], [2.0, 0.3, 0.2], [0.4, 1.5, 0.2]])
    step = np.array([0.05, -0.02, 0.0])
    db1, db2 = bump.barycentric_step(c, tuple(step))
    assert np.allclose(db1 * (c[1] - c[0]) + db2 * (c[2] - c[0]), step, atol=1e-14)


def _camera(ortho=False):
    """Materials.camera of a camera at the origin looking down world -z (Blender's camera
    rotation the identity)."""
    from snell.tracer.shader import object_inputs
    cam = object_inputs.camera_table()
    cam[object_inputs.CAM_MATRIX:object_inputs.CAM_MATRIX + 12] = np.hstack(
        [np.diag([1.0, 1.0, -1.0]), np.zeros((3, 1))]).ravel()
    cam[object_inputs.CAM_ORTHO] = float(ortho)
    return cam


def test_camera_spread_is_cycles_compact_dD():
    """A perspective camera ray's dD is the mean of |normalize(D + dx) - normalize(D)| and its
    dy twin, D on the plane at distance 1 (kernel/camera/camera.h); at the centre about the
    pixel's size, off-axis smaller."""
    pixel = np.array([0.002, 0.002])
    cam = _camera()
    centre = bump.camera_spread(cam, pixel, (0.0, 0.0, -1.0))
    assert centre == pytest.approx(0.002, rel=1e-5)
    d = _unit([0.5, 0.2, -1.0])
    pc = d / -d[2]
    ex = _unit(pc + [0.002, 0, 0]) - _unit(pc)
    ey = _unit(pc + [0, 0.002, 0]) - _unit(pc)
    assert bump.camera_spread(cam, pixel, tuple(d)) == pytest.approx(
        0.5 * (np.linalg.norm(ex) + np.linalg.norm(ey)), rel=1e-12)
    assert bump.cone_width(cam, pixel, True, tuple(d), 3.0) == pytest.approx(
        3.0 * bump.camera_spread(cam, pixel, tuple(d)), rel=1e-12)
    # Orthographic: the pixel's size, whatever the distance.
    assert bump.cone_width(_camera(ortho=True), pixel, True, tuple(d), 3.0) == \
        pytest.approx(0.002)


def _program(code, constants, registers=None):
    rows = [row + [0] * (8 - len(row)) for row in code]
    return {"registers": registers if registers is not None else len(constants) + 40,
            "constants": constants, "code": rows}


CORNERS = np.array([[[-1.0, -1.0, 0.0], [3.0, -1.0, 0.0], [-1.0, 3.0, 0.0]]])


def _run(code, constants, texcoords, length=2.0, entering=True):
    """Run a program at a hit on one triangle (CORNERS, normal +z) seen by a camera ray from
    above (the camera's axis, or from below), with a camera of pixel 0.004 looking down -z;
    returns the registers."""
    mat = {"name": "P", "kind": "program", "program": _program(code, constants)}
    check_program(mat["program"], 0, 1)
    mats = material_tables([mat], np.zeros(1, np.int32), (),
                           [{"kind": "uv", "name": "",
                             "coords": np.asarray(texcoords, np.float32)[None]}])
    mats = mats._replace(programs=mats.programs._replace(corners=CORNERS,
                                                         pixel=np.array([0.004, 0.004])),
                         camera=_camera())
    regs = program.new_registers()
    scratch = np.zeros((lobes.MAX_LOBES, lobes.FIELDS))
    n = (0.0, 0.0, 1.0) if entering else (0.0, 0.0, -1.0)
    b1, b2 = 0.3, 0.2
    p = tuple((1 - b1 - b2) * CORNERS[0, 0] + b1 * CORNERS[0, 1] + b2 * CORNERS[0, 2])
    view = (0.0, 0.0, 1.0) if entering else (0.0, 0.0, -1.0)
    hit = (p, n, n, view, entering, 0, b1, b2, 1 << inputs.LP_CAMERA, 0, length)
    program.run(mats, 0, regs, hit, scratch, shipped_tables(), False)
    return regs, np.array(p)


def test_offset_moves_position_and_coordinates_together_and_restore_puts_them_back():
    """Between OFFSET and RESTORE, Geometry Position is the hit moved by its differential
    (Cycles' svm_node_bump_P_dx: P + dP.dx width, dP.dx = camera dD x distance along
    make_orthonormals(Ng)), and a per-corner coordinate moves with it (here a UV equal to
    the position's x, y); after RESTORE both are back. (Deliberate error, measured:
    barycentrics left unmoved, the UV stays at the hit while the position moves: fails.)"""
    uv = np.array([[[-1.0, -1.0, 0.0], [3.0, -1.0, 0.0], [-1.0, 3.0, 0.0]]])[0]
    width = 0.5
    # Registers: 0 the width constant; 1.. outputs.
    code = [[bump.OFFSET, bump.AXIS_X, 0], [inputs.GEOMETRY, 1, inputs.G_POSITION],
            [inputs.TEXCOORD, 4, 0], [bump.RESTORE],
            [bump.OFFSET, bump.AXIS_Y, 0], [inputs.GEOMETRY, 7, inputs.G_POSITION],
            [inputs.TEXCOORD, 10, 0], [bump.RESTORE],
            [inputs.GEOMETRY, 13, inputs.G_POSITION], [inputs.TEXCOORD, 16, 0]]
    regs, p = _run(code, [width], uv, length=2.0)
    cone = 2.0 * 0.004 * (1.0 - 1e-6)          # camera dD at the centre x distance
    a, b = (np.asarray(v) for v in bump.make_orthonormals((0.0, 0.0, 1.0)))
    assert np.allclose(regs[1:4], p + width * cone * a, atol=1e-8)
    assert np.allclose(regs[4:7], regs[1:4], atol=1e-12)
    assert np.allclose(regs[7:10], p + width * cone * b, atol=1e-8)
    assert np.allclose(regs[10:13], regs[7:10], atol=1e-12)
    assert np.allclose(regs[13:16], p) and np.allclose(regs[16:19], p)


def test_on_a_back_face_coordinates_move_against_the_point():
    """On a back face Cycles negates dPdu and dPdv with Ng (shader_data.h): the point moves by
    dP.dx along make_orthonormals(-Ng), while the barycentric differentials, and the UV
    interpolated with them, move the opposite way. (Deliberate error, measured: the
    barycentrics moved with the point, as on a front face: here the UV's check fails; in
    tests/validation/test_bump_compare.py the back-face walls were 8% darker than Cycles', 5
    tiles failed.)"""
    uv = np.array([[-1.0, -1.0, 0.0], [3.0, -1.0, 0.0], [-1.0, 3.0, 0.0]])
    width = 0.5
    code = [[bump.OFFSET, bump.AXIS_X, 0], [inputs.GEOMETRY, 1, inputs.G_POSITION],
            [inputs.TEXCOORD, 4, 0], [bump.RESTORE]]
    regs, p = _run(code, [width], uv, length=2.0, entering=False)
    a, _ = (np.asarray(v) for v in bump.make_orthonormals((0.0, 0.0, -1.0)))
    step = width * 2.0 * 0.004 * (1.0 - 1e-6) * a
    assert np.allclose(regs[1:4], p + step, atol=1e-8)
    assert np.allclose(regs[4:7], p - step, atol=1e-8)


def test_bump_instruction_bends_by_the_moved_heights():
    """The whole chain as the exporter compiles a Bump node of Height = Geometry Position's
    x (a Separate XYZ's): h at the hit and at each moved hit copied into a block, then BUMP:
    the normal is normalize(n - distance (1, 0, 0)) (a linear height, exact)."""
    from snell.tracer.shader import math_nodes
    distance, width = 0.4, 0.1
    # Constants: 0 width, 1 strength, 2 distance, 3-5 the heights' block.
    code = []
    for k, axis in enumerate((None, bump.AXIS_X, bump.AXIS_Y)):
        if axis is not None:
            code.append([bump.OFFSET, axis, 0])
        code.append([inputs.GEOMETRY, 10 + 6 * k, inputs.G_POSITION])
        code.append([math_nodes.SEPARATE_XYZ, 10 + 6 * k, 13 + 6 * k, 14 + 6 * k,
                     15 + 6 * k])
        if axis is not None:
            code.append([bump.RESTORE])
        code.append([inputs.COPY_FLOAT, 3 + k, 13 + 6 * k])
    code.append([bump.BUMP, 30, -1, 3, 1, 2, 0, 0])
    regs, _ = _run(code, [width, 1.0, distance, 0.0, 0.0, 0.0], np.zeros((3, 3)))
    assert np.allclose(regs[30:33], _unit([-distance, 0.0, 1.0]), atol=1e-9)


def _normal_matrix_columns(m):
    """The columns x, y, z of A = M^-T, as the scene's normal_matrix coordinates hold them."""
    a = np.linalg.inv(m).T
    return tuple(tuple(a[:, k]) for k in range(3))


def test_object_space_displacement_goes_through_the_object_matrix():
    """Cycles' object-space displacement: the Displacement node's normal M normalize(M^T n)
    (object_inverse_normal_transform, then object_dir_transform), Vector Displacement's M v,
    under an unequal scale with rotation and shear, read from the normal matrix A = M^-T.
    (Deliberate error: M taken as A itself: off by the scale, caught.)"""
    rng = np.random.default_rng(3)
    m = rng.normal(size=(3, 3)) + np.diag([1.5, 0.4, 2.0])
    x, y, z = _normal_matrix_columns(m)
    v = np.array([0.3, -0.2, 0.9])
    assert np.allclose(bump.object_direction(tuple(v), x, y, z), m @ v, atol=1e-12)
    n = _unit([0.2, 0.4, 0.9])
    expect = m @ _unit(m.T @ n)
    assert np.allclose(bump.object_normal(tuple(n), x, y, z), expect, atol=1e-12)
    # The Displacement node in world space: n (height - midlevel) scale.
    assert np.allclose(bump.displacement(0.8, 0.5, 0.2, tuple(n)), n * 0.06, atol=1e-15)
    assert np.allclose(bump.vector_displacement((0.7, 0.2, 0.5), 0.5, 2.0), (0.4, -0.6, 0.0))


def test_tangent_space_vector_displacement_is_cycles():
    """Cycles' tangent space: x along the object-space tangent t, y along the object-space
    normal n, z along sign normalize(n x t), through M; the exporter's tangent is A t (world
    space through the normal matrix). Checked against that construction in numpy under an
    unequal scale. (Deliberate error: y and z swapped (the usual x, y, z = t, b, n order): off
    by the components' difference, caught.)"""
    rng = np.random.default_rng(5)
    m = rng.normal(size=(3, 3)) * 0.3 + np.diag([1.2, 0.7, 1.6])
    x, y, z = _normal_matrix_columns(m)
    a = np.linalg.inv(m).T
    t_obj = np.array([0.9, 0.1, 0.05])
    n_world = _unit(a @ _unit([0.05, -0.1, 1.0]))
    v = np.array([0.3, 0.5, -0.2])
    for sign in (1.0, -1.0):
        n_obj = _unit(m.T @ n_world)
        b = sign * _unit(np.cross(n_obj, t_obj))
        expect = m @ (t_obj * v[0] + n_obj * v[1] + b * v[2])
        got = bump.tangent_direction(tuple(v), tuple(a @ t_obj), sign, tuple(n_world), x, y, z)
        assert np.allclose(got, expect, atol=1e-12)
