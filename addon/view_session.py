"""The viewport's render session: one worker thread rendering generations of plain scenes.

No bpy here, and the worker never sees Blender or the render engine: the main thread exports
(view_export.py) and hands the session a tracer Scene; the worker renders it and leaves each
displayable state in a single-slot mailbox as a Frame (generation, image, samples) for
view_draw. Every edit is a new generation: `submit` replaces the waiting job and sets the
running one's cancel event, which the integrator checks before each chunk of paths (8k), so
the current render ends within a chunk rather than a pass (a 1-sample pass of a 960x540
region is half a million paths); the progress callback's False (the integrator's cancel
between passes) backs it up. Then the new generation starts. A generation renders 1/8, 1/4
and 1/2 of the resolution at 1 sample per pixel, then the full resolution to its sample budget
or time limit.

Only the worker builds and uses Renderers, so no Embree scene or kernel buffer is shared between
threads beyond what a render's own pool does. It keeps the last generation's Geometry (the BVH)
and reuses it when the next job's geometry version is the same (materials, lamps, world or
camera changed).
"""
from __future__ import annotations

import sys
import threading
import time
import traceback
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..tracer.scene import SceneError, validate
from ..tracer.settings import LIGHT_PATHS_PER_CAMERA_PATH
from . import kernel_warmup
from .view_camera import scaled

COARSE = (8, 4, 2)          # the first passes: 1 sample per pixel at 1/8, 1/4, 1/2 resolution
UNLIMITED_SAMPLES = 1 << 16  # "0 = until stopped": a budget no one waits for


@dataclass
class Frame:
    """One displayable state of a generation (image None: an error or status only)."""
    generation: int
    image: np.ndarray | None      # (h, w, 3) float32 linear, row 0 at the top
    samples: int                  # samples per pixel in the image (coarse passes: 1)
    divisor: int = 1              # the image is 1/divisor of the view's resolution
    final: bool = False           # the generation is done (budget, time limit or error)
    error: str | None = None
    elapsed: float = 0.0          # seconds from submit to this frame
    stats: dict = field(default_factory=dict)
    alpha: np.ndarray | None = None   # (h, w) float32 (Film > Transparent, a Holdout); None: 1


class Mailbox:
    """A single slot: the worker puts the newest Frame, view_draw takes it once."""

    def __init__(self):
        self._lock = threading.Lock()
        self._frame = None
        self._taken = True

    def put(self, frame: Frame):
        """Leave a frame, replacing any not yet taken."""
        with self._lock:
            self._frame, self._taken = frame, False

    def take(self) -> Frame | None:
        """The newest frame if it was not taken yet, else None."""
        with self._lock:
            if self._taken:
                return None
            self._taken = True
            return self._frame

    def peek(self) -> Frame | None:
        """The newest frame, taken or not."""
        with self._lock:
            return self._frame


class ViewDenoise(NamedTuple):
    """How the viewport denoises (Cycles' Sampling > Viewport > Denoise): the settings' values
    of denoising_input_passes, denoising_prefilter and denoising_quality, the first sample count
    it denoises at, and where Blender keeps Open Image Denoise (final.oidn_dirs)."""
    input_passes: str
    prefilter: str
    quality: str
    start_sample: int
    oidn_dirs: tuple = ()


@dataclass
class _Job:
    generation: int
    scene: object
    geometry_version: int
    spp: int
    time_limit: float
    submitted: float
    cancel: threading.Event = field(default_factory=threading.Event)
    denoise: ViewDenoise | None = None


