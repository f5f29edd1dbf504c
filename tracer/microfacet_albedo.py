"""The integrals that the microfacet tables hold, estimated from Snell's own BSDF.

Each table cell is the mean, over sample points, of one sample of a single-scattering lobe
(lobes.lobe_sample with ENERGY 1 and weight 1) seen from wi = (sqrt(1 - mu^2), 0, mu), on the
grids of Cycles' cycles_precompute.cpp (Blender 5.0):

- GGX_E: GGX reflection without Fresnel (eta 1), value f / pdf: the directional albedo E.
- GLASS_E, GLASS_INV_E: GGX reflection plus refraction with the dielectric Fresnel at eta = ior
  and 1 / ior, value f / pdf.
- REMAP_S: GGX reflection with the remapped dielectric Fresnel at eta = ior, value the sample's
  interpolation factor s between f0 and 1 (the red channel of a lobe whose F0 is (0, 1, 0),
  over its green one), clamped to [0, 1].

A rejected sample (wo below the surface) counts as 0, as in Cycles. The averaged tables integrate
2 mu x value over mu in [0, 1], mu being the points' fourth coordinate. tools/build_microfacet_
tables.py runs these over scrambled Sobol points and writes tracer/data/microfacet_tables.npz.
"""
from __future__ import annotations

import math

from .fresnel import ior_from_f0
from .jit import jit
from .lobes import (DIST_GGX, DIELECTRIC, F0, NO_FRESNEL, REMAPPED, lobe_sample, new_microfacet,
                    set_vec)

# What a table integrates.
GGX_E, GLASS_E, GLASS_INV_E, REMAP_S = range(4)
# Cycles' clamps of the grid coordinates (roughness and cosine away from 0, z away from 1).
MIN_COORDINATE, MAX_Z = 1e-4, 0.99
NORMAL = (0.0, 0.0, 1.0)


@jit
def grid_rough(x, nx):
    """Roughness (sqrt(alpha)) of grid column x of nx."""
    return min(max(x / (nx - 1), MIN_COORDINATE), 1.0)


@jit
def grid_mu(y, ny):
    """Cosine of the incident direction at grid row y of ny."""
    return min(max(y / (ny - 1), MIN_COORDINATE), 1.0)


@jit
def grid_ior(z, nz):
    """The index (above 1) of grid slice z of nz: F0 = z^4 spreads the slices over [1, 100),
    most of them in 1-2 (Cycles' ior_parametrization)."""
    c = min(max(z / (nz - 1), MIN_COORDINATE), MAX_Z)
    return ior_from_f0(c * c * c * c)


@jit
def setup_table_lobe(lobe, table, rough, ior):
    """Make `lobe` (one row) the single-scattering GGX lobe whose albedo `table` holds."""
    alpha = rough * rough
    white = (1.0, 1.0, 1.0)
    if table == GGX_E:
        new_microfacet(lobe, NORMAL, white, DIST_GGX, alpha, 1.0, True, False, NO_FRESNEL)
    elif table == REMAP_S:
        new_microfacet(lobe, NORMAL, white, DIST_GGX, alpha, ior, True, False, REMAPPED)
        # Red reflects mix(0, 1, s) = s, green mix(1, 1, s) = 1: their ratio is s.
        set_vec(lobe, F0, (0.0, 1.0, 0.0))
    else:
        eta = ior if table == GLASS_E else 1.0 / ior
        new_microfacet(lobe, NORMAL, white, DIST_GGX, alpha, eta, True, True, DIELECTRIC)


@jit
def sample_value(lobe, table, mu, u0, u1, u2):
    """One sample of a cell's integrand from the lobe seen at cosine mu: f / pdf, or the remap
    factor s for REMAP_S; 0 for a rejected sample."""
    wi = (math.sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu)
    _, f, pdf, _, _, valid = lobe_sample(lobe, NORMAL, wi, u0, u1, u2)
    if not valid or not pdf > 0.0:
        return 0.0
    if table == REMAP_S:
        return min(max(f[0] / f[1], 0.0), 1.0) if f[1] > 0.0 else 0.0
    return (f[0] + f[1] + f[2]) / (3.0 * pdf)


@jit
def cell_estimate(lobe, table, rough, ior, mu, averaged, points):
    """(mean, standard error) of a cell over points[r, i] = (u0, u1, u2, u_mu): r indexes
    independent replicates (their spread gives the error), i the points of one replicate.
    averaged: integrate 2 mu x value over mu = u_mu instead of taking mu as given."""
    setup_table_lobe(lobe, table, rough, ior)
    replicates, count = points.shape[0], points.shape[1]
    mean, m2 = 0.0, 0.0
    for r in range(replicates):
        total = 0.0
        for i in range(count):
            u0, u1, u2 = points[r, i, 0], points[r, i, 1], points[r, i, 2]
            if averaged:
                cosine = points[r, i, 3]
                total += 2.0 * cosine * sample_value(lobe, table, cosine, u0, u1, u2)
            else:
                total += sample_value(lobe, table, mu, u0, u1, u2)
        # Welford's update over the replicates' means.
        delta = total / count - mean
        mean += delta / (r + 1)
        m2 += delta * (total / count - mean)
    se = math.sqrt(m2 / (replicates - 1) / replicates) if replicates > 1 else math.inf
    return mean, se


@jit
def fill_table(table, points, lobe, out, out_se):
    """Every cell of out[z, y, x] (z: index slice, y: cosine row, x: roughness column) and its
    standard error. A single slice means eta 1 (GGX_E), a single row the average over mu."""
    nz, ny, nx = out.shape
    averaged = ny == 1
    for z in range(nz):
        ior = grid_ior(z, nz) if nz > 1 else 1.0
        for y in range(ny):
            mu = grid_mu(y, ny) if ny > 1 else 0.0
            for x in range(nx):
                mean, out_se[z, y, x] = cell_estimate(lobe, table, grid_rough(x, nx), ior, mu,
                                                      averaged, points)
                # Clamped to [0, 1] as Cycles does (a mean of ones can round to 1 + 2e-16).
                out[z, y, x] = min(max(mean, 0.0), 1.0)
