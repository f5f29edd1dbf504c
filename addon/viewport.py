"""Snell in the 3D viewport's Rendered mode: what view_update and view_draw do (main thread).

SnellRenderEngine.view_update and view_draw (engine.py) call a Viewport kept on the engine
instance. All Blender data is read here, on the main thread: view_update sorts the depsgraph's
updates (view_updates.py) and re-exports what they touched (view_export.py); view_draw reads
the region's matrices into a camera (view_camera.py), since navigating calls view_draw but not
view_update. Either restarts the render session (view_session.py) with a new generation when
the scene or the camera changed; a resize waits until the region has kept its size for
RESIZE_DELAY. view_draw draws the newest frame, or keeps the last one until the new
generation's first pass arrives, and tags redraws while the worker refines.

Nothing here may raise into Blender: failures become a message drawn in the viewport and
reported once through the engine (Info log).
"""
from __future__ import annotations

import sys
import time
import traceback
from types import SimpleNamespace

import numpy as np

from ..tracer.scene import SceneError, aperture_radius
from . import view_draw
from .view_camera import ViewUnsupported, camera_from_view
from .view_export import LiveExport
from .view_session import ViewDenoise, ViewSession
from .view_updates import classify, full, snapshot

RESIZE_DELAY = 0.25     # seconds a region keeps its size before the render restarts at it
STOP_WAIT = 5.0         # seconds the main thread waits for the worker to end
ATTRIBUTE = "_snell_viewport"

# What view_draw draws with; tests replace it with a stand-in (gpu cannot draw in background).
DRAWING = view_draw.GpuDrawing()


def controller(engine) -> "Viewport":
    """The engine instance's Viewport, made on first use."""
    view = getattr(engine, ATTRIBUTE, None)
    if view is None:
        view = Viewport()
        setattr(engine, ATTRIBUTE, view)
    return view


def release(engine):
    """Stop and join the engine's worker (the viewport closed or the engine changed)."""
    view = getattr(engine, ATTRIBUTE, None)
    if view is not None:
        view.stop()
        setattr(engine, ATTRIBUTE, None)


def settings(bl_scene) -> tuple[int, float, int, object]:
    """(viewport samples, 0 = until stopped; time limit in seconds, 0 = none; threads; how the
    images are denoised, a view_session.ViewDenoise, or None)."""
    from .export import blender_settings, blender_threads
    from .final import oidn_dirs

    found = blender_settings(bl_scene)
    denoise = None
    if found.viewport_denoise:
        denoise = ViewDenoise(
            found.viewport_denoising_input_passes, found.viewport_denoising_prefilter,
            found.viewport_denoising_quality, found.viewport_denoise_start_sample,
            tuple(oidn_dirs()))
    return (found.viewport_spp, found.viewport_time_limit, blender_threads(bl_scene, found),
            denoise)


def region_camera(context, depsgraph) -> dict:
    """The camera of the context's 3D view region (ViewUnsupported if Snell cannot render it)."""
    from .export import convert_camera

    region, rv3d, space = context.region, context.region_data, context.space_data
    if rv3d is None or region is None:
        raise ViewUnsupported("no 3D view region to render")
    dof, lens = None, float(getattr(space, "lens", 50.0))
    if rv3d.view_perspective == "CAMERA":
        bl_scene = depsgraph.scene
        camera = space.camera if getattr(space, "use_local_camera", False) else bl_scene.camera
        if camera is None:
            raise ViewUnsupported("the view looks through a camera, but there is none")
        # convert_camera reads the camera, the render settings and the scene's name.
        seen = SimpleNamespace(camera=camera, render=bl_scene.render, name=bl_scene.name)
        try:
            cam = convert_camera(seen, depsgraph)
        except SceneError as exc:
            raise ViewUnsupported(str(exc)) from None
        lens = cam["lens"]
        dof = dict(cam["dof"], aperture_radius=aperture_radius(cam))
    return camera_from_view(np.array(rv3d.view_matrix), np.array(rv3d.window_matrix),
                            region.width, region.height, lens=lens, dof=dof)


