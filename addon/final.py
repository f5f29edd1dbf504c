"""The final (F12) render: export the depsgraph, then render progressively into the result.

Called by SnellRenderEngine.render. Every displayed state is a whole image (the mean of the
passes done so far), so the Render window never shows a half-drawn frame. Esc (test_break) is
checked after the export, after the BVH build and after every pass; the image of the samples done
so far stays. Failures end with one clear message through report() and error_set().

`last_render` records what the most recent render did (samples, timings, warnings, error) for
`snell batch` and the tests.
"""
from __future__ import annotations

import contextlib
import importlib.util
import os
import sys
import threading
import time
import traceback

import numpy as np

from ..errors import CliError
from ..tracer.progress import describe_adaptive, fraction_done, pixels_sampling, time_left
from ..tracer.scene import SceneError, has_world_light
from . import kernel_warmup, window

MAX_REPORTED_WARNINGS = 20
SAMPLE_COUNT_PASS = "Sample Count"   # Cycles' name for its pass of each pixel's samples
# Blender's names of the denoising passes: (name, channels, channel ids), as Cycles adds them.
NOISY_PASS = ("Noisy Image", 4, "RGBA")
FEATURE_PASSES = (("Denoising Albedo", 3, "RGB"), ("Denoising Normal", 3, "XYZ"))


# View Layer > Passes > Data that Snell fills: the view layer's switch -> (name, channels,
# channel ids), as Cycles adds them (tracer/data_passes.py makes them).
DATA_PASSES = {"use_pass_z": ("Depth", 1, "Z"), "use_pass_position": ("Position", 3, "XYZ"),
               "use_pass_normal": ("Normal", 3, "XYZ"),
               "use_pass_object_index": ("Object Index", 1, "X")}


# View Layer > Passes > Light that Snell fills: the view layer's switch -> Blender's pass name
# (tracer/light_passes.py makes them, as Cycles defines them), each RGB.
LIGHT_PASSES = {"use_pass_emit": "Emission", "use_pass_environment": "Environment",
                "use_pass_diffuse_direct": "Diffuse Direct",
                "use_pass_diffuse_indirect": "Diffuse Indirect",
                "use_pass_diffuse_color": "Diffuse Color",
                "use_pass_glossy_direct": "Glossy Direct",
                "use_pass_glossy_indirect": "Glossy Indirect",
                "use_pass_glossy_color": "Glossy Color",
                "use_pass_transmission_direct": "Transmission Direct",
                "use_pass_transmission_indirect": "Transmission Indirect",
                "use_pass_transmission_color": "Transmission Color"}


def light_passes_of(view_layer) -> tuple:
    """The light passes a view layer asks for, as (name, channels, channel ids) entries."""
    return tuple((name, 3, "RGB") for switch, name in LIGHT_PASSES.items()
                 if getattr(view_layer, switch, False))


def light_groups_of(view_layer) -> tuple:
    """The light groups' passes of a view layer (View Layer > Light Groups), as (name, channels,
    channel ids) entries: "Combined_<group>", RGB, as Cycles adds them (blender/sync.cpp)."""
    from ..tracer.light_groups import pass_name
    return tuple((pass_name(group.name), 3, "RGB")
                 for group in getattr(view_layer, "lightgroups", None) or ())


def data_passes_of(view_layer) -> tuple:
    """The data passes a view layer asks for that Snell fills (DATA_PASSES' entries)."""
    return tuple(entry for switch, entry in DATA_PASSES.items()
                 if getattr(view_layer, switch, False))


def denoising_passes(settings) -> tuple:
    """The denoising passes a render with these settings fills: the noisy image when it
    denoises, the albedo and normal when it renders them (on a cluster too)."""
    return (((NOISY_PASS,) if settings.denoise else ())
            + (FEATURE_PASSES if settings.wants_features else ()))


def oidn_dirs() -> list:
    """The folders where Blender keeps its Open Image Denoise library: lib/ beside the
    executable (Linux), blender.shared (Windows), Contents/Resources/lib (macOS)."""
    import bpy
    binary = getattr(bpy.app, "binary_path", "") or ""
    if not binary:
        return []
    here = os.path.dirname(binary)
    return [os.path.join(here, "lib"), os.path.join(here, "blender.shared"), here,
            os.path.join(here, os.pardir, "Resources", "lib")]

last_render: dict = {}

