"""What runs in a Dask worker process: one window of a render per task, with the Renderer (BVH,
tables, loaded kernels) built once per render and kept for the tasks that follow."""
from __future__ import annotations

import atexit
import os
import sys
import threading
import time
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..tracer import adaptive, light_passes, passes, wavefront
from ..tracer.result import ExtraRows, Window, WindowSums

KEEP = 2      # renderers kept per process: a batch's next frame builds while the last finishes
_renderers: OrderedDict = OrderedDict()
_lock = threading.Lock()


@dataclass
class WindowExtra:
    """A window's samples of the film's alpha, of the Denoising Albedo and Normal passes, of
    the light passes and of the light groups' camera paths, one row per sample (samples,
    pixels[, 3, light_passes.COLUMNS or 3 x groups]), NaN or Inf samples as 0 and counted: the
    local render adds them to its running sums one sample at a time (RenderResult.extra_rows),
    which sums of the window could not reproduce, so the client adds these in the same order
    (add_extra)."""
    transparent: np.ndarray | None
    albedo: np.ndarray | None
    normal: np.ndarray | None
    alpha_nans: int
    feature_nans: int
    film_transparent: bool
    light: np.ndarray | None = None
    light_nans: int = 0
    groups: np.ndarray | None = None
    group_nans: int = 0

    @property
    def samples(self) -> int:
        """The window's samples (rows)."""
        return next(rows.shape[0] for rows in (self.transparent, self.albedo, self.light,
                                                self.groups) if rows is not None)


@dataclass
class WindowReply:
    """A window's sums and what the summary line adds up: rays, Embree and task seconds, and
    which process traced it (the fault tests); its alpha and denoising samples if the render
    makes them."""
    sums: WindowSums
    rays: int
    embree_s: float
    task_s: float
    pid: int
    build_s: float
    stages: dict
    split: bool
    extra: WindowExtra | None = None


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
    if renderer.alpha or renderer.features or renderer.light_passes or renderer.light_groups:
        sums, extra = window_by_sample(renderer, window, spp)
    else:
        sums, extra = renderer.render_window(window, spp), None
    return WindowReply(sums, geometry.ray_count - rays, geometry.embree_time - embree,
                       time.perf_counter() - start, os.getpid(), renderer.build_s,
                       renderer.stages(), renderer.split, extra)


def window_by_sample(renderer, window: Window, spp: int) -> tuple[WindowSums, WindowExtra]:
    """A window of every pixel traced one sample per pass: its sums, as render_window's (each
    pixel's samples added in sample order from zero), and each sample's alpha, denoising
    features, light passes and light groups, which a one-sample pass's sums from zero are
    exactly (0 + x = x)."""
    npix = renderer.camera.width * renderer.camera.height
    count = window.end - window.first
    film = (np.zeros((npix, 3)), np.zeros((npix, 3)))
    light = np.zeros((npix, 3)) if renderer.caustics is not None else None
    sums = WindowSums(window, *film, light, counters=np.zeros(len(wavefront.STATS), np.int64))
    alpha = np.zeros((count, npix)) if renderer.alpha else None
    albedo = np.zeros((count, npix, 3)) if renderer.features else None
    normal = np.zeros((count, npix, 3)) if renderer.features else None
    # The stages add a sample's light passes and groups to the half of the sample indices it is
    # in (adaptive.half_of); the client puts them where the local render's pass of the whole
    # window put them (add_extra), so here both halves are one sample's, emptied after it.
    light_rows, light_halves = _per_sample(
        count, npix, light_passes.COLUMNS if renderer.light_passes else 0)
    group_rows, group_halves = _per_sample(count, npix, 3 * len(renderer.light_groups))
    squares = np.zeros(npix)          # the alpha's squares: the client squares each sample itself
    alpha_nans, feature_nans, light_nans, group_nans = (np.zeros(1, np.int64) for _ in range(4))
    bits = max(1, (int(spp) - 1).bit_length())
    with ThreadPoolExecutor(max_workers=renderer.threads) as pool:
        for k in range(count):
            extra = ExtraRows(None if albedo is None else albedo[k],
                              None if normal is None else normal[k], feature_nans,
                              None if alpha is None else alpha[k],
                              None if alpha is None else squares, alpha_nans, light_halves,
                              light_nans, group_halves, None, group_nans)
            sums.nan_count += renderer.camera_pass(
                pool, passes.Pass(window.first + k, 1), passes.ALL_PIXELS, bits,
                (*film, passes.NO_ROWS), sums.counters, None, extra=extra)
            for rows, halves in ((light_rows, light_halves), (group_rows, group_halves)):
                if halves is not None:
                    half = halves[adaptive.half_of(window.first + k)]
                    rows[k] = half
                    half[:] = 0.0
        if light is not None:       # as Renderer.trace_window
            renderer.window_light(pool, sums, npix, bool(renderer.light_groups))
    return sums, WindowExtra(alpha, albedo, normal, int(alpha_nans[0]), int(feature_nans[0]),
                             renderer.film_transparent, light_rows, int(light_nans[0]),
                             group_rows, int(group_nans[0]))


