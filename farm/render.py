"""A frame on a Dask cluster. Fixed samples: its windows (Renderer.windows, fixed by the image
size and spp, not by the workers) traced as tasks, a few ahead, and fetched and added in window
order, which makes the local render's float sums bit for bit (RenderResult.add). Adaptive
sampling and batches: their passes, scheduled here and traced on the workers (remote.py)."""
from __future__ import annotations

import contextlib
import sys
import threading
import time
from dataclasses import dataclass

import numpy as np

from ..errors import CliError
from ..tracer import adaptive, light_groups, light_passes, passes, wavefront
from ..tracer.camera import Camera
from ..tracer.result import RenderResult
from ..tracer.shader.program import has_holdout
from . import cluster, keys, remote, worker

AHEAD_PER_THREAD = 2   # windows in flight per worker thread: workers never wait for the client
# ...but no more than about this many bytes of window sums per worker thread (a 3840x2160
# window is 600 MB). The client fetches the windows in window order, one at a time, so a window
# that finished early waits on its worker: the client holds one window and the image whatever
# the workers, and the workers the windows in flight.
AHEAD_BYTES = 2 << 30


def check_settings(settings, where: str, fix: str = "add --time-limit 0") -> None:
    """CliError unless a cluster can render the settings' image; `fix` says what to change."""
    if getattr(settings, "time_limit", 0):
        # The local render's samples would depend on its clock: no image to be equal to.
        raise CliError(f"{where}: a time limit is not distributed (its samples would depend on "
                       f"the clock): {fix}")


@contextlib.contextmanager
def session(address: str | None, workers: int | None, quiet: bool = False,
            origin: str | None = None):
    """Render with the scheduler at `address`, or a LocalCluster of `workers` processes started
    and stopped here: yields a Session (render(scene, settings, name, frame=0, progress=None,
    stop=None) -> RenderResult with .workers, and its prefetch); says where on stderr unless
    quiet. origin: what asked for the address, in errors (cluster.connect)."""
    with opening(address, workers, quiet, origin) as started:
        yield started.wait()


@contextlib.contextmanager
def opening(address: str | None, workers: int | None, quiet: bool = False,
            origin: str | None = None):
    """session's, begun now in a thread and yielded at once as an Opening: its wait() returns
    the Session, or raises what connecting raised. The command loads or exports its scene
    meanwhile, while the LocalCluster starts and its workers import the tracer and load the
    kernels. On exit (a render done, or a scene that failed to load) the opening is waited for
    and whatever it opened closed."""
    started = Opening(address, workers, quiet, origin)
    try:
        yield started
    finally:
        started.close()


class Opening:
    """A cluster session being opened in a thread (see opening): wait() for its Session; called
    or prefetch()ed, it waits and renders as the Session (what `snell batch` hands the engine
    before the cluster is up)."""

    def __init__(self, address: str | None, workers: int | None, quiet: bool,
                 origin: str | None):
        self._stack = contextlib.ExitStack()
        self._session = self._error = None
        self._said = quiet
        self._thread = threading.Thread(target=self._open, args=(address, workers, origin),
                                        name="snell: opening the Dask session", daemon=True)
        self._thread.start()

    def _open(self, address, workers, origin) -> None:
        try:
            client = self._stack.enter_context(cluster.connect(address, workers, origin=origin))
            threads = cluster.check_workers(client)
            frames = Session(client, threads, len(client.nthreads()))
            self._stack.callback(frames.drop)
            self._session = frames
        except BaseException as exc:  # noqa: BLE001  (raised again by wait, in the caller)
            self._error = exc

    def wait(self) -> "Session":
        """The Session once open (saying where on stderr the first time, unless quiet); what
        opening it raised (a CliError: no Dask, an unreachable scheduler, a worker that cannot
        render) otherwise."""
        self._thread.join()
        if self._error is not None:
            raise self._error
        frames = self._session
        if not self._said:
            self._said = True
            board = cluster.dashboard(frames.client)
            print(f"snell: rendering on {frames.processes} Dask worker"
                  f"{'s' if frames.processes != 1 else ''} ({frames.threads} threads)"
                  f"{', dashboard ' + board if board else ''}", file=sys.stderr, flush=True)
        return frames

    def __call__(self, *args, **kwargs) -> RenderResult:
        return self.wait()(*args, **kwargs)

    def prefetch(self, *args) -> None:
        """Session.prefetch, once open."""
        self.wait().prefetch(*args)

    def close(self) -> None:
        """Wait for the opening, then close what it opened (the session's prefetched frames, the
        client, the LocalCluster)."""
        self._thread.join()
        self._stack.close()