# Set by `snell batch` on Ctrl-C: the render stops as on Esc. A KeyboardInterrupt raised inside
# the engine's callback would unwind through Blender's C code, which prints it and can crash.
stop_requested = threading.Event()
# Settings `snell batch` gives on its command line, over the scene's (tracer/settings.py names):
# they reach the render without being written into the file's properties.
overrides: dict = {}
# Set by `snell batch --workers/--cluster`: the frames render through it instead of this
# process's Renderer: render(scene, settings, name, frame, progress, stop=) -> RenderResult
# (farm/render.py's Session). Without it, a scene whose Render On (scene.snell.render_on) is
# a Dask cluster renders through a Session of its own (_cluster_session); the add-on imports
# farm/ and Dask only then.
remote_render = None
# Render On's choices (addon/properties.py): this process, a scheduler's address, or Dask
# worker processes started on this computer for the render.
THIS_COMPUTER, DASK_SCHEDULER, LOCAL_WORKERS = "THIS_COMPUTER", "DASK_SCHEDULER", "LOCAL_WORKERS"


def _should_stop(engine) -> bool:
    return engine.test_break() or stop_requested.is_set()


class _Esc:
    """Esc (or `snell batch`'s Ctrl-C) as the farm's stop: is_set() asks the engine."""

    def __init__(self, engine):
        self.engine = engine

    def is_set(self) -> bool:
        return _should_stop(self.engine)


def cluster_of(props) -> tuple:
    """(scheduler address, local worker processes) of a scene's Render On (scene.snell): one of
    them None; None for This Computer. RenderFailed for a Dask Scheduler without an address."""
    where = getattr(props, "render_on", THIS_COMPUTER)
    if where == DASK_SCHEDULER:
        address = props.cluster_address.strip()
        if not address:
            raise RenderFailed("Render On is Dask Scheduler, but the scheduler's address is "
                               "empty (Render Properties > Performance > Scheduler)")
        return address, None
    if where == LOCAL_WORKERS:
        return None, int(props.cluster_workers)
    return None


@contextlib.contextmanager
def _cluster_session(engine, props):
    """A Dask session for the frame (farm/render.py's Session, closed on exit) when Render On
    is a cluster, else None: yields what renders the frame instead of a Renderer."""
    where = cluster_of(props)
    if where is None:
        yield None
        return
    address, workers = where
    if importlib.util.find_spec("distributed") is None:
        raise RenderFailed("rendering on a Dask cluster needs Dask in Blender's Python: "
                           f"{sys.executable} -m pip install distributed (and Snell on every "
                           "worker: pip install 'snell[distributed]'), or set Render On to "
                           "This Computer")
    from ..farm.render import session
    engine.update_stats("", f"Snell: connecting to the Dask scheduler {address}" if address else
                        f"Snell: starting {workers} Dask worker process"
                        + ("es" if workers != 1 else ""))
    origin = f"Render On: Dask Scheduler {address}" if address else "Render On: Local Dask Workers"
    with session(address, workers, quiet=True, origin=origin) as render:
        yield render


class RenderFailed(Exception):
    """A failure the user should see as one message."""


def _duration(seconds: float) -> str:
    if seconds != seconds or seconds == float("inf"):
        return "--:--"
    minutes, secs = divmod(seconds, 60.0)
    hours, minutes = divmod(int(minutes), 60)
    return f"{hours}:{minutes:02d}:{secs:05.2f}" if hours else f"{minutes:02d}:{secs:05.2f}"


def _border(render, full_w, full_h):
    if not render.use_border:
        return window.border_pixels(full_w, full_h)
    return window.border_pixels(full_w, full_h, (render.border_min_x, render.border_max_x,
                                                 render.border_min_y, render.border_max_y))


def _source_name() -> str:
    """The .blend's file name, which names the scene in messages."""
    import bpy
    return os.path.basename(bpy.data.filepath) or "(unsaved)"


