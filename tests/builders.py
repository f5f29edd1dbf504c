"""Scenes built directly in Python for tracer tests (no Blender needed)."""
from __future__ import annotations

import numpy as np

from snell.tracer.scene import Scene, validate


def icosphere(subdivisions: int = 3, radius: float = 1.0, center=(0.0, 0.0, 0.0)):
    """A closed, outward-wound sphere mesh: (positions float32, triangles int32, normals float32)."""
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
    pos = (unit * radius + np.asarray(center)).astype(np.float32)
    return pos, np.array(faces, np.int32), unit.astype(np.float32)


def quad(center, half_x, half_y, normal_sign=1.0):
    """An axis-aligned quad in the z = center[2] plane facing +Z (or -Z)."""
    cx, cy, cz = center
    pos = np.array([[cx - half_x, cy - half_y, cz], [cx + half_x, cy - half_y, cz],
                    [cx + half_x, cy + half_y, cz], [cx - half_x, cy + half_y, cz]], np.float32)
    tri = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    if normal_sign < 0:
        tri = tri[:, ::-1].copy()
    return pos, tri


def box(lo, hi):
    """A closed axis-aligned box with outward winding."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    pos = (lo + c * (hi - lo)).astype(np.float32)
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    tri = []
    for a, b, c2, d in faces:
        tri += [(a, b, c2), (a, c2, d)]
    return pos, np.array(tri, np.int32)


def camera(position=(0.0, 0.0, 5.0), resolution=(32, 32), lens=50.0, dof=None, **extra):
    """A camera at `position` looking down -Z (identity rotation)."""
    m = np.eye(4)
    m[:3, 3] = position
    cam = {"name": "Camera", "matrix": m.tolist(), "lens": lens, "sensor_width": 36.0,
           "sensor_height": 24.0, "sensor_fit": "AUTO", "shift_x": 0.0, "shift_y": 0.0,
           "clip_start": 0.01, "clip_end": 1e6, "resolution": list(resolution),
           "resolution_percentage": 100, "pixel_aspect": [1.0, 1.0],
           "dof": {"use_dof": False, "focus_distance": 10.0, "fstop": 2.8, "blades": 0,
                   "rotation": 0.0, "ratio": 1.0}}
    if dof:
        cam["dof"].update(dof)
    cam.update(extra)
    return cam


def make_scene(meshes, materials, cam, world=(0.0, 0.0, 0.0), lights=(), normals=None, **render):
    """Combine (positions, triangles, material index) meshes into a validated Scene."""
    pos, tri, mid, oid, nrm = [], [], [], [], []
    offset = 0
    for i, mesh in enumerate(meshes):
        p, t, m = mesh[:3]
        pos.append(p)
        tri.append(t + offset)
        mid.append(np.full(len(t), m, np.int32))
        oid.append(np.full(len(t), i, np.int32))
        nrm.append(mesh[3] if len(mesh) > 3 else None)
        offset += len(p)
    use_normals = any(n is not None for n in nrm)
    if use_normals:
        # Meshes without normals get their face normals per vertex (flat meshes only here).
        nrm = [n if n is not None else _flat_vertex_normals(p, t) for n, p, t in
               zip(nrm, [m[0] for m in meshes], [m[1] for m in meshes])]
    settings = {"spp": 16, "max_depth": 8, "seed": 0, "fresnel": "exact"}
    settings.update(render)
    scene = Scene(positions=np.concatenate(pos or [np.zeros((0, 3))]).astype(np.float32),
                  triangles=np.concatenate(tri or [np.zeros((0, 3))]).astype(np.int32),
                  material_ids=np.concatenate(mid or [np.zeros(0)]).astype(np.int32),
                  object_ids=np.concatenate(oid or [np.zeros(0)]).astype(np.int32),
                  materials=list(materials), lights=list(lights), camera=cam,
                  world={"color": list(world)}, render=settings,
                  objects=[{"name": f"object{i}", "closed": True} for i in range(len(meshes))],
                  normals=np.concatenate(nrm).astype(np.float32) if use_normals else None)
    return validate(scene)


def _flat_vertex_normals(p, t):
    n = np.zeros((len(p), 3))
    fn = np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]])
    for k in range(3):
        n[t[:, k]] = fn
    return n / np.linalg.norm(n, axis=1, keepdims=True)