def _per_sample(count: int, npix: int, columns: int) -> tuple:
    """(each sample's rows, (count, npix, columns); the two halves' sums the stages add a
    sample to, (2, npix, columns)), or (None, None) without columns."""
    if not columns:
        return None, None
    return np.zeros((count, npix, columns)), np.zeros((2, npix, columns))


@dataclass
class PassReply:
    """A task's share of a pass: its pixels' rows of the film and of the pilot's sums, traced
    into (camera pass), or its light chunks' splats in chunk order (light pass); with the NaN/Inf
    samples, event counters, rays and Embree seconds; the rows of the alpha and denoising sums
    (ExtraRows, with their NaN counts) if the pass makes them."""
    film: tuple | None
    pilot: tuple | None
    splats: list | None
    bad: int
    counters: np.ndarray
    rays: int
    embree_s: float
    extra: ExtraRows | None = None


def renderer_facts(scene, key: str, settings) -> dict:
    """What the schedulers of tracer/passes.py read of a Renderer, from this process's."""
    renderer = renderer_for(key, scene, settings)
    return {"traces_light": renderer.caustics is not None, "split": renderer.split,
            "light_vertices": renderer.light_vertices,
            "light_vertex_pilot": renderer.light_vertex_pilot,
            "light_paths_per_camera_path": renderer.light_paths_per_camera_path,
            "stages": renderer.stages(), "build_s": renderer.build_s,
            "alpha": renderer.alpha, "film_transparent": renderer.film_transparent,
            "features": renderer.features, "light_passes": renderer.light_passes,
            "light_groups": renderer.light_groups}


def trace_rows(scene, key: str, settings, in_pass: int, first_sample: int, bits: int,
               pixels: np.ndarray, film: tuple, pilot: tuple | None, jobs: list,
               vertices: bool | None, extra: ExtraRows | None = None) -> PassReply:
    """The task of a camera pass: its jobs' pixels (rows r0 .. r1 of `pixels` each, in order)
    traced into their rows of film and pilot (Renderer.trace_rows) and of the alpha's,
    denoising and light passes' sums (extra: RenderResult.extra_rows' rows of `pixels`), which
    come back."""
    renderer = renderer_for(key, scene, settings)
    geometry = renderer.geometry
    rays, embree = geometry.ray_count, geometry.embree_time
    counters, bad = np.zeros(len(wavefront.STATS), np.int64), 0
    if extra is not None:
        bad = rows_with_extra(renderer, in_pass, first_sample, bits, pixels, film, pilot, jobs,
                              vertices, extra, counters)
        return PassReply(film, pilot, None, bad, counters, geometry.ray_count - rays,
                         geometry.embree_time - embree, extra)
    for r0, r1 in jobs:
        rows = tuple(a[r0:r1] if a.shape[0] else a for a in film)
        pilot_rows = None if pilot is None else tuple(a[r0:r1] for a in pilot)
        chunk_bad, stats = renderer.trace_rows(in_pass, first_sample, pixels[r0:r1], bits, rows,
                                               vertices, pilot_rows)
        bad += chunk_bad
        counters += stats
    return PassReply(film, pilot, None, bad, counters, geometry.ray_count - rays,
                     geometry.embree_time - embree)