def _export(engine, depsgraph, record):
    from .export import export_depsgraph

    source = _source_name()
    try:
        scene, warnings = export_depsgraph(depsgraph, source=source)
    except SceneError as exc:
        raise RenderFailed(f"cannot render this scene: {exc}") from None
    record["warnings"] = list(warnings)
    for message in warnings[:MAX_REPORTED_WARNINGS]:
        engine.report({"WARNING"}, f"Snell: {message}")
    if len(warnings) > MAX_REPORTED_WARNINGS:
        engine.report({"WARNING"}, f"Snell: ... and {len(warnings) - MAX_REPORTED_WARNINGS} "
                                   f"more warnings (see the console)")
        for message in warnings[MAX_REPORTED_WARNINGS:]:
            print(f"Snell: warning: {message}", file=sys.stderr)
    if len(scene.triangles) == 0 and not scene.lights and not has_world_light(scene.world):
        message = "the scene has no geometry, no lights and a black world: the image is black"
        record["warnings"].append(message)
        engine.report({"WARNING"}, f"Snell: {message}")
    return scene


def _integrator():
    try:
        from ..tracer import integrator
    except ImportError as exc:
        # embreex, numba and llvmlite come as the extension's own wheels.
        raise RenderFailed(f"the renderer's libraries cannot be loaded: {exc}. "
                           f"Reinstall the Snell extension for this platform.") from None
    return integrator


def _compile_kernels(engine, record) -> bool:
    """Compile the kernels on the first render after an install or update, saying so, or wait
    for the background compile that choosing Snell started (kernel_warmup); False if the render
    was cancelled meanwhile."""
    integrator = _integrator()
    record["kernels_compiled_s"] = None
    if integrator.kernels_compiled():
        return True
    start = time.perf_counter()

    def waiting(status):
        engine.update_stats("", status)
        return not _should_stop(engine)

    if kernel_warmup.running():
        kernel_warmup.wait(waiting)
        if _should_stop(engine):
            return False
    if integrator.kernels_compiled():
        record["kernels_compiled_s"] = time.perf_counter() - start
        return True
    message = "Snell: compiling kernels (first run only)"
    engine.update_stats("", message)
    print(message, file=sys.stderr, flush=True)
    record["kernels_compiled_s"] = integrator.warm_up()
    return True


class _Progress:
    """The integrator's per-pass callback: pixels, progress bar, stats line and Esc."""

    def __init__(self, engine, result, width, height, spp, record, t_start):
        self.engine, self.result = engine, result
        passes = result.layers[0].passes
        self.combined = passes["Combined"]
        self.counts = passes.get(SAMPLE_COUNT_PASS)   # None if Blender did not add it
        if len(self.combined.rect) != width * height:
            raise RenderFailed(f"render result is {len(self.combined.rect)} pixels, "
                               f"expected {width}x{height}")
        self.rgba = np.ones((height, width, 4), np.float32)
        self.spp, self.record, self.t_start = spp, record, t_start
        self.t_loop = time.perf_counter()
        self.written_spp = 0

    def write(self, render_result):
        # The tracer's row 0 is the top; Blender's is the bottom.
        self.rgba[:, :, :3] = render_result.mean()[::-1]
        if render_result.has_alpha:     # Film > Transparent, or a Holdout
            self.rgba[:, :, 3] = render_result.alpha()[::-1]
        self.combined.rect.foreach_set(self.rgba.ravel())
        if self.counts is not None:
            self.counts.rect.foreach_set(
                np.ascontiguousarray(render_result.samples()[::-1], np.float32).ravel())
        self.engine.update_result(self.result)
        self.written_spp = render_result.spp

    def __call__(self, render_result, done, total):
        # Progress is samples over the budget, not passes: adaptive sampling's pass count is an
        # estimate, and the share of pixels still sampling says how much is left to do.
        self.write(render_result)
        now = time.perf_counter()
        if done == 1:
            self.record["first_pass_s"] = now - self.t_start
        remaining = time_left(render_result, now - self.t_loop)
        self.record.update(spp=render_result.spp, passes=done)
        self.engine.update_progress(fraction_done(render_result))
        sampling = pixels_sampling(render_result)
        light = (f" | {render_result.light_paths / 1e6:.2f} M light paths"
                 if render_result.light_paths else "")
        self.engine.update_stats("", f"Remaining {_duration(remaining)} | Sample "
                                     f"{render_result.spp}/{self.spp} | "
                                     + (f"{sampling} | " if sampling else "")
                                     + f"{render_result.rays_per_second / 1e6:.2f} M rays/s{light}")
        return not _should_stop(self.engine)


