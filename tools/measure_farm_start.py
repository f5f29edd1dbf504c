"""Where the whole `snell render --workers N` command's seconds go: a timeline of its steps.

    .venv/bin/python tools/measure_farm_start.py render SCENE -o OUT.exr --workers 2 [options]

Runs `snell render` with the given arguments in this process and prints, in seconds since the
interpreter started, when each step began and ended: the scene's load (a .blend's export), the
LocalCluster's start (its workers' imports and kernel loads, with the preload), the workers'
checks, the scene scattered, each worker's first window back (its Renderer's build and its
task's own seconds), the first and last windows back, the cluster's close and the EXR's write.
The steps are wrapped where the command calls them; nothing of the render changes.
"""
import os
import sys
import time

EVENTS = []


def process_start() -> float:
    """This process's start on time.time()'s clock (from /proc: the kernel's start time of the
    process, in clock ticks since boot)."""
    with open("/proc/self/stat") as f:
        ticks = int(f.read().rpartition(")")[2].split()[19])
    ago = time.clock_gettime(time.CLOCK_BOOTTIME) - ticks / os.sysconf("SC_CLK_TCK")
    return time.time() - ago


def event(name, at=None):
    EVENTS.append((time.time() if at is None else at, name))


def timed(owner, name, label):
    """Wrap owner.name to record its start and end."""
    real = getattr(owner, name)

    def wrapper(*args, **kwargs):
        event(f"{label} begins")
        try:
            return real(*args, **kwargs)
        finally:
            event(f"{label} ends")
    setattr(owner, name, wrapper)


def wrap_steps():
    """Record the steps of cmd_render and of farm/ as the command calls them."""
    import distributed
    from snell import cli
    from snell.farm import cluster, render
    from snell.tracer import image
    timed(cli, "load_scene", "scene load")
    timed(cluster, "check_workers", "workers' checks")
    timed(image, "write_exr", "EXR write")
    timed(distributed.Client, "scatter", "scatter")
    real_cluster = distributed.LocalCluster

    class LocalCluster(real_cluster):
        def __init__(self, *args, **kwargs):
            event("LocalCluster start begins")
            super().__init__(*args, **kwargs)
            event("LocalCluster start ends (workers up)")

        def close(self, *args, **kwargs):
            event("cluster close begins")
            try:
                return super().close(*args, **kwargs)
            finally:
                event("cluster close ends")
    distributed.LocalCluster = LocalCluster
    real_reply, firsts = render._reply, {}

    def reply(future, name, window):
        answer = real_reply(future, name, window)
        if not firsts:
            event(f"first window back (window {window.index})")
        if answer.pid not in firsts:
            firsts[answer.pid] = answer
            event(f"worker {answer.pid}'s first window back: its build {answer.build_s:.2f} s, "
                  f"its task {answer.task_s:.2f} s")
        return answer
    render._reply = reply
    real_frame = render.render_frame

    def render_frame(*args, **kwargs):
        try:
            return real_frame(*args, **kwargs)
        finally:
            event("last window back")
    render.render_frame = render_frame
    return cli


def main():
    started = process_start()
    cli = wrap_steps()
    event("imports of this tool done")
    status = cli.main(sys.argv[1:])
    event("command done")
    for at, name in sorted(EVENTS):
        print(f"{at - started:8.2f} s  {name}")
    return status


if __name__ == "__main__":     # the workers import this file again (spawn): nothing to run there
    sys.exit(main())
