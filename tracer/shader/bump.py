"""Bump mapping in shader programs: the Bump node with a linked Height and bump displacement
(a Material Output's Displacement with the displacement method "Bump Only", or "Displacement
and Bump" whose true displacement is not rendered), as Cycles 5.0 evaluates them.

Cycles (scene/shader_graph.cpp refine_bump_nodes and bump_from_displacement) evaluates the
Height subgraph three times: at the hit, and at the hit moved by the surface differentials
dP.dx and dP.dy times the Bump node's Filter Width (kernel/svm/attribute.h svm_node_bump_P_dx,
tex_coord.h and geometry.h's *_bump_dx/dy nodes: position, UV, Generated and Object move
together, normals and the view stay). The exporter compiles the Height's nodes three times the
same way: OFFSET moves the hit that the hit-reading instructions see (its point by the
differential, its barycentrics by the same step, so that every per-corner coordinate moves
with it) and RESTORE puts it back; BUMP then takes the finite-difference surface gradient
(kernel/svm/displace.h svm_node_set_bump). Bump displacement is the same with Cycles' Bump of
Distance 1 fed by dot(displacement, N) (svm_node_displacement, svm_node_vector_displacement)
whose normal SET_NORMAL makes the hit's shading normal for every closure and node after it
(Cycles' SetNormal before the surface shader).

The differential. Cycles keeps a compact ray differential, a cone's width (kernel/util/
differential.h): a perspective camera ray starts with dP = 0 and dD = the mean length of
normalize(D + cam.dx) - normalize(D) and its dy twin (kernel/camera/camera.h), an orthographic
one with dP = the pixel's size and dD = 0; at a hit, sd->dP = dP + t dD (shader_data.h), and
differential_from_compact(Ng, sd->dP) makes dP.dx and dP.dy that width along
make_orthonormals(Ng). After a bounce the ray keeps dD and starts from dP = sd->dP
(shade_surface.h): the width grows with the whole path's length. What differs in Snell: its
paths do not carry the width, so a hit after a bounce (and a shadow ray's hit on a
transparent surface) takes the camera's dD at the image centre times the length of its own
segment only, and a camera ray through transparent surfaces the length from its last
surface; camera hits take Cycles' dD of their own direction. The step is a small fraction of a
pixel's footprint (Filter Width 0.1 by default), so for heights smooth at that scale the
gradient, and so the normal, is the same; only heights that vary within a pixel see the
difference (as in Cycles, they alias).

On a back face Cycles moves the attributes (UV, Generated, Attribute) against the point (its
barycentric differentials flip with dPdu and dPdv); Snell moves the barycentrics so, and with
them the object's own Object coordinates (interpolated at the corners), which Cycles moves with
the point: an Object-coordinate height seen from behind is bumped the other way round than in
Cycles. Also unlike Cycles: Texture Coordinate Normal is read at the unmoved hit (Cycles
interpolates it at the moved barycentrics), a Bump node inside another Bump node's Height is
evaluated at the unmoved hit, and Cycles' object-space bump (displacement method "Displacement
and Bump") is taken in world space, the same for objects of unit scale.
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import jit
from ..vec import add, cross, dot, mul, normalize, sub
from .inputs import LP_CAMERA, interpolate, normal_in, store3
from .normals import finite_nonzero
from .object_inputs import CAM_MATRIX, CAM_ORTHO

# Opcodes 450-479.
OFFSET, RESTORE, BUMP, SET_NORMAL, DISPLACEMENT, VECTOR_DISPLACEMENT, HEIGHT, \
    OBJECT_DIRECTION, OBJECT_NORMAL, TANGENT_DIRECTION = range(450, 460)
FIRST, LAST = 450, 479
# OFFSET's literal: the differential it moves the hit by.
AXIS_X, AXIS_Y = 0, 1
# Programs.pixel: the size of a pixel on the view plane (x, y; at distance 1 in front of a
# perspective camera, in scene units for an orthographic one), with Materials.camera
# (object_inputs.py: world to camera, whether orthographic) what camera differentials need.

SPECS = {
    OFFSET: ("Bump: the hit the next instructions read moved by its differential along axis i "
             "(AXIS_X, AXIS_Y) times filter width f", "if-----", {1: 2}),
    RESTORE: ("Bump: the hit the next instructions read back at the hit", "-------"),
    BUMP: ("Bump: the normal bent from normal n by the heights v (at the hit, moved along x, "
           "along y) at strength f, distance f, inverted if i, filter width f", "vnvffif",
           {6: 2}),
    SET_NORMAL: ("Bump displacement: vector v becomes the hit's shading normal", "v------"),
    DISPLACEMENT: ("Displacement: normal n times (height f - midlevel f) times scale f",
                   "vfffn--"),
    VECTOR_DISPLACEMENT: ("Vector Displacement: (vector v - midlevel f) times scale f",
                          "vvff---"),
    HEIGHT: ("Bump displacement: displacement v along the hit's shading normal", "fv-----"),
    OBJECT_DIRECTION: ("Displacement in object space: vector v through the object's matrix M, "
                       "of normal matrix columns the scene's coordinates i, i, i", "vviii--",
                       {3: "texcoords", 4: "texcoords", 5: "texcoords"}),
    OBJECT_NORMAL: ("Displacement in object space: M normalize(M^T n), of normal matrix "
                    "columns the scene's coordinates i, i, i", "vniii--",
                    {3: "texcoords", 4: "texcoords", 5: "texcoords"}),
    TANGENT_DIRECTION: ("Vector Displacement in tangent space: vector v in the frame of the "
                        "scene's coordinates i (tangent), i (tangent_sign) and the shading "
                        "normal, through M of normal matrix columns i, i, i", "vviiiii",
                        {3: "texcoords", 4: "texcoords", 5: "texcoords", 6: "texcoords",
                         7: "texcoords"}),
}


def pixel_size(camera) -> np.ndarray:
    """Programs.pixel for a camera (tracer.camera.Camera)."""
    return np.array([2.0 * camera.half_x / camera.width, 2.0 * camera.half_y / camera.height])


def with_view(materials, corners, camera):
    """Materials whose programs know the scene's triangle corners (T, 3, 3) and the camera's
    pixel size (camera: tracer.camera.Camera), which bump differentials need."""
    programs = materials.programs._replace(corners=np.ascontiguousarray(corners, np.float64),
                                           pixel=pixel_size(camera))
    return materials._replace(programs=programs)


@jit
def make_orthonormals(n):
    """Two unit vectors completing n to a frame, as Cycles' make_orthonormals
    (util/math_float3.h): a = normalize((1, 1, 1) x n) (or (-1, 1, 1) x n), b = n x a."""
    if n[0] != n[1] or n[0] != n[2]:
        a = (n[2] - n[1], n[0] - n[2], n[1] - n[0])
    else:
        a = (n[2] - n[1], n[0] + n[2], -n[1] - n[0])
    a = normalize(a)
    return a, cross(n, a)


@jit
def direction_spread(pc, px, py):
    """Cycles' compact dD of a perspective camera ray through camera-plane point pc: the mean
    of |normalize(pc + dx) - normalize(pc)| over the pixel's steps dx = (px, 0, 0) and
    dy = (0, py, 0)."""
    d = normalize(pc)
    dx = sub(normalize((pc[0] + px, pc[1], pc[2])), d)
    dy = sub(normalize((pc[0], pc[1] + py, pc[2])), d)
    return 0.5 * (math.sqrt(dot(dx, dx)) + math.sqrt(dot(dy, dy)))


@jit
def camera_spread(cam, pixel, d):
    """The compact dD of the perspective camera ray of direction d (world space); cam:
    Materials.camera (its world-to-camera rows, +z ahead), pixel: Programs.pixel."""
    m = CAM_MATRIX
    x = cam[m] * d[0] + cam[m + 1] * d[1] + cam[m + 2] * d[2]
    y = cam[m + 4] * d[0] + cam[m + 5] * d[1] + cam[m + 6] * d[2]
    z = cam[m + 8] * d[0] + cam[m + 9] * d[1] + cam[m + 10] * d[2]
    if not z > 0.0:
        x, y, z = 0.0, 0.0, 1.0
    # Onto the view plane at distance 1, where the pixel steps are.
    return direction_spread((x / z, y / z, 1.0), pixel[0], pixel[1])


@jit
def cone_width(cam, pixel, camera_ray, d, length):
    """Cycles' sd->dP at a hit `length` along a ray of direction d (camera_ray: the camera's own
    ray); see the module docstring for what Snell's paths leave out."""
    if cam[CAM_ORTHO] != 0.0:
        return 0.5 * (pixel[0] + pixel[1])
    if camera_ray:
        return camera_spread(cam, pixel, d) * length
    return direction_spread((0.0, 0.0, 1.0), pixel[0], pixel[1]) * length


