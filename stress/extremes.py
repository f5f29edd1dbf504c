"""Stress cases of image extremes: 1x1 pixel, 1 spp, a big render's value and peak memory."""
from __future__ import annotations

import json
import os
import subprocess
import sys

from ..tracer import wavefront
from ..tracer.passes import CHUNK, PASS_PATHS
from .cases import (AT_MOST, ENDED_EVENTS, EXACT, UNIT_ROUNDING, Case, Outcome,
                    furnace_outcome, material, render)
from .geometry import WHITE, camera, quad, scene
from .glass import SLAB_IOR, furnace_scene


# ---------------------------------------------------------------------------------------------
# Image extremes


def _small_image_case(resolution, spp, quick):
    def run(threads, seed):
        scn = furnace_scene("glass", resolution=resolution, spp=spp)
        if resolution == 1:      # the ball fills the single pixel
            scn = scn.with_camera(lens=200.0)
        return furnace_outcome(render(scn, threads, seed), scn)
    return Case(f"{resolution}x{resolution} at {spp} spp", "image extremes",
                "mean of all samples in a white furnace (each exactly 1)",
                "a tiny image or a single sample breaks the pass and chunk arithmetic",
                EXACT, 1.0, run, quick)


BIG_SIZE, BIG_SIZE_QUICK = 8192, 1024
MEMORY_SLACK = 16 << 20   # the allocator's per-thread arenas and Python's own objects
JOB_BYTES = 2048          # one chunk job of a pass: its tuple and its Future (measured 1.7 KB)


def working_set_bytes(threads: int, npix: int) -> int:
    """What a render needs besides its two (H, W, 3) float64 sums and its float32 image: each
    thread's chunk buffers (tracer/integrator._Buffers), one pass's chunk jobs (the pool holds a
    Future per chunk of the pass: at most max(npix, PASS_PATHS) / CHUNK of them, whatever the
    sample count) and MEMORY_SLACK."""
    per_thread = (sum(a.nbytes for a in wavefront.new_paths(CHUNK)) * 2
                  + sum(a.nbytes for a in wavefront.new_shadows(CHUNK))
                  + CHUNK * (3 * 8 + 8))
    jobs = (max(npix, PASS_PATHS) // CHUNK + 1) * JOB_BYTES
    return threads * per_thread + jobs + MEMORY_SLACK


def _big_scene(size, spp):
    pos, tri = quad((0.0, 0.0, 0.0), 1.0, 1.0)
    cam = camera(position=(0, 0, 20.0), resolution=(size, size), lens=50.0)
    return scene([(pos, tri, 0)], [material("glass", SLAB_IOR)], cam, world=WHITE, spp=spp,
                 max_depth=8)


MEMORY_CHILD = r"""
import importlib, json, sys
sys.path[:0] = {path!r}
cases = importlib.import_module({module!r})
print(json.dumps(cases.memory_child({size}, {spp}, {threads})))
"""


def memory_child(size, spp, threads):
    """Run in a child process: render the big image, report peak RSS (VmHWM) and the sums."""
    scn = _big_scene(size, spp)
    result = render(scn, threads, 0)
    image = result.mean()       # the image a user gets is part of the render
    with open("/proc/self/status") as f:
        peak = next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmHWM:"))
    events = sum(int(result.stats.get(k, 0)) for k in ENDED_EVENTS)
    return {"peak_bytes": peak, "sum": float(result.sum[..., 0].sum()), "n": size * size * spp,
            "events": events, "nan": result.nan_count, "time_s": result.time_s,
            "image_bytes": image.nbytes}


def _child(size, spp, threads):
    code = MEMORY_CHILD.format(path=list(sys.path), module=__name__, size=size, spp=spp,
                               threads=threads)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=3600)
    if out.returncode != 0:
        raise RuntimeError(f"memory child failed: {out.stderr.strip().splitlines()[-1:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def _big_cases(quick):
    size = BIG_SIZE_QUICK if quick else BIG_SIZE
    sums = 2 * size * size * 3 * 8       # float64 sum and sum of squares
    image = size * size * 3 * 4          # the float32 image RenderResult.mean() returns
    runs = {}

    def measure(threads):
        if threads not in runs:
            if not os.path.exists("/proc/self/status"):
                raise RuntimeError("peak RSS needs Linux's /proc")
            runs[threads] = (_child(1, 1, threads), _child(size, 1, threads),
                             _child(size, 2, threads))
        return runs[threads]

    def run_furnace(threads, seed):
        _, one, two = measure(threads)
        n = one["n"] + two["n"]
        events = one["events"] + two["events"]
        return Outcome((one["sum"] + two["sum"]) / n, tolerance=(10 + n) * UNIT_ROUNDING,
                       allowance=events / n, events=events, nan_count=one["nan"] + two["nan"],
                       settings={"resolution": f"{size}x{size}", "spp": "1 and 2", "max_depth": 8},
                       note=f"render {one['time_s']:.0f} s + {two['time_s']:.0f} s")

    def run_memory(threads, seed):
        base, one, two = measure(threads)
        above = max(one["peak_bytes"], two["peak_bytes"]) - base["peak_bytes"]
        return Outcome(float(above), allowance=float(working_set_bytes(threads, size * size)),
                       nan_count=one["nan"] + two["nan"],
                       settings={"resolution": f"{size}x{size}", "spp": "1 and 2", "max_depth": 8},
                       note=("peak above a 1x1 render: "
                             f"{(one['peak_bytes'] - base['peak_bytes']) / 2**20:.1f} MiB "
                             "at 1 spp, "
                             f"{(two['peak_bytes'] - base['peak_bytes']) / 2**20:.1f} MiB at "
                             f"2 spp; sums {sums / 2**20:.1f} MiB, image {image / 2**20:.1f} MiB"))
    return [
        Case(f"{size}x{size} furnace (glass quad)", "image extremes",
             "mean of all samples at 1 and 2 spp (each exactly 1)",
             "a large image loses or corrupts samples (index overflow, chunking)", EXACT, 1.0,
             run_furnace, True),
        Case(f"{size}x{size} peak memory", "image extremes",
             "peak RSS above a 1x1 render (bytes), at 1 and 2 spp, image included: at most the two "
             "float64 sums, the float32 image and the working set",
             "the render holds per-sample, per-pass or temporary images: memory grows with the "
             "sample count or the image is copied", AT_MOST, float(sums + image), run_memory, True),
    ]


def extreme_cases(quick=False):
    """1x1 pixel, 1 spp, and a big render's value and peak memory."""
    return [_small_image_case(1, 64, True), _small_image_case(64, 1, True)] + _big_cases(quick)