class Session:
    """A cluster's frames, rendered one after the other (`snell batch`): calling it renders a
    frame; prefetch(scene, settings, name, frame) first starts a frame to come, whose tasks
    Dask runs only where the frames before it have none ready (a lower priority), so that the
    workers trace it during the last frame's tail instead of waiting for the next export."""

    def __init__(self, client, threads: int, processes: int):
        self.client, self.threads, self.processes = client, threads, processes
        self.order = 0              # frames begun: a frame's tasks have priority -order
        self.started: dict = {}     # frame -> Started (prefetched, not rendered yet)
        self.prefetched = 0         # frames that found their windows started (measurements)

    def __call__(self, scene, settings, name: str, frame: int = 0, progress=None,
                 stop=None) -> RenderResult:
        started = self.started.pop(frame, None)
        if started is not None and started.key != keys.render_key(scene, settings):
            started.cancel(self.client)      # another scene than prefetched: start afresh
            started = None
        if started is None:
            self.order += 1
            priority = -self.order
        else:
            self.prefetched += 1
            priority = started.priority
        result = render_frame(self.client, scene, settings, name, frame, progress, self.threads,
                              started, priority, stop)
        result.workers = self.processes
        return result

    def prefetch(self, scene, settings, name: str, frame: int) -> None:
        """Start a frame to come (fixed samples: its first windows; adaptive sampling and
        batches, whose passes the client schedules: its renderer on every worker)."""
        if frame in self.started or getattr(settings, "time_limit", 0):
            return
        self.order += 1
        threshold, _ = passes.adaptive_settings(settings)
        if threshold > 0.0 or settings.batches:
            self.started[frame] = _build_renderers(self.client, scene, settings, -self.order)
        else:
            self.started[frame] = start_windows(self.client, scene, settings, frame,
                                                self.threads, -self.order)

    def drop(self) -> None:
        """Cancel what was prefetched and not rendered."""
        for started in self.started.values():
            started.cancel(self.client)
        self.started.clear()


@dataclass
class Started:
    """A frame's tasks submitted ahead: its render key, scattered scene, the windows in flight
    (index -> future; none for a frame of passes, whose renderers are being built), how many
    may be, their priority, and other futures to release."""
    key: str
    scene: object
    futures: dict
    ahead: int
    priority: int
    others: list

    def cancel(self, client) -> None:
        client.cancel(list(self.futures.values()) + self.others + [self.scene])


def _build_renderers(client, scene, settings, priority: int) -> Started:
    """Every worker builds a frame's Renderer (BVH, tables) at a low priority: a frame of passes
    cannot start its windows before the client schedules them."""
    key = keys.render_key(scene, settings)
    [scene_future] = client.scatter([scene], broadcast=True, hash=False)
    builds = [client.submit(worker.renderer_facts, scene_future, key, settings, workers=[address],
                            allow_other_workers=False, priority=priority, pure=False)
              for address in client.nthreads()]
    return Started(key, scene_future, {}, 0, priority, builds)