@jit
def differentials(ng, width):
    """Cycles' differential_from_compact(Ng, dP): (dP.dx, dP.dy) of length `width` along
    make_orthonormals(ng)."""
    a, b = make_orthonormals(ng)
    return mul(a, width), mul(b, width)


@jit
def barycentric_step(c, step):
    """The change (db1, db2) of barycentrics on triangle corners c (3, 3) that moves its point
    by step (in its plane): P = c0 + b1 (c1 - c0) + b2 (c2 - c0), solved by least squares as
    Cycles' differential_dudv solves it exactly in the plane."""
    e1 = (c[1, 0] - c[0, 0], c[1, 1] - c[0, 1], c[1, 2] - c[0, 2])
    e2 = (c[2, 0] - c[0, 0], c[2, 1] - c[0, 1], c[2, 2] - c[0, 2])
    a11, a12, a22 = dot(e1, e1), dot(e1, e2), dot(e2, e2)
    det = a11 * a22 - a12 * a12
    if not det > 0.0:
        return 0.0, 0.0
    r1, r2 = dot(e1, step), dot(e2, step)
    return (a22 * r1 - a12 * r2) / det, (a11 * r2 - a12 * r1) / det


@jit
def hit_width(hit, mats):
    """sd->dP at program.run's hit."""
    camera_ray = hit[8] == 1 << LP_CAMERA          # a camera ray (through transparency too)
    return cone_width(mats.camera, mats.programs.pixel, camera_ray, mul(hit[3], -1.0),
                      hit[10])