class _Frame:
    """What the steps of one F12 render share: its engine and scene, the record, the result
    begun and not yet ended, and the cluster's session to close at the end."""

    def __init__(self, engine, depsgraph):
        self.t_start = time.perf_counter()
        self.engine, self.depsgraph, self.bl_scene = engine, depsgraph, depsgraph.scene
        record = {"frame": self.bl_scene.frame_current, "spp": 0, "passes": 0, "target_spp": 0,
                  "cancelled": False, "error": None, "warnings": [], "first_pass_s": None}
        last_render.clear()
        last_render.update(record)
        self.record = last_render
        self.result = None
        self.resources = contextlib.ExitStack()     # the cluster's session, if Render On is one
        # Set by _prepare: the windowed scene, its settings, the result's size and extra passes.
        self.scene = self.settings = None
        self.w = self.h = 0
        self.light = self.groups = self.data = ()
        # Set by _start_tracer: what renders the frame, a cluster's session or a Renderer.
        self.remote = self.renderer = None


def render(engine, depsgraph):
    """F12: the whole final render of one frame (see the module docstring)."""
    frame = _Frame(engine, depsgraph)
    try:
        _render_frame(frame)
    except (RenderFailed, CliError) as exc:    # CliError: a cluster's (remote_render)
        _fail(engine, str(exc), frame.record)
    except Exception as exc:  # a bug: keep the traceback in the console, a message in the UI
        traceback.print_exc()
        _fail(engine, f"render failed ({type(exc).__name__}: {exc}); details in the console",
              frame.record)
    finally:
        _close(frame)


def _render_frame(frame):
    """Export, start the tracer (or the cluster), render progressively and write the passes;
    Esc before the first pass ends with a black image."""
    engine = frame.engine
    if not _prepare(frame) or not _start_tracer(frame):
        _stop_without_image(engine, frame.record)
        return
    _add_passes(frame)
    frame.result = engine.begin_result(0, 0, frame.w, frame.h)
    spp = frame.settings.spp
    progress = _Progress(engine, frame.result, frame.w, frame.h, spp, frame.record,
                         frame.t_start)
    engine.update_stats("", f"Snell: rendering, sample 0/{spp}")
    if frame.remote is None:
        rendered = frame.renderer.render(progress=progress)
    else:
        rendered = _render_remote(frame, progress)
    _record_outcome(frame, rendered)
    _write_denoised(engine, frame.result, progress, rendered, frame.settings, frame.record)
    _write_extra_passes(frame, rendered)
    engine.update_stats("", _done_line(frame, rendered))
    engine.end_result(frame.result)
    frame.result = None


def _prepare(frame) -> bool:
    """Export the scene, window it to the render border, and settle its settings and the light
    and data passes the view layer asks for; False if Esc came during the export."""
    engine, bl_scene, record = frame.engine, frame.bl_scene, frame.record
    engine.update_stats("", "Snell: exporting the scene")
    scene = _export(engine, frame.depsgraph, record)
    record["export_s"] = time.perf_counter() - frame.t_start
    if _should_stop(engine):
        return False
    x0, y0, frame.w, frame.h = _border(bl_scene.render, engine.resolution_x, engine.resolution_y)
    frame.scene = scene.with_camera(**window.window_camera(scene.camera, x0, y0, frame.w,
                                                           frame.h))
    settings = _settings(bl_scene, frame.scene)
    view_layer = frame.depsgraph.view_layer
    frame.light = light_passes_of(view_layer)
    if frame.light:
        settings = settings.replace(light_passes=True)
    frame.groups = light_groups_of(view_layer)
    if frame.groups:
        settings = settings.replace(light_groups=True)
    frame.data = data_passes_of(view_layer)
    frame.settings = settings
    record["target_spp"] = settings.spp
    return True


def _start_tracer(frame) -> bool:
    """Compile the kernels, then open the cluster's session when Render On is one (or `snell
    batch` gives one), else build a Renderer and its BVH; False if Esc came meanwhile."""
    engine, bl_scene = frame.engine, frame.bl_scene
    frame.remote = remote_render
    if frame.remote is None and cluster_of(bl_scene.snell) is not None:
        from ..farm.render import check_settings
        check_settings(frame.settings, _source_name(), "set Sampling > Time Limit to 0, or "
                                                       "Render On to This Computer")
    # Local workers load the kernels this compiles from the disk cache.
    if not _compile_kernels(engine, frame.record):
        return False
    if frame.remote is None:
        frame.remote = frame.resources.enter_context(_cluster_session(engine, bl_scene.snell))
        frame.record["workers"] = getattr(frame.remote, "processes", 0)
    if _should_stop(engine):
        return False
    if frame.remote is None:
        engine.update_stats("", f"Snell: building the BVH of {len(frame.scene.triangles)} "
                                "triangles")
        frame.renderer = _integrator().Renderer(frame.scene, frame.settings)
        if _should_stop(engine):
            return False
    return True


