#!/usr/bin/env python3
"""Where manifold next-event estimation's stage (tracer/mnee.py) spends its time: renders a scene
of tests/support/sds_scenes.py with its shadow-caustics flags, once to compile and warm up and
then --runs times in the same process, each of mnee's kernels and phases timed from Python in
the rendering thread's CPU time (time.thread_time); prints each one's median over the runs, and
the whole render's wall time (the render runs in a worker thread). Pin it to one core
(taskset -c 0) on a shared machine.

    taskset -c 0 .venv/bin/python tools/measure_mnee_stage.py [--scene pool] [--size 64]
        [--spp 16] [--runs 5] [--count]

Embree inside a phase is the phase less its kernels. --count (a separate run: its bookkeeping
is Python) prints the walks' Newton iterations instead: per converged and per failed walk, and
the wavefront passes (each pass loops over every chain).
"""
from __future__ import annotations

import argparse
import collections
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
KERNELS = ("seed_chains", "probe_rays", "probe_hits", "newton_rays", "newton_accept", "reseed",
           "visibility_rays", "check_segments", "light_rays", "deliver")
PHASES = ("stage", "probe", "walk")


def timed(mnee, name, totals):
    """Replace mnee.NAME by a wrapper adding its thread CPU time to totals[name]."""
    inner = getattr(mnee, name)

    def wrapper(*args, **kwargs):
        start = time.thread_time()
        try:
            return inner(*args, **kwargs)
        finally:
            totals[name] += time.thread_time() - start
    setattr(mnee, name, wrapper)


def counting(mnee, counts):
    """Wrap mnee.walk to count each chain's Newton iterations (passes of newton_rays while it
    solves) by its exit."""
    inner = mnee.walk

    def walk(geometry, tables, mats, chains, n):
        iterations = np.zeros(n, np.int64)
        rays = mnee.newton_rays

        def counted(mesh, chains_, n_):
            solving = chains_.state[:n_] == mnee.SOLVING
            iterations[solving] += 1
            counts["passes"] += 1
            counts["chain visits"] += n_
            counts["solving visits"] += int(solving.sum())
            return rays(mesh, chains_, n_)
        mnee.newton_rays = counted
        try:
            inner(geometry, tables, mats, chains, n)
        finally:
            mnee.newton_rays = rays
        walked = iterations > 0
        state = chains.state[:n]
        for label, which in (("converged", state == mnee.CONVERGED),
                             ("failed", state == mnee.FAILED)):
            counts[label] += list(iterations[walked & which])
    mnee.walk = walk


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scene", default="pool", choices=("pool", "tumbler"))
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--count", action="store_true")
    parser.add_argument("--off", action="store_true", help="without the flags (no MNEE)")
    parser.add_argument("--blend", help="a .blend (its own flags; --size: the percentage of its "
                        "resolution) instead of --scene")
    args = parser.parse_args()
    sys.path[:0] = [os.path.join(ROOT, "tests"), os.path.join(ROOT, "scenes")]
    from support import sds_scenes
    from snell.tracer import mnee
    from snell.tracer.integrator import Renderer
    if args.blend:
        from snell.addon.export import export_blend
        scene, _ = export_blend(args.blend)
        scene = scene.with_camera(resolution_percentage=args.size)
        settings = scene.settings(spp=args.spp, threads=1, seed=1, noise_threshold=0.0,
                                  **({"shadow_caustics": False} if args.off else {}))
    else:
        build = {"pool": sds_scenes.pool, "tumbler": sds_scenes.tumbler}[args.scene]
        scene = sds_scenes.shadow_caustics(build(resolution=(args.size, args.size)),
                                           not args.off)
        settings = scene.settings(spp=args.spp, threads=1, seed=1, noise_threshold=0.0)
    Renderer(scene, settings).render()                       # compiles, warms up
    totals = collections.Counter()
    counts = collections.defaultdict(int, converged=[], failed=[])
    if args.count:
        counting(mnee, counts)
    else:
        for name in KERNELS + PHASES:
            timed(mnee, name, totals)
    runs = collections.defaultdict(list)
    for _ in range(args.runs):
        totals.clear()
        start = time.perf_counter()
        image = Renderer(scene, settings).render().mean()[..., 0]
        runs["render"].append(time.perf_counter() - start)
        for name in KERNELS + PHASES:
            runs[name].append(totals[name])
    print(f"{args.blend or args.scene} {args.size}, {args.spp} spp, 1 thread: image mean "
          f"{image.mean():.6f}; medians of {args.runs} runs (thread CPU s; render: wall s)")
    if args.count:
        for label in ("converged", "failed"):
            it = np.array(counts[label])
            if len(it):
                print(f"  {label}: {len(it) // args.runs} walks a run, iterations mean "
                      f"{it.mean():.2f}, median {np.median(it):.0f}, 90% {np.quantile(it, 0.9):.0f}, "
                      f"99% {np.quantile(it, 0.99):.0f}, 99.9% {np.quantile(it, 0.999):.0f}")
        print(f"  newton passes {counts['passes'] // args.runs} a run, chains visited "
              f"{counts['chain visits'] // args.runs}, of them solving "
              f"{counts['solving visits'] // args.runs}")
        return
    for name in ("render",) + PHASES + KERNELS:
        print(f"  {name:16s} {np.median(runs[name]):8.4f}  (min {min(runs[name]):.4f})")
    kernels = {"probe": ("probe_rays", "probe_hits"), "walk": ("newton_rays", "newton_accept")}
    for phase, names in kernels.items():
        rest = np.array(runs[phase]) - sum(np.array(runs[k]) for k in names)
        print(f"  {phase} less its kernels (Embree, loop): {np.median(rest):.4f}")


if __name__ == "__main__":
    main()