@jit
def moved_hit(hit, axis, filter_width, mats):
    """program.run's hit moved by its differential along axis (AXIS_X, AXIS_Y) times
    filter_width: its point, and its barycentrics by the same step (on a back face, the
    opposite step, as Cycles' do)."""
    dx, dy = differentials(hit[1], hit_width(hit, mats))
    step = mul(dx if axis == AXIS_X else dy, filter_width)
    programs = mats.programs
    tri = hit[5]
    db1, db2 = 0.0, 0.0
    if tri < programs.corners.shape[0]:
        db1, db2 = barycentric_step(programs.corners[tri], step)
    if not hit[4]:
        # On a back face Cycles negates dPdu and dPdv with Ng (shader_data.h), so the
        # barycentric differentials it solves for flip while dP.dx does not: attributes move
        # against the point.
        db1, db2 = -db1, -db2
    return (add(hit[0], step), hit[1], hit[2], hit[3], hit[4], hit[5], hit[6] + db1,
            hit[7] + db2, hit[8], hit[9], hit[10])


@jit
def with_normal(hit, n):
    """program.run's hit with shading normal n (Cycles' svm_node_set_normal), unless n is zero
    or not finite."""
    if not finite_nonzero(n):
        return hit
    return (hit[0], hit[1], n, hit[3], hit[4], hit[5], hit[6], hit[7], hit[8], hit[9], hit[10])


@jit
def bump_normal(heights, strength, distance, invert, filter_width, n, dx, dy):
    """Cycles' svm_node_set_bump: normal n bent by the heights (h_c, h_x, h_y) at the hit and
    at the hit moved by dx and dy times filter_width, at a strength and distance."""
    h_c, h_x, h_y = heights
    rx = cross(dy, n)
    ry = cross(n, dx)
    det = dot(dx, rx)
    surfgrad = add(mul(rx, h_x - h_c), mul(ry, h_y - h_c))
    scale = -distance if invert else distance
    strength = max(strength, 0.0)
    sign = -1.0 if det < 0.0 else 1.0
    out = normalize(sub(mul(n, filter_width * abs(det)), mul(surfgrad, scale * sign)))
    if out[0] == 0.0 and out[1] == 0.0 and out[2] == 0.0:
        return n
    out = normalize(add(mul(out, strength), mul(n, 1.0 - strength)))
    # A height or input that is not finite leaves the normal (Snell writes no NaN).
    return out if finite_nonzero(out) else n


@jit
def displacement(height, midlevel, scale, n):
    """The Displacement node in world space: n (height - midlevel) scale."""
    return mul(n, (height - midlevel) * scale)


@jit
def vector_displacement(v, midlevel, scale):
    """The Vector Displacement node in world space: (v - midlevel) scale."""
    return ((v[0] - midlevel) * scale, (v[1] - midlevel) * scale, (v[2] - midlevel) * scale)


@jit
def object_matrix_columns(x, y, z):
    """The columns of the object's matrix M and det(A) from its normal matrix A = M^-T of
    columns x, y, z: M = A^-T has columns (y x z, z x x, x x y) / det(A)."""
    det = dot(x, cross(y, z))
    inv = 1.0 / det if det != 0.0 else 0.0
    return mul(cross(y, z), inv), mul(cross(z, x), inv), mul(cross(x, y), inv)


