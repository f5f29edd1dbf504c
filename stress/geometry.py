"""Meshes, cameras and scene assembly for `snell stress`: tracer Scenes built in Python, no bpy.

tests/support/builders.py builds its test scenes from these shapes too; the rotations and degenerate
meshes are the stress cases' own.
"""
from __future__ import annotations

import math

import numpy as np

from ..tracer.scene import Scene, validate

WHITE = [1.0, 1.0, 1.0]


def icosphere(subdivisions: int = 4, radius: float = 1.0, center=(0.0, 0.0, 0.0)):
    """A closed, outward-wound sphere mesh: (positions float32, triangles int32, normals
    float32)."""
    t = (1.0 + 5 ** 0.5) / 2.0
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
             (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    v = [np.array(p, float) / np.linalg.norm(p) for p in verts]
    for _ in range(subdivisions):
        cache, new_faces = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = v[a] + v[b]
                v.append(m / np.linalg.norm(m))
                cache[key] = len(v) - 1
            return cache[key]
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new_faces += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new_faces
    unit = np.array(v)
    pos = (unit * radius + np.asarray(center, float)).astype(np.float32)
    return pos, np.array(faces, np.int32), unit.astype(np.float32)


def quad(center, half_x, half_y, normal_sign=1.0):
    """An axis-aligned quad in the z = center[2] plane facing +Z (or -Z): (positions, triangles)."""
    cx, cy, cz = center
    pos = np.array([[cx - half_x, cy - half_y, cz], [cx + half_x, cy - half_y, cz],
                    [cx + half_x, cy + half_y, cz], [cx - half_x, cy + half_y, cz]], np.float64)
    tri = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    if normal_sign < 0:
        tri = tri[:, ::-1].copy()
    return pos, tri


def box(lo, hi):
    """A closed axis-aligned box with outward winding: (positions float64, triangles)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    pos = lo + c * (hi - lo)
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tri = []
    for a, b, c2, d in faces:
        tri += [(a, b, c2), (a, c2, d)]
    return pos, np.array(tri, np.int32)


def rotate_x(points, degrees):
    """Points (n, 3) rotated about the X axis (float64)."""
    a = math.radians(degrees)
    r = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    return np.asarray(points, np.float64) @ r.T


def camera(position=(0.0, 0.0, 5.0), resolution=(32, 32), lens=50.0, dof=None, clip_start=0.01,
           clip_end=1e7):
    """A camera at `position` looking down -Z (identity rotation)."""
    m = np.eye(4)
    m[:3, 3] = position
    cam = {"name": "Camera", "matrix": m.tolist(), "lens": float(lens), "sensor_width": 36.0,
           "sensor_height": 24.0, "sensor_fit": "AUTO", "shift_x": 0.0, "shift_y": 0.0,
           "clip_start": float(clip_start), "clip_end": float(clip_end),
           "resolution": list(resolution), "resolution_percentage": 100,
           "pixel_aspect": [1.0, 1.0],
           "dof": {"use_dof": False, "focus_distance": 10.0, "fstop": 2.8, "blades": 0,
                   "rotation": 0.0, "ratio": 1.0}}
    if dof:
        cam["dof"].update(dof)
    return cam


def scene(meshes, materials, cam, world=(0.0, 0.0, 0.0), lights=(), spp=16, max_depth=8,
          seed=0):
    """A validated Scene from (positions, triangles, material index[, normals]) meshes.

    Meshes without normals get none; if any mesh has normals, the others get their face normals
    at every corner (flat), which is what an exporter writes for a flat-shaded mesh.
    """
    pos, tri, mid, oid, nrm = [], [], [], [], []
    offset = 0
    for i, mesh in enumerate(meshes):
        p, t, m = mesh[:3]
        p = np.asarray(p, np.float32)
        if len(mesh) > 3:
            nrm.append(np.asarray(mesh[3], np.float32))
        else:
            nrm.append(None)
        pos.append((p, t))
        mid.append(np.full(len(t), m, np.int32))
        oid.append(np.full(len(t), i, np.int32))
    smooth = any(n is not None for n in nrm)
    out_pos, out_tri, out_nrm = [], [], []
    for (p, t), n in zip(pos, nrm):
        if smooth and n is None:
            p, t, n = _flat_corners(p, t)
        out_pos.append(p)
        out_tri.append(t + offset)
        out_nrm.append(n)
        offset += len(p)
    result = Scene(
        positions=(np.concatenate(out_pos).astype(np.float32) if out_pos
                   else np.zeros((0, 3), np.float32)),
        triangles=(np.concatenate(out_tri).astype(np.int32) if out_tri
                   else np.zeros((0, 3), np.int32)),
        material_ids=np.concatenate(mid).astype(np.int32) if mid else np.zeros(0, np.int32),
        object_ids=np.concatenate(oid).astype(np.int32) if oid else np.zeros(0, np.int32),
        materials=list(materials), lights=list(lights), camera=cam, world={"color": list(world)},
        # Fixed samples in every pixel: the cases' bounds count spp samples per pixel.
        render={"spp": int(spp), "max_depth": int(max_depth), "seed": int(seed), "fresnel": "exact",
                "noise_threshold": 0.0},
        objects=[{"name": f"object{i}", "closed": True} for i in range(len(meshes))],
        normals=np.concatenate(out_nrm).astype(np.float32) if smooth else None)
    return validate(result)


def _flat_corners(p, t):
    """Every triangle with its own three corners, each carrying the face normal."""
    corners = p[t].reshape(-1, 3)
    fn = np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]).astype(np.float64)
    length = np.linalg.norm(fn, axis=1, keepdims=True)
    fn = np.where(length > 0, fn / np.where(length > 0, length, 1.0), [0.0, 0.0, 1.0])
    return corners, np.arange(len(corners), dtype=np.int32).reshape(-1, 3), np.repeat(fn, 3, axis=0)
