"""The meshes of the scenes with caustics seen through glass, in numpy alone: scenes/pool.py and
scenes/tumbler_caustic.py build them into .blend files, tests/support/sds_scenes.py into tracer
scenes for the photon merging tests.
"""
import math

import numpy as np

POOL_HALF = 1.0          # the pool's floor and water span [-1, 1]^2
WATER_HEIGHT = 0.5
WAVE = 0.04              # the waves' amplitude in metres
TUBE_OUTER, TUBE_INNER, TUBE_HEIGHT, SEGMENTS = 0.4, 0.34, 0.9, 64
# How far the .blend scenes stand a tube above their floor: a bottom rim coplanar with the floor
# is resolved differently by Snell and Cycles (measured on scenes/hdri_caustic.py at 64 spp: the
# top rim's mean 21.7 in Snell against 0.34 in Cycles with the tube on the floor, 26.2 against
# 26.2 lifted 2 mm; image means 0.542 against 0.491, then 0.553 against 0.555).
TUBE_LIFT = 0.002


def water_surface(n=48, half=POOL_HALF, height=WATER_HEIGHT, amplitude=WAVE):
    """A wavy sheet z = height + waves over [-half, half]^2 (n x n quads), its smooth vertex
    normals from the waves' gradient: (positions, triangles, normals)."""
    s = np.linspace(-half, half, n + 1)
    x, y = np.meshgrid(s, s, indexing="ij")
    kx, ky = 2.0 * math.pi / 0.9, 2.0 * math.pi / 0.7
    z = height + amplitude * (np.sin(kx * x + 0.3) * np.cos(ky * y) + 0.5 * np.sin(1.7 * kx * y))
    dzdx = amplitude * kx * np.cos(kx * x + 0.3) * np.cos(ky * y)
    dzdy = amplitude * (-ky * np.sin(kx * x + 0.3) * np.sin(ky * y)
                        + 0.5 * 1.7 * kx * np.cos(1.7 * kx * y))
    normals = np.stack([-dzdx, -dzdy, np.ones_like(z)], -1)
    normals /= np.linalg.norm(normals, axis=-1, keepdims=True)
    pos = np.stack([x, y, z], -1).reshape(-1, 3)
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    tri = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                          np.stack([a, c, d], -1).reshape(-1, 3)])
    return pos.astype(np.float32), tri.astype(np.int32), normals.reshape(-1, 3).astype(np.float32)


def tube(outer=TUBE_OUTER, inner=TUBE_INNER, height=TUBE_HEIGHT, segments=SEGMENTS):
    """A thick-walled glass tube standing on z = 0 (a tumbler without its base: the table is
    its floor), closed: smooth outer and inner walls, flat rims. (positions, triangles,
    normals)."""
    a = 2.0 * np.pi * np.arange(segments) / segments
    c, s = np.cos(a), np.sin(a)
    pos, nrm, tri = [], [], []

    def ring(r, z, normals):
        pos.append(np.stack([r * c, r * s, np.full(segments, z)], -1))
        nrm.append(normals)
        return sum(len(p) for p in pos) - segments

    def band(i0, i1, flip):
        k, j = np.arange(segments), (np.arange(segments) + 1) % segments
        quads = [np.stack([i0 + k, i0 + j, i1 + j], -1), np.stack([i0 + k, i1 + j, i1 + k], -1)]
        t = np.concatenate(quads)
        tri.append(t[:, ::-1] if flip else t)

    radial = np.stack([c, s, np.zeros(segments)], -1)
    up = np.tile([0.0, 0.0, 1.0], (segments, 1))
    band(ring(outer, 0.0, radial), ring(outer, height, radial), False)        # outer wall
    band(ring(inner, 0.0, -radial), ring(inner, height, -radial), True)       # inner wall
    band(ring(inner, height, up), ring(outer, height, up), True)              # top rim
    band(ring(inner, 0.0, -up), ring(outer, 0.0, -up), False)                 # bottom rim
    return (np.concatenate(pos).astype(np.float32), np.concatenate(tri).astype(np.int32),
            np.concatenate(nrm).astype(np.float32))