class Viewport:
    """One viewport's export cache, render session and what it shows."""

    def __init__(self, session_factory=ViewSession):
        self.live = LiveExport()
        self.session = None
        self.session_factory = session_factory
        self.content = None         # the latest export (view_export.Content)
        self.camera = None          # the camera of the latest submission
        self.submitted = None       # (content, camera) of the latest submission
        self.export_error = None    # the scene cannot be exported: the message
        self.view_error = None      # the view cannot be rendered: the message
        self.frame = None           # the frame on screen
        self.texture = None
        self.size, self.size_since = None, 0.0
        self.reported = set()
        self.last_plan = None
        self.generations = {}       # generation -> what restarted it (stats, tests)
        self.target_spp = 0         # the viewport samples of the latest submission

    # -- view_update ----------------------------------------------------------------------

    def update(self, engine, depsgraph):
        """view_update: re-export what the depsgraph's updates touched and restart."""
        try:
            first = self.live.content is None
            plan = full() if first else classify(snapshot(depsgraph))
            if self.last_plan is not None and self.export_error:
                plan = plan.merge(full())      # try the whole scene again after a failure
            self.last_plan = plan
            content = self.live.update(depsgraph, plan, source=_source())
            if content is not None:
                self.content, self.export_error = content, None
                for message in content.warnings:
                    self._report(engine, "WARNING", message)
                self._restart(engine, depsgraph.scene, plan.restart())
        except SceneError as exc:
            self.export_error = f"cannot render this scene: {exc}"
            self._report(engine, "ERROR", self.export_error)
        except Exception as exc:  # a bug: never raise into Blender
            traceback.print_exc()
            self.export_error = f"viewport update failed ({type(exc).__name__}: {exc})"
            self._report(engine, "ERROR", self.export_error)

    # -- view_draw ------------------------------------------------------------------------

    def draw(self, engine, context, depsgraph, drawing):
        """view_draw: follow the view, then draw the newest image and the messages."""
        region = context.region
        width, height = int(region.width), int(region.height)
        try:
            self._follow_view(engine, context, depsgraph, (width, height))
            frame = self.session.mailbox.take() if self.session is not None else None
            if frame is not None:
                self._show(engine, frame, drawing)
        except Exception as exc:  # a bug: never raise into Blender
            traceback.print_exc()
            self.view_error = f"viewport drawing failed ({type(exc).__name__}: {exc})"
            self._report(engine, "ERROR", self.view_error)
        try:
            self._draw(engine, depsgraph, drawing, width, height)
        except Exception as exc:  # a bug, or the GPU refusing: never raise into Blender
            traceback.print_exc()
            self._report(engine, "ERROR", f"viewport drawing failed ({type(exc).__name__}: {exc})")
        if self.session is not None and self.session.refining or self._resize_pending():
            engine.tag_redraw()

    def _draw(self, engine, depsgraph, drawing, width, height):
        message = self.view_error or self.export_error or (
            self.frame.error if self.frame is not None else None)
        if self.texture is not None and not self.view_error:
            engine.bind_display_space_shader(depsgraph.scene)
            try:
                drawing.draw_texture(self.texture, 0, 0, width, height)
            finally:
                engine.unbind_display_space_shader()
        if message:
            drawing.text(20, height - 60, _wrap(f"Snell: {message}", max(20, width // 8)))
        engine.update_stats("", self._status(message))

    def _follow_view(self, engine, context, depsgraph, size):
        if size != self.size:
            self.size, self.size_since = size, time.perf_counter()
        try:
            camera = region_camera(context, depsgraph)
        except ViewUnsupported as exc:
            if self.view_error != str(exc):
                self._report(engine, "WARNING", str(exc))
            self.view_error = str(exc)
            return
        self.view_error = None
        if self.camera is not None and self._resize_pending() and \
                camera["resolution"] != self.camera["resolution"]:
            return                      # the old image, stretched, until the size settles
        if camera != self.camera:
            self.camera = camera
            self._restart(engine, depsgraph.scene, "camera")

    def _resize_pending(self) -> bool:
        return time.perf_counter() - self.size_since < RESIZE_DELAY

    def _restart(self, engine, bl_scene, why):
        if self.content is None or self.camera is None or self.export_error:
            return
        if self.submitted is not None and self.submitted[0] is self.content and \
                self.submitted[1] == self.camera:
            return
        spp, limit, threads, denoise = settings(bl_scene)
        if self.session is not None and self.session.threads != threads:
            self.session.stop()           # Performance > Threads changed: a new worker pool
            self.session = None
        if self.session is None:
            self.session = self.session_factory(threads=threads)
        scene = self.content.with_camera(self.camera)
        generation = self.session.submit(scene, self.content.geometry_version, spp, limit,
                                         denoise)
        self.generations[generation] = "first" if self.submitted is None else why
        self.submitted = (self.content, self.camera)
        self.target_spp = spp

    def _show(self, engine, frame, drawing):
        if frame.error:
            self._report(engine, "ERROR", frame.error)
        if frame.image is not None:
            self.texture = drawing.texture(view_draw.display_pixels(frame.image, frame.alpha))
            if frame.stats.get("nan_count"):
                self._report(engine, "WARNING",
                             f"{frame.stats['nan_count']} NaN/Inf samples counted as 0")
            if frame.stats.get("denoise_warning"):
                self._report(engine, "WARNING", frame.stats["denoise_warning"])
        self.frame = frame

    def _status(self, message) -> str:
        if message:
            return f"Snell: {message}"
        session, frame = self.session, self.frame
        if session is not None and session.status and session.status != "rendering":
            return f"Snell: {session.status}"
        if frame is None:
            return "Snell: exporting"
        if frame.divisor > 1:
            return f"Snell: preview 1/{frame.divisor}"
        rate = frame.stats.get("samples_per_second")
        rate = f" | {rate:.1f} samples/s" if rate else ""
        return (f"Sample {frame.samples}" + (f"/{self.target_spp}" if self.target_spp else "")
                + rate + (" | denoised" if frame.stats.get("denoised") else "")
                + (" | done" if frame.final else ""))

    def _report(self, engine, level, message):
        """Report a message once per viewport (each edit re-exports, so warnings repeat)."""
        if (level, message) in self.reported:
            return
        self.reported.add((level, message))
        text = " ".join(f"Snell: {message}".split())
        print(text, file=sys.stderr)
        try:
            engine.report({level}, text)
        except Exception:  # a viewport engine may have no report list: the console has it
            pass

    def stop(self):
        """Stop and join the worker. It ends within a chunk of paths; the wait is bounded so
        that Blender never freezes on it (compiling the kernels on a first run cannot be cut
        short: the worker, a daemon thread, then ends when that is done)."""
        if self.session is not None:
            self.session.stop(timeout=STOP_WAIT)
            self.session = None
        self.texture = None


def _source():
    import bpy
    return bpy.path.basename(bpy.data.filepath) or "(unsaved)"


def _wrap(text, width):
    """Text as lines of at most about width characters."""
    lines, line = [], ""
    for word in text.split():
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}" if line else word
    return lines + ([line] if line else [])
