"""Scenes built directly in Python for tracer tests (no Blender needed)."""
from __future__ import annotations

import numpy as np

from snell.stress import geometry  # the package's own meshes (snell stress)
from snell.tracer.scene import Scene, validate


def icosphere(subdivisions: int = 3, radius: float = 1.0, center=(0.0, 0.0, 0.0)):
    """A closed, outward-wound sphere mesh: (positions float32, triangles int32, normals float32)."""
    return geometry.icosphere(subdivisions, radius, center)


def quad(center, half_x, half_y, normal_sign=1.0):
    """An axis-aligned quad in the z = center[2] plane facing +Z (or -Z), float32 positions."""
    pos, tri = geometry.quad(center, half_x, half_y, normal_sign)
    return pos.astype(np.float32), tri


def box(lo, hi):
    """A closed axis-aligned box with outward winding, float32 positions."""
    pos, tri = geometry.box(lo, hi)
    return pos.astype(np.float32), tri


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
    # No adaptive sampling unless a test asks for it: these scenes measure estimators against
    # exact values with tolerances for the samples asked for, in every pixel.
    settings = {"spp": 16, "max_depth": 8, "seed": 0, "fresnel": "exact", "noise_threshold": 0.0}
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


EMISSION = 2.0


def tiny_scene(**render) -> Scene:
    """An 8x8 camera at the origin looking down -Z at a two-sided emissive quad filling the
    top half of the view (camera +Y is up) over a black world."""
    positions = np.array([[-2, 0, -2], [2, 0, -2], [2, 2, -2], [-2, 2, -2]], np.float32)
    return Scene(
        positions=positions,
        triangles=np.array([[0, 1, 2], [0, 2, 3]], np.int32),
        material_ids=np.zeros(2, np.int32),
        object_ids=np.zeros(2, np.int32),
        objects=[{"name": "Quad", "closed": False}],
        materials=[{"name": "Lamp", "kind": "emission", "color": [1.0, 1.0, 1.0], "strength": EMISSION}],
        lights=[],
        world={"color": [0.0, 0.0, 0.0]},
        camera={"name": "Camera", "matrix": np.eye(4).tolist(), "lens": 50.0, "sensor_width": 36.0,
                "sensor_height": 24.0, "sensor_fit": "AUTO", "shift_x": 0.0, "shift_y": 0.0,
                "clip_start": 0.1, "clip_end": 100.0, "resolution": [8, 8],
                "resolution_percentage": 100, "pixel_aspect": [1.0, 1.0],
                "dof": {"use_dof": False, "focus_distance": 10.0, "fstop": 2.8, "blades": 0,
                        "rotation": 0.0, "ratio": 1.0}},
        render={"spp": 4, "max_depth": 2, "seed": 0, "fresnel": "exact", **render},
        source="test_cli.py")