def render_frame(client, scene, settings, name: str, frame: int = 0, progress=None,
                 threads: int | None = None, started: Started | None = None,
                 priority: int = 0, stop=None) -> RenderResult:
    """Render a scene's frame on the client's workers; `name` (the scene file) names it in
    errors. progress(result, passes done, passes) as Renderer.render's. started: the frame's
    tasks already submitted (Session.prefetch); priority: Dask's, of its tasks. stop (anything
    with is_set(): Esc in Blender): once set, the render ends cancelled with the windows or
    passes added so far, without waiting for the task under way; its tasks are cancelled."""
    check_settings(settings, name)
    threshold, _ = passes.adaptive_settings(settings)
    if threshold > 0.0 or settings.batches:
        try:
            return remote.render_passes(client, scene, settings, name, frame, progress, threads,
                                        stop)
        finally:
            if started is not None:
                started.cancel(client)
    return _render_windows(client, scene, settings, name, frame, progress, threads, started,
                           priority, stop)


def start_windows(client, scene, settings, frame: int, threads: int | None,
                  priority: int = 0) -> Started:
    """Scatter a fixed-sample frame's scene and submit its first windows (as many as may be in
    flight at once: the client's memory bound)."""
    key = keys.render_key(scene, settings)
    camera = Camera(scene.camera)
    w, h, spp = camera.width, camera.height, settings.spp
    windows = passes.fixed_windows(w * h, spp)
    threads = threads or sum(client.nthreads().values())
    # Sent once to every worker (a worker that joins later copies it from another), not per task.
    [scene_future] = client.scatter([scene], broadcast=True, hash=False)
    window_bytes = w * h * 3 * 8 * 3          # sums, sums of squares, light sums: float64 RGB
    # With the alpha, the denoising, the light passes or the light groups a window also sends
    # each sample's (WindowExtra), and the groups' splats (WindowSums.group_light).
    groups = 3 * len(light_groups.wanted(scene, settings))
    window_bytes += w * h * windows.step * 8 * (
        (1 if _has_alpha(settings, scene) else 0) + (6 if settings.wants_features else 0)
        + (light_passes.COLUMNS if settings.light_passes else 0) + groups) + w * h * 8 * groups
    ahead = max(2, min(AHEAD_PER_THREAD * threads + 1, threads * AHEAD_BYTES // window_bytes))
    started = Started(key, scene_future, {}, ahead, priority, [])
    for i in range(min(ahead, len(windows))):
        _submit(client, started, settings, frame, windows[i])
    return started


def _submit(client, started: Started, settings, frame: int, window) -> None:
    """Submit one window's task."""
    started.futures[window.index] = client.submit(
        worker.trace_window, started.scene, started.key, window, settings.spp, settings,
        key=keys.window_key(started.key, frame, window.index, settings.seed), retries=2,
        priority=started.priority)


def _render_windows(client, scene, settings, name: str, frame: int, progress,
                    threads: int | None, started: Started | None = None,
                    priority: int = 0, stop=None) -> RenderResult:
    """A fixed-sample frame's windows traced as tasks and added in window order."""
    camera = Camera(scene.camera)
    w, h, spp = camera.width, camera.height, settings.spp
    windows = passes.fixed_windows(w * h, spp)
    threads = threads or sum(client.nthreads().values())
    started = started or start_windows(client, scene, settings, frame, threads, priority)
    result = RenderResult(w, h, np.zeros((h, w, 3)), np.zeros((h, w, 3)), threads=threads,
                          spp_budget=spp, exposure=settings.film_exposure)
    names = light_groups.wanted(scene, settings)
    if names:               # the windows bring the groups' samples and splats
        result.start_light_groups(names)
    futures, ahead = started.futures, started.ahead
    start = time.perf_counter()
    try:
        for merged in range(len(windows)):
            # In window order (float sums depend on their order); the windows after it trace
            # meanwhile, and those that finish first wait on their workers, not here.
            future = futures.pop(merged)
            if not cluster.finished(future, stop):
                result.cancelled = True          # the windows in flight are cancelled below
                futures[merged] = future
                break
            reply = _reply(future, name, windows[merged])
            future.release()
            if reply.extra is not None and merged == 0:
                _start_extra(result, reply.extra, camera)
            _add(result, reply)
            result.time_s = time.perf_counter() - start
            if merged + ahead < len(windows):
                _submit(client, started, settings, frame, windows[merged + ahead])
            if progress is not None and progress(result, merged + 1, len(windows)) is False:
                result.cancelled = merged + 1 < len(windows)
                return result
    finally:
        started.cancel(client)
    result.time_s = time.perf_counter() - start
    return result


def _reply(future, name: str, window) -> worker.WindowReply:
    """A finished task's reply, or a CliError naming the scene and the failure."""
    try:
        return future.result()
    except Exception as exc:  # noqa: BLE001  (whatever the worker raised, or KilledWorker)
        raise cluster.failure(name, f"window {window.index} (samples {window.first}-"
                                    f"{window.end})", exc) from None


def _add(result: RenderResult, reply: worker.WindowReply) -> None:
    """Add a window to the result, with the counters of the summary line."""
    if not result.stages:
        result.stages, result.build_s = reply.stages, reply.build_s
        result.light_in_image = reply.split
    result.add(reply.sums)
    if reply.extra is not None:
        add_extra(result, reply.extra, reply.sums.window)
    result.rays += reply.rays
    result.embree_time_s += reply.embree_s


def _has_alpha(settings, scene) -> bool:
    """Whether a render may make an alpha (Film > Transparent, or a material with a Holdout):
    the client's memory bound counts its samples."""
    return bool(settings.film_transparent or has_holdout(scene.materials))


def _start_extra(result: RenderResult, extra: worker.WindowExtra, camera: Camera) -> None:
    """Keep the alpha's, the denoising and the light passes' sums where the windows bring
    samples of them."""
    if extra.albedo is not None:
        result.start_features(camera.rotation)
    if extra.transparent is not None:
        result.start_alpha(extra.film_transparent)
    if extra.light is not None:
        result.start_light_passes()


def add_extra(result: RenderResult, extra: worker.WindowExtra, window) -> None:
    """Add a window's alpha, denoising, light-pass and light-group samples to the result's sums
    one sample at a time, with the tracer's own additions (wavefront.film_alpha, film_features,
    light_passes.film_light_passes, which adds rows of any width): the local render's sums bit
    for bit, as each of its pixels gets its samples in sample order. A sample's light passes
    and groups go to the half of the sample indices of the first sample of the local render's
    pass it is in (a window is whole passes of samples_per_pass), where that pass adds them."""
    rows = result.extra_rows()
    npix = result.width * result.height
    step = passes.samples_per_pass(npix)
    for k in range(extra.samples):
        half = adaptive.half_of(window.first + k - k % step)
        light = None if extra.light is None else rows.light[half]
        groups = None if extra.groups is None else rows.groups[half]
        if extra.transparent is not None:
            wavefront.film_alpha(extra.transparent[k], npix, 0, 1, passes.ALL_PIXELS,
                                 rows.transparent, rows.transparent_sq)
        if extra.albedo is not None:
            wavefront.film_features(extra.albedo[k], extra.normal[k], npix, 0, 1,
                                    passes.ALL_PIXELS, rows.albedo, rows.normal)
        if light is not None:
            light_passes.film_light_passes(extra.light[k], npix, 0, 1, passes.ALL_PIXELS, light)
        if groups is not None:
            light_passes.film_light_passes(extra.groups[k], npix, 0, 1, passes.ALL_PIXELS,
                                           groups)
    if extra.transparent is not None:
        result.alpha_nans[0] += extra.alpha_nans
    if extra.albedo is not None:
        result.feature_nans[0] += extra.feature_nans
    if extra.light is not None:
        result.light_pass_nans[0] += extra.light_nans
    if extra.groups is not None:
        result.light_group_nans[0] += extra.group_nans
