"""What runs in a Dask worker process: one window of a render per task, with the Renderer (BVH,
tables, loaded kernels) built once per render and kept for the tasks that follow."""
from __future__ import annotations

import os
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass

from ..tracer.result import Window, WindowSums

KEEP = 2      # renderers kept per process: a batch's next frame builds while the last finishes
_renderers: OrderedDict = OrderedDict()
_lock = threading.Lock()


@dataclass
class WindowReply:
    """A window's sums and what the summary line adds up: rays, Embree and task seconds, and
    which process traced it (the fault tests)."""
    sums: WindowSums
    rays: int
    embree_s: float
    task_s: float
    pid: int
    build_s: float
    stages: dict
    split: bool


def renderer_for(key: str, scene, settings):
    """This process's Renderer of a render (built on its first task), one thread per task:
    Dask runs as many tasks at once as the worker has threads."""
    from ..tracer.integrator import Renderer
    with _lock:
        renderer = _renderers.get(key)
        if renderer is None:
            renderer = Renderer(scene, settings.replace(threads=1))
            _renderers[key] = renderer
            while len(_renderers) > KEEP:
                _renderers.popitem(last=False)
        _renderers.move_to_end(key)
    return renderer


def trace_window(scene, key: str, window: Window, spp: int, settings) -> WindowReply:
    """The task: the sums of one window of every pixel (Renderer.render_window)."""
    renderer = renderer_for(key, scene, settings)
    geometry = renderer.geometry
    # Counted around the task: exact with one task at a time per process, shared otherwise.
    rays, embree, start = geometry.ray_count, geometry.embree_time, time.perf_counter()
    sums = renderer.render_window(window, spp)
    return WindowReply(sums, geometry.ray_count - rays, geometry.embree_time - embree,
                       time.perf_counter() - start, os.getpid(), renderer.build_s,
                       renderer.stages(), renderer.split)


def describe() -> dict:
    """This worker's Snell (its tracer sources' hash) and whether it can render: run on every
    worker before a render, so that a mismatch is one clear error rather than wrong pixels."""
    from .. import tracer
    from ..tracer import jit
    info = {"pid": os.getpid(), "sources": jit.sources_hash(), "error": "",
            "path": os.path.dirname(os.path.abspath(tracer.__file__))}
    try:
        from ..tracer import integrator  # noqa: F401  (Embree and Numba load here)
    except ImportError as exc:
        info["error"] = f"cannot import the tracer ({exc})"
    return info
