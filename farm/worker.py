"""What runs in a Dask worker process: one window of a render per task, with the Renderer (BVH,
tables, loaded kernels) built once per render and kept for the tasks that follow."""
from __future__ import annotations

import os
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

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


@dataclass
class PassReply:
    """A task's share of a pass: its pixels' rows of the film and of the pilot's sums, traced
    into (camera pass), or its light chunks' splats in chunk order (light pass); with the NaN/Inf
    samples, event counters, rays and Embree seconds."""
    film: tuple | None
    pilot: tuple | None
    splats: list | None
    bad: int
    counters: np.ndarray
    rays: int
    embree_s: float


def renderer_facts(scene, key: str, settings) -> dict:
    """What the schedulers of tracer/passes.py read of a Renderer, from this process's."""
    renderer = renderer_for(key, scene, settings)
    return {"traces_light": renderer.caustics is not None, "split": renderer.split,
            "light_vertices": renderer.light_vertices,
            "light_vertex_pilot": renderer.light_vertex_pilot,
            "light_paths_per_camera_path": renderer.light_paths_per_camera_path,
            "stages": renderer.stages(), "build_s": renderer.build_s}


def trace_rows(scene, key: str, settings, in_pass: int, first_sample: int, bits: int,
               pixels: np.ndarray, film: tuple, pilot: tuple | None, jobs: list,
               vertices: bool | None) -> PassReply:
    """The task of a camera pass: its jobs' pixels (rows r0 .. r1 of `pixels` each, in order)
    traced into their rows of film and pilot (Renderer.trace_rows), which come back."""
    from ..tracer import wavefront
    renderer = renderer_for(key, scene, settings)
    geometry = renderer.geometry
    rays, embree = geometry.ray_count, geometry.embree_time
    counters, bad = np.zeros(len(wavefront.STATS), np.int64), 0
    for r0, r1 in jobs:
        rows = tuple(a[r0:r1] if a.shape[0] else a for a in film)
        pilot_rows = None if pilot is None else tuple(a[r0:r1] for a in pilot)
        chunk_bad, stats = renderer.trace_rows(in_pass, first_sample, pixels[r0:r1], bits, rows,
                                               vertices, pilot_rows)
        bad += chunk_bad
        counters += stats
    return PassReply(film, pilot, None, bad, counters, geometry.ray_count - rays,
                     geometry.embree_time - embree)


def trace_light(scene, key: str, settings, pass_index: int, jobs: list) -> PassReply:
    """The task of a light pass: its jobs' light paths (start, count), their splats in order."""
    from ..tracer import wavefront
    renderer = renderer_for(key, scene, settings)
    geometry = renderer.geometry
    rays, embree = geometry.ray_count, geometry.embree_time
    splats = [renderer.trace_light_chunk(pass_index, start, n) for start, n in jobs]
    return PassReply(None, None, splats, 0, np.zeros(len(wavefront.STATS), np.int64),
                     geometry.ray_count - rays, geometry.embree_time - embree)


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
