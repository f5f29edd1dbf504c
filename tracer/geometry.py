"""Triangle geometry on Embree: ray queries, hit reconstruction and self-intersection offsets.

Per-triangle data is stored transposed, (k, T), so that `take(prim, axis=1)` gathers each hit's
rows into contiguous (k, n) arrays in one call (structure of arrays, as the integrator uses).
"""
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
    """Surface data for hits, (3, n) vectors: point, geometric and shading normals, offset size."""
    __slots__ = ("p", "ng", "ns", "eps")

    def __init__(self, p, ng, ns, eps):
        self.p, self.ng, self.ns, self.eps = p, ng, ns, eps


class Geometry:
    """The scene's triangles in one Embree mesh (primID = triangle index) plus float64 copies."""

    def __init__(self, positions: np.ndarray, triangles: np.ndarray, normals: np.ndarray | None):
        self.count = len(triangles)
        self.embree_time = 0.0
        self.ray_count = 0
        self._lock = threading.Lock()
        tri = triangles.astype(np.int64)
        # (T, 3 corners, xyz): a hit gathers its triangle's 72 contiguous bytes in one cache line
        # or two; a (9, T) layout would cost nine scattered reads per hit on big meshes.
        corners = positions.astype(np.float64)[tri]
        self.corners = corners
        self.corner_normals = None if normals is None else normals.astype(np.float64)[tri]
        cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        length = np.linalg.norm(cross, axis=1)
        self.area = 0.5 * length
        # Degenerate triangles cannot be hit in a meaningful way; give them any unit normal.
        unit = np.where(length[:, None] > 0.0, cross / np.where(length > 0.0, length, 1.0)[:, None],
                        [0.0, 0.0, 1.0])
        self.face_normal = np.ascontiguousarray(unit.T)                      # (3, T)
        self.tri_scale = np.abs(corners).max(axis=(1, 2)) if self.count else np.zeros(0)
        extent = float(np.ptp(positions, axis=0).max()) if self.count else 1.0
        self.extent = max(extent, 1e-12)
        self.floor_offset = FLOOR_OFFSET * self.extent
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

    def intersect(self, o: np.ndarray, d: np.ndarray, tmax: np.ndarray):
        """Closest hit per ray of (3, n) origins and directions: (primID, -1 = miss; u; v; t)."""
        n = o.shape[1]
        if self._scene is None or n == 0:
            return np.full(n, -1, np.int32), np.zeros(n, np.float32), np.zeros(n, np.float32), np.full(n, FAR)
        o32 = np.ascontiguousarray(o.T, dtype=np.float32)
        d32 = np.ascontiguousarray(d.T, dtype=np.float32)
        dists = np.minimum(tmax, FAR).astype(np.float32)
        res = self._timed(n, lambda: self._scene.run(o32, d32, dists=dists, output=1))
        return res["primID"], res["u"], res["v"], res["tfar"]

    def occluded(self, o: np.ndarray, d: np.ndarray, tmax: np.ndarray) -> np.ndarray:
        """True where something blocks the segment o + t d, 0 <= t < tmax ((3, n) inputs)."""
        n = o.shape[1]
        if self._scene is None or n == 0:
            return np.zeros(n, bool)
        o32 = np.ascontiguousarray(o.T, dtype=np.float32)
        d32 = np.ascontiguousarray(d.T, dtype=np.float32)
        dists = np.minimum(tmax, FAR).astype(np.float32)
        res = self._timed(n, lambda: self._scene.run(o32, d32, dists=dists, query="OCCLUDED"))
        return res == 0

    def hits(self, prim: np.ndarray, u: np.ndarray, v: np.ndarray) -> Hits:
        """Rebuild hit points from barycentrics in float64 (not from o + t d) with their normals."""
        u = u.astype(np.float64)
        v = v.astype(np.float64)
        bary = np.stack([1.0 - u - v, u, v])
        p = interpolate(self.corners, prim, bary)
        ng = self.face_normal.take(prim, axis=1)
        if self.corner_normals is None:
            ns = ng
        else:
            ns = interpolate(self.corner_normals, prim, bary)
            length = np.sqrt(ns[0] * ns[0] + ns[1] * ns[1] + ns[2] * ns[2])
            ns = np.where(length > 1e-12, ns / np.where(length > 0, length, 1.0), ng)
        return Hits(p, ng, ns, hit_offset(self, prim, p))


def hit_offset(geometry: Geometry, prim: np.ndarray, p: np.ndarray) -> np.ndarray:
    """How far to lift points p (3, n) on triangles prim off their surface."""
    scale = np.maximum(np.maximum(np.abs(p[0]), np.abs(p[1])), np.abs(p[2]))
    return np.maximum(RELATIVE_OFFSET * np.maximum(geometry.tri_scale.take(prim), scale),
                      geometry.floor_offset)


def interpolate(corner_values: np.ndarray, prim: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """Barycentric interpolation (3, n) of per-corner vectors (T, 3, 3) at triangles prim."""
    # Gather each hit's nine contiguous values, then transpose once into contiguous (9, n) rows:
    # twice as fast as an einsum over the gathered (n, 3, 3) block.
    c = np.ascontiguousarray(corner_values.reshape(-1, 9).take(prim, axis=0).T)
    out = c[0:3] * bary[0]
    out += c[3:6] * bary[1]
    out += c[6:9] * bary[2]
    return out


def offset_origin(p: np.ndarray, ng: np.ndarray, eps: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Move points p (3, n) off their surface along ng, to the side `direction` leaves to."""
    toward = ng[0] * direction[0] + ng[1] * direction[1] + ng[2] * direction[2]
    return p + np.where(toward >= 0.0, eps, -eps) * ng
