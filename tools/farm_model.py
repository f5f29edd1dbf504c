"""A model of a fixed-sample render on Dask workers (farm/), from measured costs: where adding
workers stops paying, and how much work a lost worker costs.

    .venv/bin/python tools/farm_model.py [--path-us 1.4] [--task-ms 5.8] [--build-s 0.94]
        [--scene-mib 0.25] [--merge-gbps 5.9] [--net-gbps 1.25] [--sched-ms 1] [--seed 1]

The inputs (defaults: docs/measurements.md, "Rendering on Dask workers"):
  --path-us    a worker thread's microseconds per camera path, the light tracer's share included
               (the tasks' own seconds over their paths, cornell_spheres at 256x256);
  --task-ms    a task's fixed cost on the worker and in the client's loop (the 1-worker overhead);
  --build-s    a worker's Renderer build (BVH, tables) for a new scene;
  --scene-mib  the pickled scene, scattered from the client to every worker;
  --merge-gbps the client's in-order add of a window's sums (RenderResult.add), GB/s of sums;
  --net-gbps   the client's network link, GB/s (1.25: 10 GbE);
  --sched-ms   the Dask scheduler's own time per task (Dask's documentation: about 1 ms);
  --ahead-gib  the client's bound on window sums submitted and not yet added (farm/render.py's
               AHEAD_BYTES), which also bounds how many workers trace at once.

A window of a fixed-sample render is samples_per_window(pixels) samples of every pixel
(tracer/passes.py: up to four passes of 2^17 paths below 2^19 pixels, one pass of one sample
from there up), traced by one worker thread; it sends back
72 bytes a pixel (float64 sums, squares and light sums, RGB). The client receives and adds the
windows one at a time, in window order: it is a serial resource, as is the scheduler. The frame
time on W single-threaded workers is then

    setup + max(ceil(N / B) * (t_window + task), N * (bytes / net + bytes / merge), N * sched)

with B = min(W, the windows the client lets be in flight), setup = the scene sent W times over the client's link, plus one build. Equal windows make
ceil(N / W) rounds exact for the compute term (the last round's idle workers are the tail).
The speed-up is against one such worker thread doing it all (N * t_window). An animation is a
run of such frames whose setups overlap the frame before (snell batch's prefetch).

Workers are worker threads (a `dask worker --nthreads 4` is 4), each tracing one window at a time.

The worker-loss simulation replays a frame's windows on W workers, each window taking t_window,
with workers killed at random times (uniform over the frame): a killed worker's running window
is traced again from its start by the next free worker, and the killed worker comes back
(Dask's nanny) after a restart time (kernel load and build). It prints the work traced twice.
"""
import argparse
import heapq
import math
import random

from snell.farm.render import AHEAD_BYTES, AHEAD_PER_THREAD
from snell.tracer.passes import samples_per_window

BYTES_PER_PIXEL = 72        # sums, sums of squares, light sums: 3 x float64 RGB


