"""How busy `snell batch --workers` keeps its workers, with and without starting each frame
before the last one ends (farm/render.py's Session.prefetch).

    .venv/bin/python tools/measure_farm_batch.py [SCENE.blend] [--size 128] [--spp 64]
        [--frames 6] [--workers 2] [--runs 2]

Saves a copy of the scene with its camera moving over the frames, then renders them with
`snell batch --workers N --noise-threshold 0` in this process, in turn with the prefetch and
without it, and prints per run: the frames' wall time (from the first export to the last image
written), the frames that found their first windows started, the tasks' own seconds (WindowReply.task_s: tracing, not the worker's renderer build)
and the workers' idle share, 1 - task seconds / (wall x worker threads), which counts the
exports, the image writes, each frame's renderer builds and the wait for its last windows.
"""
import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

# bpy and snell's batch are imported in main(): Dask's worker processes import this script as
# their __main__, and bpy does not import there.


def moving_copy(scene_path: str, frames: int, folder: Path) -> str:
    """The scene with its camera moved a little along x on every frame, saved in folder."""
    import bpy
    bpy.ops.wm.open_mainfile(filepath=scene_path)
    scene = bpy.context.scene
    camera = scene.camera
    start = camera.location.x
    for frame in range(1, frames + 1):
        camera.location.x = start + 0.02 * (frame - 1)
        camera.keyframe_insert("location", index=0, frame=frame)
    path = folder / "moving.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    return str(path)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default="scenes/cornell_spheres.blend")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--runs", type=int, default=2)
    args = ap.parse_args()
    import bpy

    from snell import cli
    from snell.addon import batch
    from snell.farm import render as farm_render
    folder = Path(tempfile.mkdtemp(prefix="snell-farm-batch-"))
    blend = moving_copy(str(Path(args.scene).resolve()), args.frames, folder)
    scale = max(1, round(100 * args.size / bpy.context.scene.render.resolution_x))
    replies, spans = [], []
    real_add, real_frames, real_prefetch = farm_render._add, batch._render_frames, batch._prefetch

    def add(result, reply):
        replies.append(reply)
        real_add(result, reply)

    def frames(*a, **k):
        start = time.perf_counter()
        try:
            return real_frames(*a, **k)
        finally:
            spans.append(time.perf_counter() - start)
    found = []
    real_render = farm_render.render_frame

    def render_frame(*a, **k):
        started = a[7] if len(a) > 7 else k.get("started")
        found.append(started is not None and bool(started.futures))
        return real_render(*a, **k)
    farm_render._add, batch._render_frames, farm_render.render_frame = add, frames, render_frame
    rows = {True: [], False: []}
    for run in range(args.runs):
        for prefetch in (False, True):
            batch._prefetch = real_prefetch if prefetch else (lambda *a, **k: None)
            replies.clear()
            found.clear()
            status = cli.main(["batch", blend, "--frames", f"1-{args.frames}", "--spp",
                               str(args.spp), "--noise-threshold", "0", "--scale", str(scale),
                               "--workers", str(args.workers), "-o",
                               str(folder / f"f{int(prefetch)}_####.exr")])
            if status != 0:
                sys.exit("measure_farm_batch: the batch failed")
            wall, tasks = spans[-1], sum(r.task_s for r in replies)
            idle = 1.0 - tasks / (wall * args.workers)
            rows[prefetch].append(idle)
            print(f"run {run + 1}, prefetch {'on ' if prefetch else 'off'}: {args.frames} frames "
                  f"in {wall:.2f} s, {len(replies)} windows, tasks {tasks:.2f} s, idle "
                  f"{100 * idle:.1f}%, {sum(found)} frames found their windows started", flush=True)
    for prefetch in (False, True):
        print(f"prefetch {'on ' if prefetch else 'off'}: idle share median "
              f"{100 * statistics.median(rows[prefetch]):.1f}% "
              f"({', '.join(f'{100 * v:.1f}' for v in rows[prefetch])})")


if __name__ == "__main__":
    main()
