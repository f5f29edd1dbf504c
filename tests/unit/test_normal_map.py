"""The Normal Map node's formulas (tracer/shader/normals.py, Cycles' svm_node_normal_map), the
exporter's world-space tangent frame (addon/export/meshes.py Mesh.tangent_frame) against Cycles'
object-space construction, and Cycles' bump shadowing of bent normals (lobes.bump_shadowing)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from snell.addon.export.meshes import Mesh
from snell.tracer import lobes
from snell.tracer.shader import normals

NS = (0.0, 0.0, 1.0)


def _close(a, b, tol=1e-12):
    return np.allclose(np.asarray(a, float), np.asarray(b, float), atol=tol, rtol=0)


def test_decode_is_two_c_minus_one():
    assert _close(normals.decode((0.5, 0.5, 1.0)), (0.0, 0.0, 1.0))
    assert _close(normals.decode((1.0, 0.0, 0.75)), (1.0, -1.0, 0.5))


def test_tangent_strength_scales_xy_and_mixes_z_from_one():
    """Cycles: x, y times the strength, z = mix(1, z, saturate(strength)). (Deliberate error:
    z mixed by the unclamped strength gives z = 0.6 at strength 2, not 0.8: caught.)"""
    c = (0.2, -0.4, 0.8)
    assert _close(normals.tangent_strength(c, 0.5), (0.1, -0.2, 0.9))
    assert _close(normals.tangent_strength(c, 2.0), (0.4, -0.8, 0.8))
    assert _close(normals.tangent_strength(c, -1.0), (-0.2, 0.4, 1.0))
    assert _close(normals.tangent_strength(c, 0.0), (0.0, 0.0, 1.0))


def test_tangent_map_in_a_unit_frame():
    t, b, n = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    flat = (0.5, 0.5, 1.0)
    assert _close(normals.normal_map_tangent(flat, 1.0, t, b, n, NS, False), n)
    # Pure +x: the tangent; on a back face reversed, as Cycles inverts it.
    assert _close(normals.normal_map_tangent((1.0, 0.5, 0.5), 1.0, t, b, n, NS, False), t)
    assert _close(normals.normal_map_tangent((1.0, 0.5, 0.5), 1.0, t, b, n, NS, True),
                  (-1.0, 0.0, 0.0))
    # A frame of zeros (a mesh without the UV map) or a zero result: the shading normal.
    zero = (0.0, 0.0, 0.0)
    assert _close(normals.normal_map_tangent(flat, 1.0, zero, zero, zero, NS, False), NS)
    assert _close(normals.normal_map_tangent((0.5, 0.5, 0.5), 1.0, t, b, n, (0.0, 1.0, 0.0),
                                             False), (0.0, 1.0, 0.0))


def _one_triangle_mesh(tangents, sign, normals_):
    """A one-triangle Mesh whose corners have these tangents and normals (3, 3) and sign."""
    co = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    corners = np.arange(3, dtype=np.int32)
    uvs = {"UVMap": np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], np.float32)}
    frames = {"UVMap": (np.asarray(tangents, np.float32), np.full(3, sign, np.float32))}
    return Mesh(co, corners, corners.reshape(1, 3), np.zeros(1, np.int32),
                np.asarray(normals_, np.float32), (uvs, "UVMap", np.zeros((3, 3), np.float32),
                                                   frames, {}))


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_world_frame_matches_cycles_object_space_under_any_matrix(sign):
    """Cycles builds N = x t + y sign (n x t) + z n of the interpolated object-space t and n,
    and transforms it by the normal matrix A = M^-T; the exporter's corners (A t, A n, and the
    sign with G = det(M) (M M^T)^-1) give the same normal at any barycentrics, on a smooth
    triangle (corner normals and tangents that differ), under rotations, unequal scales,
    shears and mirrors. (Deliberate error: G left out, B = sign (A n x A t): fails for both
    signs; caught. An earlier design interpolated the corners' crosses instead: off by up to
    12.6 degrees from Cycles' normal on Suzanne's coarse smooth mesh, measured apart.)"""
    rng = np.random.default_rng(7)
    t_obj = np.array([[1.0, 0.0, 0.1], [0.9, 0.3, 0.0], [1.0, -0.2, 0.2]])
    n_obj = np.array([[0.0, 0.0, 1.0], [0.3, 0.0, 0.95], [-0.2, 0.3, 0.93]])
    t_obj /= np.linalg.norm(t_obj, axis=1, keepdims=True)
    n_obj /= np.linalg.norm(n_obj, axis=1, keepdims=True)
    mesh = _one_triangle_mesh(t_obj, sign, n_obj)
    for trial in range(20):
        m = np.eye(4)
        m[:3, :3] = rng.normal(size=(3, 3)) + np.diag([1.5, 0.3, 2.0])
        if trial % 2:
            m[:3, 0] *= -1.0                                    # a mirror
        frame = mesh.tangent_frame(mesh.coords[3]["UVMap"], m)
        color = tuple(rng.uniform(0.0, 1.0, 3))
        strength = float(rng.uniform(0.2, 1.5))
        b1, b2 = rng.uniform(0.0, 0.5, 2)
        bary = np.array([1 - b1 - b2, b1, b2])
        hit = (b1, b2)
        if np.linalg.det(m[:3, :3]) < 0:
            # depsgraph.texcoords swaps corners 1 and 2 of a mirrored part, as to_world does.
            frame = {k: v[:, [0, 2, 1]] for k, v in frame.items()}
            hit = (b2, b1)
        t = tuple(np.array([1 - b1 - b2, *hit]) @ frame["tangent"][0])
        n = tuple(np.array([1 - b1 - b2, *hit]) @ frame["tangent_normal"][0])
        b = normals.bitangent(frame["tangent_sign"], 0, *hit, t, n)
        got = normals.normal_map_tangent(color, strength, t, b, n, NS, False)
        c = np.array(normals.tangent_strength(normals.decode(color), strength))
        ti, ni = bary @ t_obj, bary @ n_obj
        n_cycles = c[0] * ti + c[1] * sign * np.cross(ni, ti) + c[2] * ni
        want = np.linalg.inv(m[:3, :3]).T @ n_cycles
        assert _close(got, want / np.linalg.norm(want), 1e-6), (trial, got, want)


def test_object_and_world_spaces():
    """Object space: through the normal matrix's columns; Blender's conventions negate y and z;
    strength mixes linearly from the shading normal."""
    x, y, z = (2.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)       # M^-T of scale (0.5, 1, 1)
    color = (0.75, 0.5, 0.5 + 0.5 * math.sqrt(0.75))                   # (0.5, 0, 0.866)
    got = normals.normal_map_space(color, 1.0, normals.SPACE_OBJECT, x, y, z, NS, False)
    want = np.array([1.0, 0.0, math.sqrt(0.75)])
    assert _close(got, want / np.linalg.norm(want))
    world = normals.normal_map_space((0.5, 1.0, 0.5), 1.0, normals.SPACE_BLENDER_WORLD,
                                     *normals_axes(), NS, False)
    assert _close(world, (0.0, -1.0, 0.0))
    half = normals.normal_map_space((1.0, 0.5, 0.5), 0.5, normals.SPACE_WORLD, *normals_axes(),
                                    NS, False)
    assert _close(half, np.array([0.5, 0.0, 0.5]) / math.sqrt(0.5))
    assert _close(normals.normal_map_space((1.0, 0.5, 0.5), 0.0, normals.SPACE_WORLD,
                                           *normals_axes(), NS, False), NS)


def normals_axes():
    return normals.WORLD_X, normals.WORLD_Y, normals.WORLD_Z


def _lambert(n, ns):
    lobe = np.zeros(lobes.FIELDS)
    lobes.new_lobe(lobe, lobes.LAMBERT, n, (1.0, 1.0, 1.0))
    lobe[lobes.SMOOTH_NORMAL:lobes.SMOOTH_NORMAL + 3] = ns
    return lobe


def test_bump_shadowing_of_a_bent_diffuse_normal():
    """Cycles' bump_shadowing_term: 1 when the normal is the smooth one; 0 for light behind the
    smooth normal on the bent normal's side; else G1 of GGX with alpha^2 = tan^2(ns, n) / 8 at
    |cos(ns, wo)|: 0.61278 for a 30-degree bend and light at cosine 0.1 (computed by hand).
    (Deliberate error: alpha^2 = tan^2 / 4: 0.49488; caught.)"""
    bend = (math.sin(math.radians(30)), 0.0, math.cos(math.radians(30)))
    wo = (math.sqrt(1 - 0.01), 0.0, 0.1)
    assert lobes.bump_shadowing(_lambert(NS, NS), wo, True) == 1.0
    assert lobes.bump_shadowing(_lambert(bend, NS), wo, True) == pytest.approx(0.61278, abs=1e-5)
    below = (0.995, 0.0, -0.0999)                          # under ns, above the bent normal
    assert np.dot(below, bend) > 0.0
    assert lobes.bump_shadowing(_lambert(bend, NS), below, True) == 0.0
    value, pdf = lobes.lobe_eval(_lambert(bend, NS), (0.0, 0.0, 1.0), below)
    assert value == (0.0, 0.0, 0.0) and pdf == 0.0


def test_bump_shadowing_leaves_microfacet_samples_alone():
    """A microfacet lobe: only the evaluation's side test, no softening."""
    lobe = np.zeros(lobes.FIELDS)
    bend = (math.sin(0.5), 0.0, math.cos(0.5))
    lobes.new_microfacet(lobe, bend, (1.0, 1.0, 1.0), lobes.DIST_GGX, 0.1, 1.5, 1.0, 0.0,
                         lobes.NO_FRESNEL)
    lobe[lobes.SMOOTH_NORMAL:lobes.SMOOTH_NORMAL + 3] = NS
    wo = (math.sqrt(1 - 0.01), 0.0, 0.1)
    assert lobes.bump_shadowing(lobe, wo, True) == 1.0
    assert lobes.bump_shadowing(lobe, (0.995, 0.0, -0.0999), False) == 1.0
    assert lobes.bump_shadowing(lobe, (0.995, 0.0, -0.0999), True) == 0.0

