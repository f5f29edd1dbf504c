"""Triangle geometry on Embree: ray queries, hit reconstruction and self-intersection offsets."""
from __future__ import annotations

import threading
import time

import numpy as np
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh

# Offsets scale with the coordinates (float32 spacing grows with magnitude) and have a floor
# tied to the scene's size, because Embree reports hits at t = 0 (robust-tracing.md).
RELATIVE_OFFSET = 2.0 ** -18
FLOOR_OFFSET = 2.0 ** -24
FAR = np.float32(1e30)


class Hits:
    """Surface data for the rays that hit something (all arrays share the same row order)."""
    __slots__ = ("prim", "t", "p", "ng", "ns", "eps")

    def __init__(self, prim, t, p, ng, ns, eps):
        self.prim, self.t, self.p, self.ng, self.ns, self.eps = prim, t, p, ng, ns, eps


class Geometry:
    """The scene's triangles in one Embree mesh (primID = triangle index) plus float64 copies."""

    def __init__(self, positions: np.ndarray, triangles: np.ndarray, normals: np.ndarray | None):
        self.positions = positions.astype(np.float64)
        self.triangles = triangles.astype(np.int64)
        self.normals = None if normals is None else normals.astype(np.float64)
        self.count = len(triangles)
        self.embree_time = 0.0
        self.ray_count = 0
        self._lock = threading.Lock()
        # Corner positions (and normals) per triangle, so a hit gathers one row, not six.
        self.corners = self.positions[self.triangles]
        self.corner_normals = None if normals is None else self.normals[self.triangles]
        if self.count:
            corners = self.corners
            cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
            length = np.linalg.norm(cross, axis=1)
            self.area = 0.5 * length
            # Degenerate triangles cannot be hit in a meaningful way; give them any unit normal.
            safe = np.where(length > 0.0, length, 1.0)[:, None]
            self.face_normal = np.where(length[:, None] > 0.0, cross / safe, [0.0, 0.0, 1.0])
            self.tri_scale = np.abs(corners).max(axis=(1, 2))
            extent = float(np.ptp(self.positions, axis=0).max())
        else:
            self.area = np.zeros(0)
            self.face_normal = np.zeros((0, 3))
            self.tri_scale = np.zeros(0)
            extent = 1.0
        self.extent = max(extent, 1e-12)
        self.floor_offset = FLOOR_OFFSET * self.extent + 1e-30
        self._scene = None
        if self.count:
            self._scene = rtcore_scene.EmbreeScene()
            TriangleMesh(self._scene, positions.astype(np.float32), triangles.astype(np.int32))

    def _timed(self, n, fn):
        start = time.perf_counter()
        out = fn()
        elapsed = time.perf_counter() - start
        with self._lock:
            self.embree_time += elapsed
            self.ray_count += n
        return out

    def intersect(self, o: np.ndarray, d: np.ndarray, tmax: np.ndarray | None = None):
        """Closest hit per ray: (primID with -1 for a miss, u, v, t)."""
        n = len(o)
        if self._scene is None or n == 0:
            return np.full(n, -1, np.int32), np.zeros(n, np.float32), np.zeros(n, np.float32), np.full(n, FAR)
        o32 = np.ascontiguousarray(o, dtype=np.float32)
        d32 = np.ascontiguousarray(d, dtype=np.float32)
        dists = np.full(n, FAR, np.float32) if tmax is None else np.ascontiguousarray(tmax, np.float32)
        res = self._timed(n, lambda: self._scene.run(o32, d32, dists=dists, output=1))
        return res["primID"], res["u"], res["v"], res["tfar"]

    def occluded(self, o: np.ndarray, d: np.ndarray, tmax: np.ndarray) -> np.ndarray:
        """True where something blocks the segment o + t d, 0 <= t < tmax."""
        n = len(o)
        if self._scene is None or n == 0:
            return np.zeros(n, bool)
        o32 = np.ascontiguousarray(o, dtype=np.float32)
        d32 = np.ascontiguousarray(d, dtype=np.float32)
        dists = np.ascontiguousarray(np.minimum(tmax, FAR), np.float32)
        res = self._timed(n, lambda: self._scene.run(o32, d32, dists=dists, query="OCCLUDED"))
        return res == 0

    def hits(self, prim: np.ndarray, u: np.ndarray, v: np.ndarray, t: np.ndarray) -> Hits:
        """Rebuild hit points from barycentrics in float64 (not from o + t d) with their normals."""
        u = u.astype(np.float64)[:, None]
        v = v.astype(np.float64)[:, None]
        w = 1.0 - u - v
        c = self.corners[prim]
        p = w * c[:, 0] + u * c[:, 1] + v * c[:, 2]
        ng = self.face_normal[prim]
        if self.corner_normals is None:
            ns = ng
        else:
            c = self.corner_normals[prim]
            ns = w * c[:, 0] + u * c[:, 1] + v * c[:, 2]
            length = np.linalg.norm(ns, axis=1, keepdims=True)
            ns = np.where(length > 1e-12, ns / np.where(length > 0, length, 1.0), ng)
        eps = np.maximum(RELATIVE_OFFSET * np.maximum(self.tri_scale[prim], np.abs(p).max(axis=1)),
                         self.floor_offset)
        return Hits(prim, t.astype(np.float64), p, ng, ns, eps)


def offset_origin(p: np.ndarray, ng: np.ndarray, eps: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Move p off its surface along the geometric normal, to the side `direction` leaves to."""
    side = np.where(np.einsum("ij,ij->i", direction, ng) >= 0.0, 1.0, -1.0)
    return p + (side * eps)[:, None] * ng