@jit
def object_direction(v, x, y, z):
    """M v (Cycles' object_dir_transform) for normal matrix columns x, y, z."""
    m0, m1, m2 = object_matrix_columns(x, y, z)
    return add(add(mul(m0, v[0]), mul(m1, v[1])), mul(m2, v[2]))


@jit
def object_normal(n, x, y, z):
    """M normalize(M^T n): a world normal to object space (object_inverse_normal_transform)
    and that direction back through M (object_dir_transform), as the Displacement node's
    object space does."""
    m0, m1, m2 = object_matrix_columns(x, y, z)
    local = normalize((dot(m0, n), dot(m1, n), dot(m2, n)))
    return object_direction(local, x, y, z)


@jit
def object_transposed(v, x, y, z):
    """M^T v (a world normal to object space before normalising; a normal-matrix-transformed
    vector A t back to t) for normal matrix columns x, y, z."""
    m0, m1, m2 = object_matrix_columns(x, y, z)
    return dot(m0, v), dot(m1, v), dot(m2, v)


@jit
def tangent_direction(v, tangent, sign, ns, x, y, z):
    """Cycles' tangent-space Vector Displacement (svm_node_vector_displacement): v's
    components along the object-space tangent t, normal n and bitangent sign normalize(n x t)
    (x, normal, bitangent in that order: Blender's convention), through M. tangent: A t
    interpolated at the hit (A = M^-T, the normal matrix of columns x, y, z); ns the world
    shading normal."""
    t = object_transposed(tangent, x, y, z)
    n = normalize(object_transposed(ns, x, y, z))
    b = mul(normalize(cross(n, t)), sign)
    local = add(add(mul(t, v[0]), mul(n, v[1])), mul(b, v[2]))
    return object_direction(local, x, y, z)


@jit
def execute(ins, regs, hit, mats):
    """Run BUMP and the displacement instructions at program.run's hit (OFFSET, RESTORE and
    SET_NORMAL change the hit: run does them)."""
    op = ins[0]
    ns = hit[2]
    if op == BUMP:
        n = normal_in(regs, ins[2], ns)
        dx, dy = differentials(hit[1], hit_width(hit, mats))
        h = ins[3]
        out = bump_normal((regs[h], regs[h + 1], regs[h + 2]), regs[ins[4]], regs[ins[5]],
                          ins[6] != 0, regs[ins[7]], n, dx, dy)
        store3(regs, ins[1], out if finite_nonzero(out) else ns)
    elif op == DISPLACEMENT:
        store3(regs, ins[1], displacement(regs[ins[2]], regs[ins[3]], regs[ins[4]],
                                          normal_in(regs, ins[5], ns)))
    elif op == VECTOR_DISPLACEMENT:
        v = ins[2]
        store3(regs, ins[1], vector_displacement((regs[v], regs[v + 1], regs[v + 2]),
                                                 regs[ins[3]], regs[ins[4]]))
    elif op == HEIGHT:
        v = ins[2]
        regs[ins[1]] = dot((regs[v], regs[v + 1], regs[v + 2]), ns)
    elif op == OBJECT_DIRECTION or op == OBJECT_NORMAL:
        tri, b1, b2 = hit[5], hit[6], hit[7]
        x = interpolate(mats.coords[ins[3]], tri, b1, b2)
        y = interpolate(mats.coords[ins[4]], tri, b1, b2)
        z = interpolate(mats.coords[ins[5]], tri, b1, b2)
        if op == OBJECT_DIRECTION:
            v = ins[2]
            store3(regs, ins[1], object_direction((regs[v], regs[v + 1], regs[v + 2]), x, y, z))
        else:
            store3(regs, ins[1], object_normal(normal_in(regs, ins[2], ns), x, y, z))
    elif op == TANGENT_DIRECTION:
        tri, b1, b2 = hit[5], hit[6], hit[7]
        x = interpolate(mats.coords[ins[5]], tri, b1, b2)
        y = interpolate(mats.coords[ins[6]], tri, b1, b2)
        z = interpolate(mats.coords[ins[7]], tri, b1, b2)
        tangent = interpolate(mats.coords[ins[3]], tri, b1, b2)
        sign = interpolate(mats.coords[ins[4]], tri, b1, b2)[0]
        v = ins[2]
        store3(regs, ins[1], tangent_direction((regs[v], regs[v + 1], regs[v + 2]), tangent,
                                               sign, ns, x, y, z))