class ViewSession:
    """The worker thread and its mailbox; see the module docstring."""

    def __init__(self, threads: int = 2, coarse=COARSE):
        self.threads = max(1, int(threads))
        self.coarse = tuple(coarse)
        self.mailbox = Mailbox()
        self.status = ""                  # what the worker is doing, for the stats line
        self.generation = 0               # the last one submitted
        self.done_generation = 0          # the last one the worker finished
        self._cond = threading.Condition()
        self._job = None
        self._running = None              # the job the worker renders
        self._stopping = False
        self._geometry = None
        self._geometry_version = None
        self._thread = threading.Thread(target=self._run, name="snell-viewport", daemon=True)
        self._thread.start()

    # -- main thread --------------------------------------------------------------------------

    def submit(self, scene, geometry_version: int, spp: int, time_limit: float = 0.0,
               denoise: ViewDenoise | None = None) -> int:
        """Render a new generation (replacing any job not started); returns its number.
        spp 0 renders until stopped; time_limit 0 has none; denoise: how its images are
        denoised (None: they are not)."""
        with self._cond:
            if self._stopping:
                raise RuntimeError("the viewport session is stopped")
            self.generation += 1
            self._job = _Job(self.generation, scene, geometry_version,
                             int(spp) if spp > 0 else UNLIMITED_SAMPLES, float(time_limit),
                             time.perf_counter(), denoise=denoise)
            if self._running is not None:
                self._running.cancel.set()     # ends its render within a chunk of paths
            self._cond.notify()
            return self.generation

    @property
    def refining(self) -> bool:
        """Whether the worker has work in hand (the engine keeps tagging redraws)."""
        return self._thread.is_alive() and self.done_generation < self.generation

    @property
    def alive(self) -> bool:
        """Whether the worker thread runs."""
        return self._thread.is_alive()

    def stop(self, timeout: float | None = 30.0) -> bool:
        """Stop the worker after its current pass and join it; True if it ended."""
        with self._cond:
            self._stopping = True
            self._job = None
            if self._running is not None:
                self._running.cancel.set()
            self._cond.notify()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout)
        self._geometry = None
        return not self._thread.is_alive()

    def wait(self, predicate, timeout: float = 60.0) -> Frame | None:
        """Wait (tests, tools) for a mailbox frame that satisfies predicate; None on timeout."""
        end = time.perf_counter() + timeout
        while time.perf_counter() < end:
            frame = self.mailbox.peek()
            if frame is not None and predicate(frame):
                return frame
            time.sleep(0.002)
        return None

    # -- worker thread ------------------------------------------------------------------------

    def _superseded(self, generation) -> bool:
        return self._stopping or (self._job is not None and self._job.generation != generation)

    def _run(self):
        while True:
            with self._cond:
                while self._job is None and not self._stopping:
                    self._cond.wait()
                if self._stopping:
                    return
                job, self._job = self._job, None
                self._running = job
            try:
                self._render(job)
            except SceneError as exc:
                self._fail(job, f"cannot render this scene: {exc}")
            except Exception as exc:  # a bug: the traceback to the console, a message on screen
                traceback.print_exc()
                self._fail(job, f"render failed ({type(exc).__name__}: {exc}); details in the "
                                f"console")
            finally:
                with self._cond:
                    self._running = None
                self.done_generation = max(self.done_generation, job.generation)
                self.status = ""

    def _fail(self, job, message):
        self.mailbox.put(Frame(job.generation, None, 0, final=True, error=message,
                               elapsed=time.perf_counter() - job.submitted))

    def _waiting(self, status):
        """kernel_warmup.wait's poll: show its status; stop waiting once the session ends."""
        self.status = status.removeprefix("Snell: ")
        return not self._stopping

    def _render(self, job):
        from ..tracer import integrator

        validate(job.scene)
        if kernel_warmup.running() and not kernel_warmup.wait(self._waiting) and self._stopping:
            return
        if not integrator.kernels_compiled():
            self.status = "compiling kernels (first run only)"
            print(f"Snell: {self.status}", file=sys.stderr, flush=True)
            integrator.warm_up()
        generation = job.generation
        reuse = job.geometry_version == self._geometry_version and self._geometry is not None
        self.status = "building the BVH" if not reuse else "updating"
        t0 = time.perf_counter()
        # Every pixel to the budget: the viewport refines the whole image, never adaptively.
        # The final render's time limit is not the viewport's (viewport_time_limit, per session).
        # Denoising, when on, is the viewport's own (each displayed image, from its start
        # sample on), with the passes it asks for: never the final render's.
        # The light tracer's share is fixed: the first image must not wait for its pilot.
        guided = job.denoise is not None and job.denoise.input_passes != "color"
        settings = job.scene.settings(spp=job.spp, noise_threshold=0.0, time_limit=0.0,
                                      threads=self.threads, denoise=False,
                                      denoising_passes=guided,
                                      light_paths_per_camera_path=LIGHT_PATHS_PER_CAMERA_PATH)
        renderer = integrator.Renderer(job.scene, settings,
                                       geometry=self._geometry if reuse else None)
        self._geometry, self._geometry_version = renderer.geometry, job.geometry_version
        stats = {"bvh_reused": reuse, "build_s": time.perf_counter() - t0}
        if self._superseded(generation):
            return
        camera = job.scene.camera
        keep_going = lambda *_: not self._superseded(generation)  # noqa: E731
        self.status = "rendering"
        for divisor in self.coarse:
            coarse = renderer.with_camera(scaled(camera, divisor)).with_sampling(spp=1)
            result = coarse.render(progress=keep_going, stop=job.cancel)
            if self._superseded(generation):
                return
            self.mailbox.put(Frame(generation, result.mean(), 1, divisor,
                                   elapsed=time.perf_counter() - job.submitted, stats=stats,
                                   alpha=_alpha(result)))
        start = time.perf_counter()

        def progress(result, done, total):
            over = job.time_limit > 0 and time.perf_counter() - start >= job.time_limit
            finished = over or result.spp >= job.spp
            image, denoised = result.mean(), {}
            if job.denoise is not None and result.spp >= job.denoise.start_sample:
                image, denoised = _denoised(result, settings, job.denoise)
            self.mailbox.put(Frame(generation, image, result.spp, 1, final=finished,
                                   elapsed=time.perf_counter() - job.submitted,
                                   stats={**stats, "samples_per_second":
                                          result.spp / max(result.time_s, 1e-9),
                                          "nan_count": result.nan_count, **denoised},
                                   alpha=_alpha(result)))
            return not (over or self._superseded(generation))

        # A frame after every pass, not every window of a few (small regions' windows).
        renderer.render(progress=progress, stop=job.cancel, every_pass=True)


def _alpha(result):
    """A render's alpha for the viewport, or None where it made none (opaque)."""
    return result.alpha() if result.has_alpha else None


def _denoised(result, settings, how: ViewDenoise):
    """(the image denoised as `how` says, frame stats: "denoised", and "denoise_warning" when
    OIDN could not run or lacked its passes)."""
    from ..tracer.denoise import denoise_result
    outcome = denoise_result(result, settings.replace(denoising_input_passes=how.input_passes,
                                                      denoising_prefilter=how.prefilter,
                                                      denoising_quality=how.quality),
                             how.oidn_dirs)
    stats = {"denoised": outcome.denoised}
    if outcome.warning:
        stats["denoise_warning"] = outcome.warning
    return outcome.image, stats
