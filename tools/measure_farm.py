"""Time a fixed-sample render on this machine's threads and on Dask worker processes (farm/).

    .venv/bin/python tools/measure_farm.py [SCENE.blend|SCENE.snell] [--size 256] [--spp 256]
        [--runs 3] [--threads 2]
    .venv/bin/python tools/measure_farm.py SCENE --size 3840x2160 --spp 2 --memory [--workers 2]

Renders the same image (--noise-threshold 0) locally with --threads threads, then on a
LocalCluster of 1 and of 2 single-threaded worker processes (kernels warm, the cluster started
before the clock), and prints medians over the runs: wall time, its ratio to the local render,
the windows, the sum of the tasks' own seconds, the overhead per task ((wall x threads - task
seconds) / tasks: scheduling, transfer, the client's merge, idle workers), the bytes a window
sends back, the workers' BVH build, and the scene's transfer (its pickled size and the
seconds to scatter it to every worker). Checks that every distributed image is the local one.

--memory renders only on the cluster (--workers processes) and prints the peak resident memory
of the client and of each worker (getrusage's ru_maxrss), before and after the render.
"""
import argparse
import pickle
import resource
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
    ap.add_argument("--size", default="256", help="N (square) or WxH")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--memory", action="store_true")
    ap.add_argument("--workers", type=int, default=2, help="with --memory")
    args = ap.parse_args()
    w, _, h = args.size.partition("x")
    scene = load_scene(args.scene).with_camera(resolution=[int(w), int(h or w)],
                                               resolution_percentage=100)
    settings = scene.settings(spp=args.spp, noise_threshold=0.0, threads=args.threads)
    warm_up()
    if args.memory:
        memory(scene, settings, args)
        return
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
            start = time.perf_counter()
            [scattered] = client.scatter([scene], broadcast=True, hash=False)
            scatter_s = time.perf_counter() - start
            client.cancel([scattered])
            wall, tasks = statistics.median(times), len(replies)
            overhead = (wall * threads - statistics.median(task_s)) / tasks
            sums = replies[0].sums
            window_bytes = sum(a.nbytes for a in (sums.sum, sums.sum_sq, sums.light_sum)
                               if a is not None)
            print(f"--workers {workers}: {wall:.2f} s median ({', '.join(f'{t:.2f}' for t in times)}),"
                  f" {wall / statistics.median(local_t):.3f}x local; {tasks} windows, tasks "
                  f"{statistics.median(task_s):.2f} s, overhead {1e3 * overhead:.1f} ms/task, "
                  f"{window_bytes / 2**20:.1f} MiB/window back, build "
                  f"{', '.join(f'{b:.2f}s' for _, b in builds)}; scene "
                  f"{len(pickle.dumps(scene)) / 2**20:.2f} MiB pickled, scattered to every "
                  f"worker in {1e3 * scatter_s:.0f} ms")
    farm_render._add = real_add


def peak_mib() -> float:
    """This process's peak resident memory, MiB (Linux: ru_maxrss in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def memory(scene, settings, args):
    """Peak resident memory of the client and of each worker around a render on the cluster."""
    client_before = peak_mib()
    with cluster.connect(None, args.workers) as client:
        cluster.check_workers(client)
        workers_before = client.run(peak_mib)
        start = time.perf_counter()
        result = farm_render.render_frame(client, scene, settings, args.scene)
        wall = time.perf_counter() - start
        workers_after = client.run(peak_mib)
    print(f"{result.width}x{result.height}, {result.spp} spp on {args.workers} workers in "
          f"{wall:.1f} s: client peak {client_before:.0f} -> {peak_mib():.0f} MiB; workers "
          + ", ".join(f"{workers_before[a]:.0f} -> {workers_after[a]:.0f} MiB"
                      for a in sorted(workers_after)))


if __name__ == "__main__":
    main()