def in_flight(pixels: int, workers: int, ahead_bytes: int = AHEAD_BYTES) -> int:
    """The windows farm/render.py lets be submitted and not yet added (the workers' memory
    bound, ahead_bytes per worker thread): at most this many workers trace at once."""
    return max(2, min(AHEAD_PER_THREAD * workers + 1,
                      workers * ahead_bytes // (pixels * BYTES_PER_PIXEL)))


def frame(pixels: int, spp: int, workers: int, a) -> dict:
    """The model's frame time and what bounds it."""
    per_window = samples_per_window(pixels)
    windows = math.ceil(spp / per_window)
    t_window = pixels * per_window * a.path_us * 1e-6
    window_bytes = pixels * BYTES_PER_PIXEL
    busy = min(workers, in_flight(pixels, workers, a.ahead_gib * 2**30))
    compute = math.ceil(windows / busy) * (t_window + a.task_ms * 1e-3)
    client = windows * (window_bytes / (a.net_gbps * 1e9) + window_bytes / (a.merge_gbps * 1e9))
    scheduler = windows * a.sched_ms * 1e-3
    setup = workers * a.scene_mib * 2**20 / (a.net_gbps * 1e9) + a.build_s
    bound = max(("workers" if busy == workers else "memory bound", compute),
                ("client", client), ("scheduler", scheduler), key=lambda kv: kv[1])
    total = setup + bound[1]
    one = windows * t_window
    return {"windows": windows, "per_window": per_window, "t_window": t_window,
            "window_mb": window_bytes / 1e6, "compute": compute, "client": client,
            "scheduler": scheduler, "setup": setup, "total": total, "bound": bound[0],
            "speedup": one / total, "one": one, "busy": busy}


def saturation(pixels: int, spp: int, a) -> int:
    """The fewest workers beyond which the client or the scheduler bounds the frame."""
    for workers in range(1, 100000):
        if frame(pixels, spp, workers, a)["bound"] != "workers":
            return workers
    return 100000


def lost_work(windows: int, t_window: float, workers: int, kills: int, restart: float,
              rng: random.Random) -> tuple[float, float]:
    """(thread-seconds traced twice, makespan) of a frame of equal windows on `workers`, with
    `kills` workers killed at times uniform over the frame's failure-free makespan. The client
    fetches windows in window order as soon as each is done (fetch time left out), so a killed
    worker loses its running window and the windows it finished that are not fetched yet (done
    while an earlier window still ran), all traced again, first in line."""
    clean = math.ceil(windows / workers) * t_window
    kills_left = sorted(rng.uniform(0, clean) for _ in range(kills))
    free = [(0.0, w) for w in range(workers)]        # (time the worker is free, worker)
    heapq.heapify(free)
    queue = list(range(windows))                     # windows to trace, in order
    running = {}                                     # worker -> (start, finish, window)
    held = {w: [] for w in range(workers)}           # finished, not fetched: worker -> windows
    done, fetched = set(), 0
    redone, end = 0.0, 0.0
    while fetched < windows:
        next_kill = kills_left[0] if kills_left else math.inf
        next_finish = min((f for _, f, _ in running.values()), default=math.inf)
        next_free = free[0][0] if free and queue else math.inf
        now = min(next_kill, next_finish, next_free)
        if now == next_kill:
            kills_left.pop(0)
            victim = rng.choice([w for w in range(workers) if running.get(w) or held[w]]
                                or list(range(workers)))
            lost = []
            if victim in running:
                start, _, window = running.pop(victim)
                redone += now - start
                lost.append(window)
            for window in held[victim]:
                redone += t_window
                done.discard(window)
                lost.append(window)
            held[victim] = []
            queue[:0] = sorted(lost)
            free = [(t, w) for t, w in free if w != victim]
            heapq.heapify(free)
            heapq.heappush(free, (now + restart, victim))
        elif now == next_finish:
            worker = next(w for w, (_, f, _) in running.items() if f == now)
            _, _, window = running.pop(worker)
            done.add(window)
            held[worker].append(window)
            heapq.heappush(free, (now, worker))
            while fetched in done:               # the client takes the next in order
                for w in held:
                    if fetched in held[w]:
                        held[w].remove(fetched)
                fetched += 1
            end = now
        else:
            at, worker = heapq.heappop(free)
            running[worker] = (at, at + t_window, queue.pop(0))
    return redone, end


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--path-us", type=float, default=1.4)
    ap.add_argument("--task-ms", type=float, default=5.8)
    ap.add_argument("--build-s", type=float, default=0.94)
    ap.add_argument("--scene-mib", type=float, default=0.25)
    ap.add_argument("--merge-gbps", type=float, default=5.9)
    ap.add_argument("--net-gbps", type=float, default=1.25)
    ap.add_argument("--sched-ms", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--ahead-gib", type=float, default=AHEAD_BYTES / 2**30,
                    help="the client's bound on window sums in flight (farm/render.py)")
    a = ap.parse_args()
    uhd, hd = 3840 * 2160, 1920 * 1080
    print("3840x2160 at 4096 spp:")
    for workers in (1, 4, 16, 64):
        f = frame(uhd, 4096, workers, a)
        print(f"  {workers:3d} workers ({f['busy']} busy): {f['total'] / 60:7.1f} min, speed-up "
              f"{f['speedup']:5.1f} (bound: {f['bound']}; workers {f['compute'] / 60:.1f} min, "
              f"client {f['client'] / 60:.1f} min, scheduler {f['scheduler']:.0f} s)")
    f = frame(uhd, 4096, 1, a)
    print(f"  {f['windows']} windows of {f['per_window']} sample ({f['t_window']:.1f} s, "
          f"{f['window_mb']:.0f} MB back each); saturates at {saturation(uhd, 4096, a)} workers")
    frames = 250
    print(f"{frames} frames of 1920x1080 at 256 spp (setups overlapped):")
    for workers in (1, 4, 16, 64):
        f = frame(hd, 256, workers, a)
        total = frames * (f["total"] - f["setup"]) + f["setup"]
        print(f"  {workers:3d} workers ({f['busy']} busy): {total / 3600:6.2f} h, speed-up "
              f"{frames * f['one'] / total:5.1f} (bound: {f['bound']})")
    print(f"  saturates at {saturation(hd, 256, a)} workers")
    rng = random.Random(a.seed)
    f = frame(uhd, 4096, 64, a)
    restart = 10.0 + a.build_s
    print(f"worker loss at 64 workers, 3840x2160 at 4096 spp ({f['windows']} windows of "
          f"{f['t_window']:.1f} s; a killed worker back after {restart:.0f} s):")
    for kills in (1, 4, 16):
        runs = [lost_work(f["windows"], f["t_window"], 64, kills, restart, rng)
                for _ in range(200)]
        redone = sorted(r for r, _ in runs)
        spans = sorted(s for _, s in runs)
        clean = math.ceil(f["windows"] / 64) * f["t_window"]
        print(f"  {kills:2d} killed: work traced twice median {redone[100]:.1f} s "
              f"(max {redone[-1]:.1f} s, {100 * redone[100] / f['one']:.3f}% of the frame's "
              f"{f['one'] / 3600:.1f} thread-hours); the workers' makespan {clean / 60:.1f} -> "
              f"{spans[100] / 60:.1f} min median")


if __name__ == "__main__":
    main()
