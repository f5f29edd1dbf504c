#!/usr/bin/env python3
"""Build tracer/data/microfacet_tables.npz: the albedo tables of Snell's microfacet lobes.

    .venv/bin/python tools/build_microfacet_tables.py [--log2-points 13] [--replicates 8]
                                                      [--cycles PATH/shader.tables] [--output F]

Every cell is estimated by tracer/microfacet_albedo.py over scrambled Sobol points (4D: two for
the visible normal, one for reflection or refraction, one for the cosine of the averaged
tables), the same points for every cell of a table, in independent replicates whose spread gives
each cell's standard error (stored as se_<table>, float32). The glass tables, whose integrand
jumps where reflection and refraction meet, get 4x the points, and each averaged table, which
also integrates over the cosine, 4x its table's. Fixed seed: the file is reproducible. With
--cycles, prints each table's differences from Cycles' own (Blender's
intern/cycles/kernel/tables/shader.tables); nothing of Cycles' is stored. Single-threaded; about
7 minutes at the defaults.
"""
from __future__ import annotations

import argparse
import os
import re
import time

import numpy as np
from scipy.stats import qmc

from snell.tracer import lobes, microfacet_albedo as albedo
from snell.tracer.microfacet_tables import TABLES_PATH

SEED = 20251123
# (table field, what it integrates, grid shape (z, mu, roughness), log2 of its points over the
# base count, Cycles' name)
TABLES = [
    ("ggx_e", albedo.GGX_E, (1, 32, 32), 0, "ggx_E"),
    ("ggx_e_avg", albedo.GGX_E, (1, 1, 32), 2, "ggx_Eavg"),
    ("glass_e", albedo.GLASS_E, (16, 16, 16), 2, "ggx_glass_E"),
    ("glass_e_avg", albedo.GLASS_E, (16, 1, 16), 4, "ggx_glass_Eavg"),
    ("glass_inv_e", albedo.GLASS_INV_E, (16, 16, 16), 2, "ggx_glass_inv_E"),
    ("glass_inv_e_avg", albedo.GLASS_INV_E, (16, 1, 16), 4, "ggx_glass_inv_Eavg"),
    ("remap_s", albedo.REMAP_S, (16, 16, 16), 0, "ggx_gen_schlick_ior_s"),
]


def sobol_points(replicates: int, log2_points: int, seed: int) -> np.ndarray:
    """(replicates, 2^log2_points, 4) independently Owen-scrambled Sobol points."""
    rng = np.random.default_rng(seed)
    return np.stack([qmc.Sobol(4, scramble=True, seed=rng).random_base2(log2_points)
                     for _ in range(replicates)])


def build(log2_points: int, replicates: int, seed: int = SEED, log=print) -> dict:
    """Every table, its standard errors (se_<name>) and its points per cell (points_<name>)."""
    lobe = np.zeros(lobes.FIELDS)
    out = {}
    for i, (name, table, shape, extra, _) in enumerate(TABLES):
        start = time.perf_counter()
        points = sobol_points(replicates, log2_points + extra, seed + i)
        values, se = np.zeros(shape), np.zeros(shape)
        albedo.fill_table(table, points, lobe, values, se)
        values, se = values.squeeze(), se.squeeze()
        out[name], out["se_" + name] = values, se.astype(np.float32)
        out["points_" + name] = np.array(points.shape[0] * points.shape[1])
        log(f"{name:16s} {values.shape!s:13s} {points.shape[0] * points.shape[1]:8d} points "
            f"{time.perf_counter() - start:6.1f} s  standard error max {se.max():.1e} "
            f"median {np.median(se):.1e}")
    return out


def read_cycles_tables(path: str) -> dict:
    """Cycles' float tables from shader.tables, by Cycles' name (flat arrays)."""
    text = open(path).read()
    found = {}
    for m in re.finditer(r"table_(\w+)\[(\d+)\]\s*=\s*\{(.*?)\};", text, re.S):
        found[m[1]] = np.array([float(v) for v in re.findall(r"[-+0-9.e]+(?=f)", m[3])])
    return found


def compare_with_cycles(tables: dict, path: str, log=print) -> None:
    """Print each table's largest and typical difference from Cycles' and where the largest is."""
    cycles = read_cycles_tables(path)
    log("difference from Cycles (Snell - Cycles): max |d|, median |d|, 99th percentile, at")
    for name, _, _, _, cycles_name in TABLES:
        ours = tables[name]
        theirs = cycles[cycles_name].reshape(ours.shape)
        d = ours - theirs
        worst = np.unravel_index(np.argmax(np.abs(d)), d.shape)
        log(f"{name:16s} {np.abs(d).max():.2e} {np.median(np.abs(d)):.2e} "
            f"{np.percentile(np.abs(d), 99):.2e}  {tuple(int(i) for i in worst)} "
            f"(Snell {ours[worst]:.6f}, Cycles {theirs[worst]:.6f}, se {tables['se_' + name][worst]:.1e})")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--log2-points", type=int, default=13,
                        help="log2 of the Sobol points per replicate (default 13)")
    parser.add_argument("--replicates", type=int, default=8)
    parser.add_argument("--cycles", help="Cycles' shader.tables, to compare with")
    parser.add_argument("--output", default=TABLES_PATH)
    args = parser.parse_args(argv)
    print(f"{args.replicates} replicates of 2^{args.log2_points} points per cell, more for some "
          f"tables", flush=True)
    start = time.perf_counter()
    tables = build(args.log2_points, args.replicates, log=lambda line: print(line, flush=True))
    print(f"built in {time.perf_counter() - start:.0f} s")
    os.makedirs(os.path.dirname(os.path.abspath(args.output)), exist_ok=True)
    np.savez_compressed(args.output, **tables)
    print("wrote", args.output)
    if args.cycles:
        compare_with_cycles(tables, args.cycles)


if __name__ == "__main__":
    main()
