"""Triangle geometry: Embree queries (through embreex), hit points and self-intersection offsets.

`Geometry` owns the Embree scene and the float64 per-triangle tables that compiled code reads
through a `Mesh`; `hit_point` rebuilds a hit from its barycentrics and `offset_origin` lifts a
new ray's origin off the surface (robust-tracing.md).
"""
from __future__ import annotations

import threading
import time
from typing import NamedTuple

import numpy as np
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh

from .jit import jit, jit_inline
from .vec import dot, madd, mul, row

# Offsets scale with the coordinates (float32 spacing grows with magnitude) and have a floor
# tied to the scene's size, because Embree reports hits at t = 0 (robust-tracing.md).
RELATIVE_OFFSET = 2.0 ** -18
FLOOR_OFFSET = 2.0 ** -24
FAR = 1e30


class Mesh(NamedTuple):
    """Per-triangle tables for compiled code."""
    corners: np.ndarray          # (T, 3, 3) float32: triangle, corner, xyz (the file's precision)
    corner_normals: np.ndarray   # (T, 3, 3) float32 shading normals, or (0, 3, 3) if flat
    face_normal: np.ndarray      # (T, 3) unit geometric normals
    tri_scale: np.ndarray        # (T,) largest |coordinate| of each triangle
    floor_offset: float          # smallest offset, from the scene's size


class Geometry:
    """The scene's triangles in one Embree mesh (primID = triangle index) plus float64 copies."""

    def __init__(self, positions: np.ndarray, triangles: np.ndarray, normals: np.ndarray | None):
        self.count = len(triangles)
        self.embree_time = 0.0
        self.ray_count = 0
        self._lock = threading.Lock()
        self._thread_rays = threading.local()
        tri = triangles.astype(np.int64)
        # (T, 3 corners, xyz): a hit reads its triangle's 72 contiguous bytes, one or two lines.
        corners = positions.astype(np.float64)[tri]
        self.corners = corners
        self.corner_normals = None if normals is None else normals.astype(np.float64)[tri]
        cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        length = np.linalg.norm(cross, axis=1)
        self.area = 0.5 * length
        # Degenerate triangles cannot be hit in a meaningful way; give them any unit normal.
        self.face_normal = np.where(length[:, None] > 0.0,
                                    cross / np.where(length > 0.0, length, 1.0)[:, None],
                                    [0.0, 0.0, 1.0])
        self.tri_scale = np.abs(corners).max(axis=(1, 2)) if self.count else np.zeros(0)
        extent = float(np.ptp(positions, axis=0).max()) if self.count else 1.0
        self.extent = max(extent, 1e-12)
        self.floor_offset = FLOOR_OFFSET * self.extent
        self._scene = None
        if self.count:
            self._scene = rtcore_scene.EmbreeScene()
            TriangleMesh(self._scene, positions.astype(np.float32), triangles.astype(np.int32))
        # Compiled code reads the file's float32 values and computes in float64: the same hit
        # points as float64 tables give, from half the memory a hit has to fetch.
        self.mesh = Mesh(positions.astype(np.float32)[tri],
                         np.zeros((0, 3, 3), np.float32) if normals is None
                         else normals.astype(np.float32)[tri],
                         np.ascontiguousarray(self.face_normal), self.tri_scale, self.floor_offset)

    def _timed(self, n, fn):
        start = time.perf_counter()
        out = fn()
        elapsed = time.perf_counter() - start
        with self._lock:
            self.embree_time += elapsed
            self.ray_count += n
        self._thread_rays.n = getattr(self._thread_rays, "n", 0) + n
        return out

    def thread_rays(self) -> int:
        """Rays the calling thread has traced on this geometry."""
        # A chunk runs on one thread from start to end, so the difference around it is its own
        # rays whatever else shares the geometry (ray_count is every thread's).
        return getattr(self._thread_rays, "n", 0)

    def intersect(self, o32: np.ndarray, d32: np.ndarray, tmax32: np.ndarray):
        """Closest hits of (n, 3) float32 rays: (primID, -1 = miss; u; v; t). tmax32 is
        overwritten with the hit distances (embreex's output), and is the returned t."""
        n = len(o32)
        if self._scene is None or n == 0:
            return (np.full(n, -1, np.int32), np.zeros(n, np.float32), np.zeros(n, np.float32),
                    tmax32)
        res = self._timed(n, lambda: self._scene.run(o32, d32, dists=tmax32, output=1))
        return res["primID"], res["u"], res["v"], res["tfar"]

    def occluded(self, o32: np.ndarray, d32: np.ndarray, tmax32: np.ndarray) -> np.ndarray:
        """Per (n, 3) float32 segment o + t d, 0 <= t < tmax: 0 where blocked, -1 where free."""
        n = len(o32)
        if self._scene is None or n == 0:
            return np.full(n, -1, np.int32)
        return self._timed(n, lambda: self._scene.run(o32, d32, dists=tmax32, query="OCCLUDED"))


@jit_inline
def hit_offset(mesh, prim, p):
    """How far to lift a point p on triangle prim off its surface."""
    scale = max(abs(p[0]), max(abs(p[1]), abs(p[2])))
    return max(RELATIVE_OFFSET * max(mesh.tri_scale[prim], scale), mesh.floor_offset)


@jit_inline
def hit_point(mesh, prim, u, v):
    """The hit on triangle prim at barycentrics (u, v), rebuilt in float64 (not from o + t d):
    (point, geometric normal, shading normal, offset size)."""
    w = 1.0 - u - v
    c = mesh.corners[prim]
    p = (w * np.float64(c[0, 0]) + u * np.float64(c[1, 0]) + v * np.float64(c[2, 0]),
         w * np.float64(c[0, 1]) + u * np.float64(c[1, 1]) + v * np.float64(c[2, 1]),
         w * np.float64(c[0, 2]) + u * np.float64(c[1, 2]) + v * np.float64(c[2, 2]))
    ng = row(mesh.face_normal, prim)
    ns = ng
    if mesh.corner_normals.shape[0] > 0:
        cn = mesh.corner_normals[prim]
        n = (w * np.float64(cn[0, 0]) + u * np.float64(cn[1, 0]) + v * np.float64(cn[2, 0]),
             w * np.float64(cn[0, 1]) + u * np.float64(cn[1, 1]) + v * np.float64(cn[2, 1]),
             w * np.float64(cn[0, 2]) + u * np.float64(cn[1, 2]) + v * np.float64(cn[2, 2]))
        length = np.sqrt(dot(n, n))
        if length > 1e-12:
            ns = mul(n, 1.0 / length)
    return p, ng, ns, hit_offset(mesh, prim, p)


@jit
def offset_origin(p, ng, eps, direction):
    """Move p off its surface along ng, to the side `direction` leaves to."""
    return madd(p, eps if dot(ng, direction) >= 0.0 else -eps, ng)


@jit_inline
def facing(d, ng, ns):
    """(geometric normal, shading normal, entering) of a hit, the normals turned to face the
    ray along d that met it (entering: it met the front face)."""
    entering = dot(d, ng) < 0.0
    side = 1.0 if entering else -1.0
    return mul(ng, side), mul(ns, side), entering
