"""Time a fixed-sample render on this machine's threads and on Dask worker processes (farm/).

    .venv/bin/python tools/measure_farm.py [SCENE.blend|SCENE.snell] [--size 256] [--spp 256]
        [--runs 3] [--threads 2]

Renders the same image (--noise-threshold 0) locally with --threads threads, then on a
LocalCluster of 1 and of 2 single-threaded worker processes (kernels warm, the cluster started
before the clock), and prints medians over the runs: wall time, its ratio to the local render,
the windows, the sum of the tasks' own seconds, the overhead per task ((wall x threads - task
seconds) / tasks: scheduling, transfer, the client's merge, idle workers), the bytes a window
sends back, and the workers' BVH build. Checks that every distributed image is the local one.
"""
import argparse
import statistics
import sys
import time

import numpy as np

from snell.cli import load_scene
from snell.farm import cluster, render as farm_render
from snell.tracer.integrator import Renderer, warm_up


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default="scenes/cornell_spheres.blend")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    scene = load_scene(args.scene).with_camera(resolution=[args.size, args.size],
                                               resolution_percentage=100)
    settings = scene.settings(spp=args.spp, noise_threshold=0.0, threads=args.threads)
    warm_up()
    local_t, local = [], None
    for _ in range(args.runs):
        start = time.perf_counter()
        local = Renderer(scene, settings).render()
        local_t.append(time.perf_counter() - start)
    print(f"local, {args.threads} threads: {statistics.median(local_t):.2f} s median of "
          f"{args.runs} ({', '.join(f'{t:.2f}' for t in local_t)})")
    replies = []
    real_add = farm_render._add

    def add(result, reply):
        replies.append(reply)
        real_add(result, reply)
    farm_render._add = add
    for workers in (1, 2):
        with cluster.connect(None, workers) as client:
            threads = cluster.check_workers(client)
            times, task_s, builds = [], [], []
            for _ in range(args.runs):
                replies.clear()
                start = time.perf_counter()
                result = farm_render.render_frame(client, scene, settings, args.scene)
                times.append(time.perf_counter() - start)
                task_s.append(sum(r.task_s for r in replies))
                builds = sorted({(r.pid, round(r.build_s, 3)) for r in replies})
                if not (np.array_equal(result.sum, local.sum)
                        and np.array_equal(result.mean(), local.mean())):
                    sys.exit("measure_farm: the distributed image differs from the local one")
            wall, tasks = statistics.median(times), len(replies)
            overhead = (wall * threads - statistics.median(task_s)) / tasks
            sums = replies[0].sums
            window_bytes = sum(a.nbytes for a in (sums.sum, sums.sum_sq, sums.light_sum)
                               if a is not None)
            print(f"--workers {workers}: {wall:.2f} s median ({', '.join(f'{t:.2f}' for t in times)}),"
                  f" {wall / statistics.median(local_t):.3f}x local; {tasks} windows, tasks "
                  f"{statistics.median(task_s):.2f} s, overhead {1e3 * overhead:.1f} ms/task, "
                  f"{window_bytes / 2**20:.1f} MiB/window back, build "
                  f"{', '.join(f'{b:.2f}s' for _, b in builds)}")
    farm_render._add = real_add


if __name__ == "__main__":
    main()
