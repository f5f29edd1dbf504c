#!/usr/bin/env python3
"""Time the first, uncached compile of Snell's kernels: per function CPU seconds and the total.

    .venv/bin/python tools/measure_compile.py [--runs 1] [--top 25] [--passes]
        [--render SCENE.blend [--spp 1]]

Each run is a fresh Python process whose kernel cache is a new, empty directory
(SNELL_KERNEL_CACHE), so nothing is loaded from any earlier compile and no one else's cache is
touched. The process runs integrator.warm_up() (every kernel), or with --render a render of
that scene at its own settings (what its first F12 compiles; --spp to make the render itself
short). Times are CPU seconds of the compiling thread (time.thread_time: far steadier than wall
time on a shared machine): a function's own seconds leave out the functions it compiled while
it was compiling (its callees, compiled first), `with callees` keeps them. Prints, per run, the
process's CPU and wall seconds, the seconds inside Numba's compiles, and the functions of the
most own seconds (with how many signatures each compiled); with several runs, the medians.
--passes adds, for the top functions, the compiler passes of the most CPU seconds (typing,
lowering and LLVM's optimisation of the function's module are passes of their own).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# Runs in the child, a fresh interpreter: records numba:compile and numba:run_pass events.
CHILD = r"""
import json, sys, threading, time
from numba.core import event

class Recorder(event.Listener):
    def __init__(self):
        self.local = threading.local()
        self.functions = {}   # qualname -> [own, with callees, signatures, own in LLVM]
        self.passes = {}      # (qualname, pass) -> own CPU seconds

    def stack(self, kind):
        # One stack per event kind: passes nest inside compiles, and compiles inside passes.
        return self.local.__dict__.setdefault(kind, [])

    def on_start(self, ev):
        self.stack(ev.kind).append([time.thread_time(), 0.0])
        if ev.kind == "numba:compile":
            self.local.__dict__.setdefault("current", []).append(ev.data)

    def on_end(self, ev):
        stack = self.stack(ev.kind)
        start, nested = stack.pop()
        if ev.kind == "numba:compile":
            self.local.current.pop()
        took = time.thread_time() - start
        if stack:
            stack[-1][1] += took
        if ev.kind == "numba:compile":
            d = ev.data["dispatcher"]
            name = d.py_func.__module__.rsplit(".", 1)[-1] + "." + d.py_func.__qualname__
            row = self.functions.setdefault(name, [0.0, 0.0, 0, 0.0])
            row[0] += took - nested
            row[1] += took
            row[2] += 1
            row[3] += self.local.__dict__.pop(id(ev.data), 0.0)
        elif ev.kind == "numba:llvm_lock":
            # Every call into LLVM takes this lock: its time goes to the innermost compile.
            compiles = self.stack("numba:compile")
            if compiles:
                key = id(self.local.current[-1])
                self.local.__dict__[key] = self.local.__dict__.get(key, 0.0) + took - nested
        else:
            name = ev.data["name"]
            self.passes[name] = self.passes.get(name, 0.0) + took - nested

rec = Recorder()
event.register("numba:compile", rec)
event.register("numba:run_pass", rec)
event.register("numba:llvm_lock", rec)
wall, cpu = time.perf_counter(), time.process_time()
mode = sys.argv[1]
if mode == "warm_up":
    from snell.tracer.integrator import warm_up
    warm_up()
else:
    from snell.cli import load_scene
    from snell.tracer.integrator import render
    scene = load_scene(mode)
    spp = int(sys.argv[2])
    render(scene, scene.settings(spp=spp) if spp > 0 else None)
print(json.dumps({"cpu": time.process_time() - cpu, "wall": time.perf_counter() - wall,
                  "functions": rec.functions, "passes": rec.passes}))
"""


def run_once(target: str, spp: int) -> dict:
    """One fresh process's compile: its figures as CHILD prints them."""
    with tempfile.TemporaryDirectory(prefix="snell-compile-") as cache:
        env = dict(os.environ, SNELL_KERNEL_CACHE=cache)
        out = subprocess.run([sys.executable, "-c", CHILD, target, str(spp)], env=env,
                             check=True, capture_output=True, text=True, cwd=ROOT).stdout
    return json.loads(out.strip().splitlines()[-1])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--top", type=int, default=25)
    parser.add_argument("--passes", action="store_true")
    parser.add_argument("--render", metavar="SCENE", help="render this scene instead of warm_up")
    parser.add_argument("--spp", type=int, default=0, help="with --render (0: the scene's own)")
    args = parser.parse_args(argv)
    target = os.path.abspath(args.render) if args.render else "warm_up"
    runs = []
    for k in range(args.runs):
        r = run_once(target, args.spp)
        compiling = sum(row[0] for row in r["functions"].values())
        print(f"run {k + 1}: {r['cpu']:.1f} s CPU, {r['wall']:.1f} s wall, {compiling:.1f} s CPU "
              f"compiling {len(r['functions'])} functions", flush=True)
        runs.append(r)
    med = statistics.median

    def median_of(name, k):
        return med(r["functions"].get(name, [0.0, 0.0, 0, 0.0])[k] for r in runs)
    functions = {name: [median_of(name, k) for k in range(4)]
                 for r in runs for name in r["functions"]}
    print(f"\n{target}: median of {len(runs)}: {med(r['cpu'] for r in runs):.1f} s CPU, "
          f"{med(r['wall'] for r in runs):.1f} s wall, "
          f"{med(sum(v[0] for v in r['functions'].values()) for r in runs):.1f} s CPU compiling, "
          f"{med(sum(v[3] for v in r['functions'].values()) for r in runs):.1f} s of it in LLVM")
    print(f"{'function':44s} {'own s':>7s} {'in LLVM':>8s} {'with callees':>13s} {'signatures':>10s}")
    ranked = sorted(functions.items(), key=lambda item: -item[1][0])
    for name, (own, total, sigs, llvm) in ranked[:args.top]:
        print(f"{name:44s} {own:7.2f} {llvm:8.2f} {total:13.2f} {sigs:10.0f}")
    rest = ranked[args.top:]
    print(f"{len(rest)} others{'':30s} {sum(v[0] for _, v in rest):7.2f} "
          f"{sum(v[3] for _, v in rest):8.2f}")
    if args.passes:
        for name, _ in ranked[:5]:
            qual = name.split(".", 1)[1]
            passes = sorted(((p, med(r["passes"].get(p, 0.0) for r in runs))
                             for p in {p for r in runs for p in r["passes"]}
                             if p.endswith(f"[{qual}]")), key=lambda item: -item[1])
            print(f"\n{name}: " + ", ".join(f"{p.split(' [')[0]} {s:.1f}" for p, s in passes[:6]))


if __name__ == "__main__":
    main()
