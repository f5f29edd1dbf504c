"""The albedo tables of Cycles' microfacet energy compensation, and their interpolated lookup.

Cycles renders Multiscatter GGX as single-scattering GGX scaled by 1 / E, E being the lobe's
directional albedo (Kulla and Conty 2017), and weights the Principled BSDF's layers by an
estimate of the specular layer's albedo. Both come from tables indexed by roughness
(sqrt(alpha)), the cosine to the normal and, for dielectrics, z = sqrt(|eta - 1| / (eta + 1)):
the same grids as Cycles' shader.tables, read with the same linear interpolation
(kernel/util/lookup_table.h). Snell computes its own tables from its own BSDF
(tools/build_microfacet_tables.py) and keeps them in tracer/data/microfacet_tables.npz.
"""
from __future__ import annotations

import functools
import math
import os
from typing import NamedTuple

import numpy as np

from .jit import jit

TABLES_PATH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data",
                           "microfacet_tables.npz")


class MicrofacetTables(NamedTuple):
    """Albedo tables; the last axis is roughness, then cosine, then z."""
    ggx_e: np.ndarray          # (32, 32) GGX reflection albedo E(mu, rough)
    ggx_e_avg: np.ndarray      # (32,) its cosine-weighted average over mu
    glass_e: np.ndarray        # (16, 16, 16) GGX glass albedo, eta > 1, E(z, mu, rough)
    glass_e_avg: np.ndarray    # (16, 16)
    glass_inv_e: np.ndarray    # (16, 16, 16) the same for eta = 1 / ior < 1
    glass_inv_e_avg: np.ndarray
    remap_s: np.ndarray        # (16, 16, 16) mean Fresnel interpolation factor s(z, mu, rough)


def load_tables(path: str = TABLES_PATH) -> MicrofacetTables:
    """The tables shipped with Snell (float64 arrays)."""
    with np.load(path) as data:
        return MicrofacetTables(*(np.ascontiguousarray(data[name], np.float64)
                                  for name in MicrofacetTables._fields))


@functools.lru_cache(maxsize=1)
def shipped_tables() -> MicrofacetTables:
    """The shipped tables, read once per process."""
    return load_tables()


@jit
def lerp_1d(table, x):
    """table read at x in [0, 1] (clamped), linearly between its samples."""
    n = table.shape[0]
    x = min(max(x, 0.0), 1.0) * (n - 1)
    i = min(int(x), n - 1)
    j = min(i + 1, n - 1)
    t = x - i
    return (1.0 - t) * table[i] + t * table[j]


@jit
def lerp_2d(table, x, y):
    """table[y, x] read at (x, y) in [0, 1]^2, bilinearly."""
    n = table.shape[0]
    y = min(max(y, 0.0), 1.0) * (n - 1)
    i = min(int(y), n - 1)
    j = min(i + 1, n - 1)
    t = y - i
    return (1.0 - t) * lerp_1d(table[i], x) + t * lerp_1d(table[j], x)


@jit
def lerp_3d(table, x, y, z):
    """table[z, y, x] read at (x, y, z) in [0, 1]^3, trilinearly."""
    n = table.shape[0]
    z = min(max(z, 0.0), 1.0) * (n - 1)
    i = min(int(z), n - 1)
    j = min(i + 1, n - 1)
    t = z - i
    return (1.0 - t) * lerp_2d(table[i], x, y) + t * lerp_2d(table[j], x, y)


@jit
def ior_coordinate(eta):
    """The tables' z for a relative index eta > 0: sqrt(|eta - 1| / (eta + 1))."""
    return math.sqrt(abs((eta - 1.0) / (eta + 1.0)))


@jit
def ggx_albedo(tables, rough, mu):
    """(E, E_avg) of GGX reflection at roughness rough = sqrt(alpha) and cosine mu."""
    return lerp_2d(tables.ggx_e, rough, mu), lerp_1d(tables.ggx_e_avg, rough)


@jit
def glass_albedo(tables, rough, mu, eta):
    """(E, E_avg) of a GGX dielectric (reflection plus refraction) of relative index eta."""
    if eta < 1.0:
        z = ior_coordinate(1.0 / eta)
        return (lerp_3d(tables.glass_inv_e, rough, mu, z),
                lerp_2d(tables.glass_inv_e_avg, rough, z))
    z = ior_coordinate(eta)
    return lerp_3d(tables.glass_e, rough, mu, z), lerp_2d(tables.glass_e_avg, rough, z)


@jit
def remap_albedo(tables, rough, mu, eta):
    """The mean factor s with which a GGX reflection lobe with the remapped dielectric Fresnel
    reflects mix(f0, 1, s) of the light (Cycles' ggx_gen_schlick_ior_s)."""
    return lerp_3d(tables.remap_s, rough, mu, ior_coordinate(eta))
