"""The shipped microfacet albedo tables: recomputed cells, Cycles' published values, the lookups.

The tables (tracer/data/microfacet_tables.npz, tools/build_microfacet_tables.py) are integrals of
Snell's own single-scattering lobes on Cycles' grids; each cell carries its standard error.
"""
import math

import numpy as np
import pytest
from scipy import stats

from snell.tracer import lobes, microfacet_albedo as albedo
from snell.tracer.microfacet_tables import (ggx_albedo, glass_albedo, ior_coordinate, lerp_1d, lerp_2d,
                                            lerp_3d, remap_albedo)

from support.microfacet import STANDARD_ERRORS, TABLES

# (table field, what it integrates, cell (z, mu row, roughness column) or (z, roughness) for an
# averaged table, grid shape (nz, ny, nx)); one cell of every table, away from the grid's edges.
RECOMPUTED = [
    ("ggx_e", albedo.GGX_E, (0, 9, 20), (1, 32, 32)),
    ("ggx_e_avg", albedo.GGX_E, (0, 0, 24), (1, 1, 32)),
    ("glass_e", albedo.GLASS_E, (6, 4, 11), (16, 16, 16)),
    ("glass_e_avg", albedo.GLASS_E, (9, 0, 13), (16, 1, 16)),
    ("glass_inv_e", albedo.GLASS_INV_E, (6, 3, 12), (16, 16, 16)),
    ("glass_inv_e_avg", albedo.GLASS_INV_E, (4, 0, 10), (16, 1, 16)),
    ("remap_s", albedo.REMAP_S, (8, 2, 14), (16, 16, 16)),
]


def _stored(name, cell, shape):
    """A cell of a shipped table and its standard error (tables drop their size-1 axes)."""
    index = tuple(i for i, n in zip(cell, shape) if n > 1)
    return TABLES._asdict()[name][index], STANDARD_ERRORS[name][index]


def test_recomputed_cells_match_the_table():
    """Each table's cell, estimated again from 2^17 independent uniform points, agrees with the
    stored value within 3.2 combined standard errors (two-sided 1% over the 7 cells, Bonferroni)."""
    rng = np.random.default_rng(15)
    lobe = np.zeros(lobes.FIELDS)
    z_bound = stats.norm.isf(0.01 / 2 / len(RECOMPUTED))
    for name, table, (z, y, x), (nz, ny, nx) in RECOMPUTED:
        # One point per replicate: the replicate spread is the plain Monte Carlo error.
        points = rng.random((1 << 17, 1, 4))
        ior = albedo.grid_ior(z, nz) if nz > 1 else 1.0
        mu = albedo.grid_mu(y, ny) if ny > 1 else 0.0
        mean, se = albedo.cell_estimate(lobe, table, albedo.grid_rough(x, nx), ior, mu, ny == 1,
                                        points)
        stored, stored_se = _stored(name, (z, y, x), (nz, ny, nx))
        assert abs(mean - stored) < z_bound * math.hypot(se, stored_se), (name, mean, stored, se)


# Cycles 5.0's values (intern/cycles/kernel/tables/shader.tables), as facts to match:
# (table, cell as in the table's own layout (z, mu row, roughness column), Cycles' value).
CYCLES_VALUES = [
    ("ggx_e", (31, 31), 0.306853),
    ("ggx_e", (8, 20), 0.788846),
    ("ggx_e", (16, 10), 0.968235),
    ("ggx_e_avg", (16,), 0.870874),
    ("ggx_e_avg", (31,), 0.409137),
    ("glass_e", (12, 3, 15), 0.709514),
    ("glass_e", (6, 8, 10), 0.917349),
    ("glass_e_avg", (12, 15), 0.634955),
    ("glass_inv_e", (12, 15, 15), 0.303554),
    ("glass_inv_e", (6, 12, 10), 0.764848),
    ("remap_s", (6, 4, 8), 0.087983),
    ("remap_s", (10, 1, 15), 0.036542),
]
# Cycles' cells are estimates too (2^23 samples, printed to 6 decimals): a few 1e-5.
CYCLES_ERROR = 1e-4


