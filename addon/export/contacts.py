"""Refracting surfaces lying on another object's surface, such as a glass standing exactly on a
table: where Snell and Cycles part ways.

Cycles starts a ray on the surface it leaves and skips only that triangle (kernel/bvh/util.h,
intersection_skip_self), so a ray leaving a glass's base finds the table's face at a distance
of about 0. Snell starts it a few float steps off the surface (geometry.offset_origin), past
the table's face. Where the two faces coincide, the renders differ: a glass tube standing on its
table gave 0.23 at its rim in Cycles against 2.6 in Snell; lifted by 0.1 mm, 3.00 against 3.14
(docs/measurements.md, "Caustic scenes in the bench"). Neither is a physical contact, so the
exporter warns and the validator calls such a scene not comparable.
"""
from __future__ import annotations

import numpy as np

# Faces are in one plane when their unit normals agree to this (quantized per component) and
# their distances from the origin to this fraction of the scene's size.
NORMAL_STEP = 1e-4
DISTANCE_STEP = 1e-6
# The in-plane overlap, as a fraction of the scene's size, below which faces only touch at an
# edge (a glass cube standing beside a box) and are not counted.
MIN_OVERLAP = 1e-4

_MIX = np.array([0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9,
                 0x27D4EB2F165667C5], dtype=np.uint64)


def refracting_contacts(positions, triangles, object_ids, refracting) -> list[tuple[int, int]]:
    """The pairs (refracting object, other object) that have faces in one plane overlapping:
    `refracting` marks the triangles whose material refracts."""
    tri = np.asarray(positions, np.float64)[np.asarray(triangles)]
    object_ids = np.asarray(object_ids, np.int64)
    refracting = np.asarray(refracting, bool)
    if not refracting.any() or len(np.unique(object_ids)) < 2:
        return []
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normal, axis=1)
    keep = length > 0.0
    tri, normal = tri[keep], normal[keep] / length[keep, None]
    object_ids, refracting = object_ids[keep], refracting[keep]
    # One sign for both sides: a glass's base faces down, the table's top up.
    biggest = np.argmax(np.abs(normal), axis=1)
    normal *= np.where(normal[np.arange(len(normal)), biggest] < 0.0, -1.0, 1.0)[:, None]
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    size = float(np.max(hi.max(axis=0) - lo.min(axis=0))) or 1.0
    distance = np.einsum("ij,ij->i", normal, tri[:, 0]) / (DISTANCE_STEP * size)
    plane = np.column_stack([np.round(normal / NORMAL_STEP), np.round(distance)]).astype(np.int64)
    groups = _object_planes(plane, object_ids, refracting, lo, hi)
    pairs = set()
    for g, o in _candidates(groups):
        if _overlap(groups.lo[g], groups.hi[g], groups.lo[o], groups.hi[o], MIN_OVERLAP * size):
            pairs.add((int(groups.obj[g]), int(groups.obj[o])))
    return sorted(pairs)


def _candidates(groups):
    """Pairs (refracting group, group of another object) in one plane, either neighbouring
    distance step included (a plane may round to either side)."""
    h = _plane_hash(groups.plane)
    order = np.argsort(h, kind="stable")
    h_sorted = h[order]
    # Whether a plane holds groups of two objects decides, in NumPy, which few groups go on.
    pairs = []
    refr = np.flatnonzero(groups.refracts)
    for step in (-1, 0, 1):
        probe = _plane_hash(groups.plane[refr] + [0, 0, 0, step])
        sort = np.argsort(probe)    # sorted probes search several times faster
        left = np.empty_like(sort)
        right = np.empty_like(sort)
        left[sort] = np.searchsorted(h_sorted, probe[sort], "left")
        right[sort] = np.searchsorted(h_sorted, probe[sort], "right")
        more = right - left > (1 if step == 0 else 0)
        for g, a, b in zip(refr[more], left[more], right[more]):
            for o in order[a:b]:
                if groups.obj[o] != groups.obj[g] and np.array_equal(
                        groups.plane[o], groups.plane[g] + [0, 0, 0, step]):
                    pairs.append((g, o))
    return pairs


def _plane_hash(plane):
    """One 64-bit hash of each row of plane keys (collisions only add candidates)."""
    return (plane.astype(np.uint64) * _MIX).sum(axis=1, dtype=np.uint64)


class _Groups:
    """Each object's faces in each plane, as one box around them: rows of plane keys, object,
    low and high corners, whether any of them refracts."""

    def __init__(self, plane, obj, lo, hi, refracts):
        self.plane, self.obj, self.lo, self.hi, self.refracts = plane, obj, lo, hi, refracts


def _object_planes(plane, object_ids, refracting, lo, hi) -> _Groups:
    """The faces grouped by plane and object."""
    # One sort of a 64-bit hash of (plane, object) instead of a sort on five keys.
    key = _plane_hash(plane) ^ (object_ids.astype(np.uint64) * _MIX[0])
    order = np.argsort(key, kind="stable")
    key, plane, object_ids = key[order], plane[order], object_ids[order]
    lo, hi, refracting = lo[order], hi[order], refracting[order]
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    return _Groups(plane[starts], object_ids[starts], np.minimum.reduceat(lo, starts),
                   np.maximum.reduceat(hi, starts), np.logical_or.reduceat(refracting, starts))


def _overlap(a_lo, a_hi, b_lo, b_hi, least) -> bool:
    """Whether two boxes around faces of one plane overlap over more than an edge: their
    overlap is at least `least` along the two axes it is longest on."""
    extent = np.minimum(a_hi, b_hi) - np.maximum(a_lo, b_lo)
    if np.any(extent < -least):
        return False
    return bool(np.sort(extent)[-2] >= least)
