"""Adaptive sampling and batches on a Dask cluster: the coordinator runs tracer/passes.py's
schedulers itself (the stopping rule, the light-vertex pilot, the batches) and has each pass
traced by the workers, through RemoteTracer, which offers the schedulers a Renderer's pass
interface.

A camera pass is cut into the jobs a local render would run (passes.jobs: whole pixels' samples,
at most a chunk of paths); a task takes consecutive jobs with their pixels' sums so far and
sends them back with the pass's samples added, in the order a local render adds them
(Renderer.trace_rows). A pixel belongs to one job of a pass, so the tasks may finish in any
order. A light pass's tasks return their chunks' splats, which are added here in chunk order.
Either way the image is the local render's bit for bit.
"""
from __future__ import annotations

import numpy as np

from ..tracer import passes
from ..tracer.camera import Camera
from ..tracer.result import ExtraRows, RenderResult
from . import cluster, keys, worker

TASKS_PER_THREAD = 2   # tasks per worker thread in a pass: a slow task delays a pass the less


class RemoteTracer:
    """A render's passes traced on the client's workers, with a Renderer's pass interface
    (camera_pass, light_pass, light_count, ray_count, embree_time and the schedulers' flags)."""

    def __init__(self, client, scene, settings, name: str, frame: int = 0,
                 threads: int | None = None):
        # The workers' light passes splat only: photon merging (tracer/photon_merging.py) needs
        # every photon of a pass in one place, so here the path tracer keeps the merged paths.
        if settings.merges_photons:
            settings = settings.replace(photon_merging="off")
        self.client, self.settings, self.name, self.frame = client, settings, name, frame
        self.key = keys.render_key(scene, settings)
        camera = Camera(scene.camera)
        self.npix = camera.width * camera.height
        self.threads = threads or sum(client.nthreads().values())
        # Sent once to every worker (a worker that joins later copies it from another).
        [self.scene] = client.scatter([scene], broadcast=True, hash=False)
        facts = self._wait(client.submit(worker.renderer_facts, self.scene, self.key, settings,
                                         key=f"snell-facts-{self.key[:20]}", retries=2),
                           "building the renderer")
        self.caustics = True if facts["traces_light"] else None   # passes test `is not None`
        self.split = facts["split"]
        self.light_vertices = facts["light_vertices"]
        self.light_vertex_pilot = facts["light_vertex_pilot"]
        self.light_paths_per_camera_path = facts["light_paths_per_camera_path"]
        self.facts = facts
        self.ray_count, self.embree_time = 0, 0.0

    def close(self) -> None:
        """Release the scattered scene."""
        self.client.cancel([self.scene])

    def light_count(self, rows: int, samples: int, share: float = 1.0) -> int:
        """As Renderer.light_count."""
        return passes.light_count(self.light_paths_per_camera_path, rows, samples, share)

    def camera_pass(self, pool, step, pixels, bits, film, counters, stop, vertices=None,
                    pilot=None, merge=False, extra=None) -> int:
        """As Renderer.camera_pass (no merge: the schedulers that use it add in place); the
        rows of the alpha's, denoising, light passes' and light groups' sums (extra) go with
        the pixels and come back likewise."""
        rows = pixels.shape[0] or self.npix
        bad = 0
        for sub in passes.sub_passes(step, rows):
            jobs = passes.jobs(0, rows * sub.samples, sub.samples)
            tasks = []
            for group in _groups(jobs, TASKS_PER_THREAD * self.threads):
                r0 = group[0][0] // sub.samples
                r1 = (group[-1][0] + group[-1][1]) // sub.samples
                index = pixels[r0:r1] if pixels.shape[0] else np.arange(r0, r1, dtype=np.int64)
                block = tuple(a[index] if a.shape[0] else a for a in film)
                block_pilot = None if pilot is None else tuple(a[index] for a in pilot)
                block_extra = None if extra is None else _rows_of(extra, index)
                local = [(start // sub.samples - r0, (start + n) // sub.samples - r0)
                         for start, n in group]
                future = self.client.submit(
                    worker.trace_rows, self.scene, self.key, self.settings, sub.samples,
                    sub.first, bits, index, block, block_pilot, local, vertices, block_extra,
                    key=keys.pass_key(self.key, self.frame, "camera", sub.first, r0,
                                      self.settings.seed), retries=2)
                tasks.append((index, future))
            replies = []
            for index, future in tasks:
                if not cluster.finished(future, stop):
                    # Esc: nothing of the pass is added (the scheduler drops it) and its tasks
                    # are cancelled.
                    self.client.cancel([f for _, f in tasks])
                    return bad
                replies.append((index, self._wait(future, f"samples {sub.first}-"
                                                          f"{sub.first + sub.samples}")))
            for index, reply in replies:
                for whole, part in zip(film, reply.film):
                    if whole.shape[0]:
                        whole[index] = part
                if pilot is not None:
                    for whole, part in zip(pilot, reply.pilot):
                        whole[index] = part
                if extra is not None:
                    _put_rows(extra, index, reply.extra)
                bad += reply.bad
                counters += reply.counters
                self._count(reply)
            if stop is not None and stop.is_set():
                break
        return bad

    def light_pass(self, pool, pass_index, n_light, n_a, film, film_a, counters,
                   groups=None) -> int:
        """As Renderer.light_pass: the splats added here in chunk order, the light groups'
        splats to `groups` if not None."""
        film[:] = 0.0
        if film_a is not None:
            film_a[:] = 0.0
        bad = 0
        for begin, end in passes.light_segments(n_light, n_a):
            jobs = passes.jobs(begin, end, 1)
            tasks = [(group, self.client.submit(
                worker.trace_light, self.scene, self.key, self.settings, pass_index, group,
                key=keys.pass_key(self.key, self.frame, f"light{pass_index}", group[0][0], 0,
                                  self.settings.seed), retries=2))
                for group in _groups(jobs, TASKS_PER_THREAD * self.threads)]
            for group, future in tasks:
                reply = self._wait(future, f"light paths of pass {pass_index}")
                bad += passes.add_splats(group, reply.splats, n_a, film, film_a, counters,
                                         groups)
                self._count(reply)
        return bad

    def _count(self, reply: worker.PassReply) -> None:
        self.ray_count += reply.rays
        self.embree_time += reply.embree_s

    def _wait(self, future, what: str):
        """A task's reply, or a CliError naming the scene and the failure."""
        try:
            return future.result()
        except Exception as exc:  # noqa: BLE001  (whatever the worker raised, or KilledWorker)
            raise cluster.failure(self.name, what, exc) from None
        finally:
            future.release()


EXTRA_SUMS = ("albedo", "normal", "transparent", "transparent_sq")   # ExtraRows' rows


HALVES_SUMS = ("light", "groups")   # ExtraRows' rows of both halves, (2, pixels, columns)
NAN_COUNTS = ("feature_nans", "alpha_nans", "light_nans", "group_nans")


def _rows_of(extra: ExtraRows, index: np.ndarray) -> ExtraRows:
    """The rows of `index` of the render's alpha, denoising, light-pass and light-group sums
    (those of both halves for the last two; not the light tracer's group splats, which a camera
    pass leaves alone), with NaN counts from 0."""
    rows = {name: None if getattr(extra, name) is None else getattr(extra, name)[index]
            for name in EXTRA_SUMS}
    halves = {name: None if getattr(extra, name) is None else getattr(extra, name)[:, index]
              for name in HALVES_SUMS}
    return extra._replace(**rows, **halves, group_light=None,
                          **{name: np.zeros(1, np.int64) for name in NAN_COUNTS})


def _put_rows(extra: ExtraRows, index: np.ndarray, rows: ExtraRows) -> None:
    """Put a task's rows of the alpha, denoising, light-pass and light-group sums back, and add
    its NaN counts."""
    for name in EXTRA_SUMS:
        if getattr(extra, name) is not None:
            getattr(extra, name)[index] = getattr(rows, name)
    for name in HALVES_SUMS:
        if getattr(extra, name) is not None:
            getattr(extra, name)[:, index] = getattr(rows, name)
    for name in NAN_COUNTS:
        if getattr(extra, name) is not None:
            getattr(extra, name)[0] += getattr(rows, name)[0]


def _groups(jobs: list, most: int) -> list[list]:
    """Consecutive jobs in at most `most` groups of near-equal count."""
    count = max(1, min(most, len(jobs)))
    bounds = [i * len(jobs) // count for i in range(count + 1)]
    return [jobs[a:b] for a, b in zip(bounds, bounds[1:]) if b > a]


def render_passes(client, scene, settings, name: str, frame: int = 0, progress=None,
                  threads: int | None = None, stop=None) -> RenderResult:
    """Render a scene's frame with adaptive sampling or batches on the client's workers, the
    schedulers run here; the local render's image bit for bit."""
    tracer = RemoteTracer(client, scene, settings, name, frame, threads)
    try:
        threshold, _ = passes.adaptive_settings(settings)
        camera = Camera(scene.camera)
        w, h = camera.width, camera.height
        result = RenderResult(w, h, np.zeros((h, w, 3)), np.zeros((h, w, 3)),
                              threads=tracer.threads, build_s=tracer.facts["build_s"],
                              light_in_image=tracer.split, stages=tracer.facts["stages"],
                              spp_budget=settings.spp, noise_threshold=threshold,
                              exposure=settings.film_exposure)
        if tracer.facts["features"]:
            result.start_features(camera.rotation)
        if tracer.facts["alpha"]:
            result.start_alpha(tracer.facts["film_transparent"])
        if tracer.facts["light_passes"]:
            result.start_light_passes()
        if tracer.facts["light_groups"]:
            result.start_light_groups(tracer.facts["light_groups"])
        scheduler = passes.scheduler(tracer, result, settings)
        return passes.drive(tracer, scheduler, None, progress, stop, 0.0)
    finally:
        tracer.close()