def _add_passes(frame):
    """Add the Sample Count, denoising, light, light group and data passes to the view layer:
    before begin_result, so that the result has them (as Cycles adds its passes)."""
    layer = frame.depsgraph.view_layer.name
    frame.engine.add_pass(SAMPLE_COUNT_PASS, 1, "X", layer=layer)
    for name, channels, ids in (denoising_passes(frame.settings) + frame.light + frame.groups
                                + frame.data):
        frame.engine.add_pass(name, channels, ids, layer=layer)


def _render_remote(frame, progress):
    """The frame rendered on the Dask cluster (remote_render or Render On's session)."""
    rendered = frame.remote(frame.scene, frame.settings, _source_name(),
                            frame.bl_scene.frame_current, progress, stop=_Esc(frame.engine))
    if rendered.spp == 0:       # Esc before the cluster's first window: a black image
        progress.write(rendered)
    return rendered


def _record_outcome(frame, rendered):
    """What the render did, into the record, and its NaN/Inf samples reported."""
    frame.record.update(spp=rendered.spp, cancelled=rendered.cancelled, time_s=rendered.time_s,
                        compile_s=rendered.compile_s,
                        rays_per_second=rendered.rays_per_second, nan_count=rendered.nan_count,
                        light_paths=rendered.light_paths, adaptive=describe_adaptive(rendered),
                        saved_share=rendered.saved_share,
                        mean_spp=float(rendered.samples().mean()),
                        exr_channels=rendered.exr_channels())
    engine = frame.engine
    if rendered.nan_count:
        engine.report({"WARNING"}, f"Snell: {rendered.nan_count} NaN/Inf samples counted as 0")
    if rendered.alpha_nan_count:
        engine.report({"WARNING"}, f"Snell: {rendered.alpha_nan_count} NaN/Inf alpha samples "
                                   "left out")


def _write_extra_passes(frame, rendered):
    """The light, light group and data passes of a finished render into the result."""
    engine, result = frame.engine, frame.result
    if frame.light and rendered.has_light_passes:
        _write_light_passes(engine, result, frame.light, rendered)
    if frame.groups and rendered.has_light_groups:
        _write_passes(result, frame.groups, rendered.light_group_images())
        if rendered.light_group_nans[0]:
            engine.report({"WARNING"}, f"Snell: {int(rendered.light_group_nans[0])} NaN/Inf "
                                       "light-group samples left out")
        engine.update_result(result)
    if frame.data and not rendered.cancelled:
        _write_data_passes(result, frame.data,
                           frame.renderer or _integrator().Renderer(frame.scene, frame.settings))
        engine.update_result(result)


def _done_line(frame, rendered) -> str:
    """The stats line of a finished render: how it ended, samples, time, workers, speed."""
    state = ("Cancelled after" if rendered.cancelled else
             "Time limit reached after" if rendered.time_limited else "Done:")
    workers = getattr(rendered, "workers", 0)
    on = f" on {workers} Dask worker{'s' if workers != 1 else ''}" if workers else ""
    adaptive = frame.record["adaptive"]
    return (f"Snell: {state} {rendered.spp}/{frame.settings.spp} samples in "
            f"{_duration(time.perf_counter() - frame.t_start)}{on} "
            f"({rendered.rays_per_second / 1e6:.2f} M rays/s)"
            + (f" | {adaptive}" if adaptive else ""))


def _close(frame):
    """End a result left begun (cancelled), close the cluster's session and record the time."""
    if frame.result is not None:
        frame.engine.end_result(frame.result, cancel=True)
    try:
        frame.resources.close()        # the cluster's client, and the local workers stopped
    except Exception as exc:  # noqa: BLE001  (closing must not hide the render's outcome)
        print(f"Snell: closing the Dask session: {type(exc).__name__}: {exc}", file=sys.stderr)
    frame.record["total_s"] = time.perf_counter() - frame.t_start