def rows_with_extra(renderer, in_pass: int, first_sample: int, bits: int, pixels: np.ndarray,
                    film: tuple, pilot: tuple | None, jobs: list, vertices: bool | None,
                    extra: ExtraRows, counters: np.ndarray) -> int:
    """trace_rows' jobs with the alpha, denoising, light passes or light groups: Renderer.
    trace_chunk adds those to rows of the whole image (Renderer.trace_rows makes none), so the
    task's rows are put at `pixels` in image-sized copies, traced into there and copied back
    (the same additions in the same order as the local render's). Returns the NaN or Inf
    samples."""
    npix = renderer.camera.width * renderer.camera.height

    def whole(rows):
        if rows is None or rows.shape[0] == 0:
            return rows
        image = np.zeros((npix,) + rows.shape[1:])
        image[pixels] = rows
        return image

    def both_halves(rows):               # (2 halves, rows, columns)
        if rows is None:
            return None
        image = np.zeros((2, npix, rows.shape[2]))
        image[:, pixels] = rows
        return image
    film_image = tuple(whole(a) for a in film)
    pilot_image = None if pilot is None else tuple(whole(a) for a in pilot)
    light_image, groups_image = both_halves(extra.light), both_halves(extra.groups)
    extra_image = extra._replace(albedo=whole(extra.albedo), normal=whole(extra.normal),
                                 transparent=whole(extra.transparent),
                                 transparent_sq=whole(extra.transparent_sq), light=light_image,
                                 groups=groups_image)
    bad = 0
    for r0, r1 in jobs:
        chunk_bad, stats = renderer.trace_chunk(r0 * in_pass, (r1 - r0) * in_pass, in_pass,
                                                first_sample, pixels, bits, *film_image,
                                                vertices, pilot_image, False, extra_image)
        bad += chunk_bad
        counters += stats
    sums = ("albedo", "normal", "transparent", "transparent_sq")
    pairs = (list(zip(film, film_image)) + list(zip(pilot or (), pilot_image or ()))
             + [(getattr(extra, name), getattr(extra_image, name)) for name in sums])
    for rows, image in pairs:
        if rows is not None and rows.shape[0]:
            rows[:] = image[pixels]
    for rows, image in ((extra.light, light_image), (extra.groups, groups_image)):
        if image is not None:
            rows[:] = image[:, pixels]
    return bad


def trace_light(scene, key: str, settings, pass_index: int, jobs: list) -> PassReply:
    """The task of a light pass: its jobs' light paths (start, count), their splats in order."""
    renderer = renderer_for(key, scene, settings)
    geometry = renderer.geometry
    rays, embree = geometry.ray_count, geometry.embree_time
    splats = [renderer.trace_light_chunk(pass_index, start, n) for start, n in jobs]
    return PassReply(None, None, splats, 0, np.zeros(len(wavefront.STATS), np.int64),
                     geometry.ray_count - rays, geometry.embree_time - embree)


def start(dask_worker=None) -> None:
    """A LocalCluster worker's start (cluster.WORKER_START): the tracer imported and every
    kernel loaded now, while the client exports its scene, rather than on the first task; and
    the process's exit made quick."""
    atexit.register(_exit_now)
    try:
        from ..tracer.integrator import kernels_compiled, warm_up
        if kernels_compiled():       # else the client is compiling them: the first task loads
            warm_up()
    except Exception:  # noqa: BLE001  (describe and the first task report it, as without this)
        pass


def _exit_now() -> None:
    """At exit, the other exit handlers run, then the process ends without the interpreter's
    teardown of its modules: with Numba's and Dask's loaded that took 1-1.5 s, which the
    command's close of its LocalCluster waited for, worker by worker."""
    atexit.unregister(_exit_now)
    atexit._run_exitfuncs()      # registered before this one: they run after it otherwise
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


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