def test_tables_match_cycles_published_values():
    """Snell's tables equal Cycles' where both integrate the same BSDF: within 4 of Snell's
    standard errors plus Cycles' own error. Not compared: Cycles' glass_inv_E at low cosines and
    its averages, which count refractions that leave on the reflection side (Cycles 5.0's
    sampler rejects them, as Snell's does): there Snell's albedo is lower, by up to 0.93 at
    mu = 1e-4 and about 1% in the averages."""
    for name, cell, value in CYCLES_VALUES:
        stored = TABLES._asdict()[name][cell]
        se = STANDARD_ERRORS[name][cell]
        assert abs(stored - value) < 4.0 * se + CYCLES_ERROR, (name, cell, stored, value, se)


def test_lerp_returns_grid_values_interpolates_midpoints_and_clamps():
    rng = np.random.default_rng(3)
    t1, t2, t3 = rng.random(7), rng.random((5, 7)), rng.random((4, 5, 7))
    for i in range(7):
        assert lerp_1d(t1, i / 6) == pytest.approx(t1[i], abs=1e-15)
    assert lerp_1d(t1, 2.5 / 6) == pytest.approx(0.5 * (t1[2] + t1[3]), abs=1e-15)
    assert lerp_1d(t1, -0.3) == t1[0] and lerp_1d(t1, 1.7) == t1[-1]
    # table[y, x] at (x, y); table[z, y, x] at (x, y, z).
    assert lerp_2d(t2, 3 / 6, 1 / 4) == pytest.approx(t2[1, 3], abs=1e-15)
    assert lerp_2d(t2, 3.5 / 6, 1.5 / 4) == pytest.approx(t2[1:3, 3:5].mean(), abs=1e-15)
    assert lerp_2d(t2, 2.0, -1.0) == t2[0, -1]
    assert lerp_3d(t3, 5 / 6, 2 / 4, 1 / 3) == pytest.approx(t3[1, 2, 5], abs=1e-15)
    assert lerp_3d(t3, 4.5 / 6, 0.5 / 4, 2.5 / 3) == pytest.approx(t3[2:4, 0:2, 4:6].mean(),
                                                                   abs=1e-15)
    assert lerp_3d(t3, -1.0, 9.0, 9.0) == t3[-1, -1, 0]


def test_albedo_lookups_read_the_cell_of_their_arguments():
    """At a grid point's roughness, cosine and index, each lookup returns that cell: the axes
    are in the order the build wrote them, and eta below 1 reads the inverse tables."""
    x, y, z = 5, 7, 9
    rough, mu, ior = x / 15, y / 15, albedo.grid_ior(z, 16)
    assert ior_coordinate(ior) == pytest.approx(z / 15, abs=1e-12)
    assert ggx_albedo(TABLES, 11 / 31, 20 / 31) == pytest.approx(
        (TABLES.ggx_e[20, 11], TABLES.ggx_e_avg[11]), abs=1e-12)
    assert glass_albedo(TABLES, rough, mu, ior) == pytest.approx(
        (TABLES.glass_e[z, y, x], TABLES.glass_e_avg[z, x]), abs=1e-9)
    assert glass_albedo(TABLES, rough, mu, 1 / ior) == pytest.approx(
        (TABLES.glass_inv_e[z, y, x], TABLES.glass_inv_e_avg[z, x]), abs=1e-9)
    assert remap_albedo(TABLES, rough, mu, ior) == pytest.approx(TABLES.remap_s[z, y, x], abs=1e-9)


def test_ggx_albedo_is_one_when_smooth_and_falls_with_roughness():
    """E = 1 at roughness ~0 (a mirror loses nothing) and everywhere at most 1; from mu = 0.13
    (row 4) up it falls as roughness grows. Nearer grazing it dips at roughness 0.1-0.2 and
    rises again, in Cycles' table too."""
    e = TABLES.ggx_e
    assert np.all(e[:, 0] == 1.0) and np.all(e <= 1.0)
    assert np.all(np.diff(e[4:], axis=1) < 0)
    assert e[4, -1] < 0.75 and e[-1, -1] < 0.35      # rough 1: 72% at mu = 0.13, 31% at mu = 1
    assert np.all(e[1:4].min(axis=1) < 0.9)
    assert TABLES.ggx_e_avg[0] == pytest.approx(1.0) and np.all(np.diff(TABLES.ggx_e_avg[1:]) < 0)
