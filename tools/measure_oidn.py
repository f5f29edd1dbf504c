#!/usr/bin/env python3
"""Time Open Image Denoise as Snell loads it (tracer/denoise.py, ctypes on OIDN's C API) from
each library given: loading, and denoising a noisy image with albedo and normal at each size,
prefilter and quality (two runs each: the first includes OIDN's own set-up).

    .venv/bin/python tools/measure_oidn.py [LIBRARY ...] [--sizes 256,1024]
        [--prefilters none,accurate] [--qualities high,fast] [--threads 2]

Without a LIBRARY, the one Snell finds (Blender's, the bpy wheel's, pyoidn's, the system's). To
time pyoidn's bundled library, install the wheel anywhere (pip install --target DIR pyoidn) and
pass DIR/pyoidn/oidn/lib/libOpenImageDenoise.so.2.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def measure(args):
    """Time the library Snell loads in this process (SNELL_OIDN_LIBRARY, when given)."""
    from snell.tracer import denoise
    start = time.perf_counter()
    lib = denoise.load()
    print(f"{lib.path}: loaded in {time.perf_counter() - start:.3f} s")
    rng = np.random.default_rng(0)
    for n in args.sizes:
        color = (0.5 + rng.exponential(0.5, (n, n, 3))).astype(np.float32)
        albedo = (0.5 + rng.normal(0.0, 0.05, (n, n, 3))).astype(np.float32)
        normal = np.zeros((n, n, 3), np.float32)
        normal[..., 2] = -1.0
        for prefilter in args.prefilters:
            for quality in args.qualities:
                times = []
                for _ in range(2):
                    start = time.perf_counter()
                    denoise.denoise(color, albedo, normal, prefilter, quality, args.threads)
                    times.append(time.perf_counter() - start)
                print(f"  {n}x{n} prefilter {prefilter}, quality {quality}: "
                      f"{times[0]:.2f} s, then {times[1]:.2f} s")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("libraries", nargs="*")
    parser.add_argument("--sizes", default="256,1024")
    parser.add_argument("--prefilters", default="none,accurate")
    parser.add_argument("--qualities", default="high,fast")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args(argv)
    args.sizes = [int(s) for s in args.sizes.split(",")]
    args.prefilters, args.qualities = args.prefilters.split(","), args.qualities.split(",")
    if not args.libraries:
        return measure(args)
    for library in args.libraries:   # one process each: a process loads one OIDN
        command = [sys.executable, os.path.abspath(__file__), "--sizes",
                   ",".join(map(str, args.sizes)), "--prefilters", ",".join(args.prefilters),
                   "--qualities", ",".join(args.qualities), "--threads", str(args.threads)]
        subprocess.run(command, check=True, env={**os.environ, "SNELL_OIDN_LIBRARY": library})


if __name__ == "__main__":
    sys.exit(main())