def _write_light_passes(engine, result, light, rendered):
    """The light passes (light_passes_of's) of a render into the result."""
    _write_passes(result, light, rendered.light_pass_images())
    if rendered.light_pass_nan_count:
        engine.report({"WARNING"}, f"Snell: {rendered.light_pass_nan_count} NaN/Inf light-pass "
                                   "samples left out")
    engine.update_result(result)


def _write_passes(result, entries, values):
    """RGB passes ((name, channels, ids) entries, their images in values: float32 (H, W, 3),
    row 0 at the top) into the result, NaN and Inf made 0."""
    from ..tracer.image import sanitize
    passes = result.layers[0].passes
    for name, _, _ in entries:
        target = passes.get(name)
        if target is not None:       # Blender's row 0 is the bottom
            clean, _ = sanitize(values[name])
            target.rect.foreach_set(np.ascontiguousarray(clean[::-1], np.float32).ravel())


def _write_data_passes(result, data, renderer):
    """The data passes (data_passes_of's) of the render's scene and camera into the result."""
    from ..tracer.data_passes import data_passes
    values = data_passes(renderer, [name for name, _, _ in data])
    passes = result.layers[0].passes
    for name, channels, _ in data:
        target = passes.get(name)
        if target is not None:       # Blender's row 0 is the bottom
            target.rect.foreach_set(np.ascontiguousarray(values[name][::-1]).ravel())


def _write_denoised(engine, result, progress, rendered, settings, record):
    """The denoising passes of a finished render into the result and, with denoising on, the
    denoised image as its Combined pass (the noisy one kept as Noisy Image); a missing or
    failing OIDN leaves the noisy image and says why."""
    record["denoised"] = False
    if not (rendered.has_features or settings.denoise):
        return
    passes = result.layers[0].passes

    def put(name, rgb, channels):
        target = passes.get(name)
        if target is None or rgb is None:
            return
        pixels = np.ones((rgb.shape[0], rgb.shape[1], channels), np.float32)
        pixels[..., :3] = rgb[::-1]          # Blender's row 0 is the bottom
        target.rect.foreach_set(pixels.ravel())

    if rendered.has_features:
        put(FEATURE_PASSES[0][0], rendered.denoising_albedo(), 3)
        put(FEATURE_PASSES[1][0], rendered.denoising_normal(), 3)
        if rendered.feature_nan_count:
            engine.report({"WARNING"}, f"Snell: {rendered.feature_nan_count} NaN/Inf "
                                       "denoising-pass samples left out")
    if not settings.denoise or rendered.cancelled or rendered.spp == 0:
        engine.update_result(result)
        return
    from ..tracer.denoise import denoise_result
    engine.update_stats("", "Snell: denoising")
    outcome = denoise_result(rendered, settings, oidn_dirs())
    put(NOISY_PASS[0], outcome.noisy, 4)
    if outcome.denoised:
        progress.rgba[:, :, :3] = outcome.image[::-1]
        progress.combined.rect.foreach_set(progress.rgba.ravel())
    record.update(denoised=outcome.denoised, denoise_s=outcome.seconds)
    if outcome.warning:
        record["warnings"].append(outcome.warning)
        engine.report({"WARNING"}, f"Snell: {outcome.warning}")
    engine.update_result(result)


def _settings(bl_scene, scene):
    """The render's settings: the exported scene's, Snell's threads (or Blender's), and `snell
    batch`'s overrides."""
    from .export import blender_settings, blender_threads

    try:
        threads = blender_threads(bl_scene, blender_settings(bl_scene))
        return scene.settings(threads=threads).replace(**overrides)
    except SceneError as exc:
        raise RenderFailed(f"cannot render this scene: {exc}") from None


def _stop_without_image(engine, record):
    """Esc or Ctrl-C before the first pass: end with a black result. Writing the still of a render
    that produced no pixels (none begun, or one ended with cancel=True) crashes Blender 5.0 in
    its EXR writer; `snell batch` deletes the image of an interrupted frame."""
    record["cancelled"] = True
    engine.end_result(engine.begin_result(0, 0, engine.resolution_x, engine.resolution_y))


def _fail(engine, message, record):
    message = " ".join(f"Snell: {message}".split())
    record["error"] = message
    engine.report({"ERROR"}, message)
    engine.error_set(message)
    engine.update_stats("", message)
