"""`snell batch`: headless renders of .blend frames through the bpy module and the registered
engine.

The same path as `blender --background scene.blend --engine SNELL --render-frame N`: the file is
opened, its render engine set to SNELL, and each frame rendered by bpy.ops.render.render with
write_still, so the engine, the exporter, Blender's colour management and its image writers do
exactly what they do for F12. One progress line per frame on stderr; the exit status is 1 if
any frame failed.
"""
from __future__ import annotations

import contextlib
import os
import re
import signal
import sys
import time

from .blendfile import BlendFileError, blender_reason, open_blend
from .console import stdout_silenced

FORMATS = {".exr": "OPEN_EXR", ".png": "PNG"}


class BatchError(Exception):
    """A user error before any frame is rendered (bad file, bad frame list, bad output name)."""


def parse_frames(text: str) -> list[int]:
    """'7', '1-10', '1-10x2' or comma-separated mixes of them, in the given order."""
    frames = []
    for part in text.split(","):
        m = re.fullmatch(r"\s*(-?\d+)(?:\s*(?:-|\.\.)\s*(-?\d+)(?:\s*x\s*(\d+))?)?\s*", part)
        if not m:
            raise BatchError(f"--frames {text!r}: expected frames like 1, 1-10, 1-10x2 or 1,5,9")
        start = int(m.group(1))
        end = int(m.group(2)) if m.group(2) is not None else start
        step = int(m.group(3) or 1)
        if end < start or step < 1:
            raise BatchError(f"--frames {text!r}: empty range {part.strip()!r}")
        frames.extend(range(start, end + 1, step))
    return frames


def _set_output(scene, output):
    ext = os.path.splitext(output)[1].lower()
    if ext not in FORMATS:
        raise BatchError(f"-o {output}: expected a .exr or .png file name")
    directory = os.path.dirname(os.path.abspath(output))
    if not os.path.isdir(directory):
        raise BatchError(f"-o {output}: directory {directory} does not exist")
    settings = scene.render.image_settings
    settings.file_format = FORMATS[ext]
    # With Film > Transparent the alpha too, as Cycles' files have it.
    mode = "RGBA" if scene.render.film_transparent else "RGB"
    if ext == ".exr":   # linear scene-referred float, as `snell render` writes
        settings.color_depth = "32"
        settings.color_mode = mode
    else:               # 8-bit through the scene's view transform, as any engine
        settings.color_depth = "8"
        settings.color_mode = mode
    scene.render.use_file_extension = True
    scene.render.filepath = os.path.abspath(output)


def _add_render_channels(path, channels):
    """Blender's EXR of a frame rewritten with the render's own channels after R, G, B (its
    alpha where it made one, each pixel's samples: RenderResult.exr_channels), so that `snell
    batch` and `snell render` write the same channels. Left as Blender wrote it when they do not
    cover the image (a render region without crop)."""
    from ..tracer import image

    rgb = image.read_exr(path)
    if not channels or channels["samples"].shape != rgb.shape[:2]:
        return
    image.write_exr(path, rgb, channels=channels)


def run(blend_path: str, frames: str | None = None, output: str | None = None,
        stream=sys.stderr, settings: dict | None = None, scale: int | None = None,
        remote_render=None) -> int:
    """Render the frames of blend_path; returns the exit status (0, or 1 if a frame failed).
    settings: render settings over the file's (tracer/settings.py names), for every frame;
    scale: the resolution percentage over the file's; remote_render: what renders each frame
    instead of this process (final.remote_render: a Dask cluster's)."""
    import bpy

    from . import final, registration

    if not os.path.isfile(blend_path):
        raise BatchError(f"{blend_path}: no such file")
    frame_list = parse_frames(frames) if frames else None
    registration.ensure_registered()
    try:
        with stdout_silenced():
            open_blend(blend_path)
    except BlendFileError as exc:
        raise BatchError(str(exc)) from None
    scene = bpy.context.scene
    scene.render.engine = "SNELL"
    if scale is not None:
        scene.render.resolution_percentage = scale
    if output:
        _set_output(scene, output)
    frame_list = frame_list or [scene.frame_current]
    exact = None
    if output and "#" not in os.path.basename(output):
        # Blender would append the frame number to a name without #: same.exr0001.exr.
        if len(frame_list) > 1:
            raise BatchError(f"-o {output}: {len(frame_list)} frames need #### in the file name "
                             "for the frame number (e.g. frame_####.exr)")
        exact = os.path.abspath(output)
    with _ctrl_c_stops_the_render(final.stop_requested) as interrupted, \
            _overriding(final.overrides, settings or {}), _rendering_with(final, remote_render):
        return _render_frames(bpy, final, scene, blend_path, frame_list, interrupted, stream,
                              exact)


@contextlib.contextmanager
def _overriding(overrides: dict, settings: dict):
    """The engine renders with `settings` over the file's while the frames render."""
    overrides.update(settings)
    try:
        yield
    finally:
        overrides.clear()


@contextlib.contextmanager
def _rendering_with(final, remote_render):
    """The engine renders through remote_render (None: in this process) while the frames render."""
    final.remote_render = remote_render
    try:
        yield
    finally:
        final.remote_render = None


@contextlib.contextmanager
def _ctrl_c_stops_the_render(stop):
    """While rendering, Ctrl-C sets `stop` (the engine ends the frame as on Esc) instead of
    raising inside Blender's render call; the yielded list records it."""
    interrupted = []

    def handler(signum, frame):
        interrupted.append(signum)
        stop.set()

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield interrupted
    finally:
        signal.signal(signal.SIGINT, previous)
        stop.clear()


def _prefetch(bpy, final, scene, frame: int, prefetch) -> None:
    """Export a frame to come and have the cluster start it (final.remote_render.prefetch).
    Exported from the view layer's depsgraph: Blender makes a render's only inside the render,
    so a frame whose render evaluation differs (a modifier's render levels) is started for
    nothing and renders afresh when its turn comes; an export that fails is left to the render
    to report. Leaves the scene at `frame`: the next render sets its own."""
    from ..tracer.camera import Camera
    from . import window
    from .export import export_depsgraph
    try:
        scene.frame_set(frame)
        exported, _ = export_depsgraph(bpy.context.evaluated_depsgraph_get(),
                                       source=final._source_name())
        full = Camera(exported.camera)
        x0, y0, w, h = final._border(scene.render, full.width, full.height)
        exported = exported.with_camera(**window.window_camera(exported.camera, x0, y0, w, h))
        prefetch(exported, final._settings(scene, exported), final._source_name(), frame)
    except Exception:  # noqa: BLE001  (the frame's own render reports what is wrong)
        pass


def _render_frames(bpy, final, scene, blend_path, frame_list, interrupted, stream, exact=None):
    """Render the frames; `exact`: the one frame's image goes to this path as given (-o without
    #), renamed from the numbered name Blender writes."""
    pattern = scene.render.filepath
    failed, seen_warnings, reasons = 0, set(), set()
    opened = getattr(final.remote_render, "wait", None)
    if opened is not None:      # a cluster opening meanwhile (farm/render.py): its error ends all
        opened()
    prefetch = getattr(final.remote_render, "prefetch", None)
    if prefetch is not None:
        _prefetch(bpy, final, scene, frame_list[0], prefetch)
    for i, frame in enumerate(frame_list, 1):
        head = f"snell: frame {frame} ({i}/{len(frame_list)})"
        if prefetch is not None and i < len(frame_list):
            # The next frame starts on the cluster before this one: its tasks take the workers
            # this frame's last windows leave idle (farm/render.py's Session).
            _prefetch(bpy, final, scene, frame_list[i], prefetch)
        path = scene.render.frame_path(frame=frame)
        start = time.perf_counter()
        error = None
        before = os.stat(path).st_mtime_ns if os.path.exists(path) else None
        final.last_render.clear()   # Blender may fail before the engine runs (no camera)
        try:
            scene.render.filepath = path   # already numbered and with its extension
            scene.frame_set(frame)
            with stdout_silenced():
                bpy.ops.render.render(write_still=True)
        except RuntimeError as exc:
            error = final.last_render.get("error") or blender_reason(exc)
        finally:
            scene.render.filepath = pattern
        if interrupted:
            # Blender wrote the image of the samples done before the stop: not the frame asked
            # for, so it goes (earlier frames are complete and stay).
            if os.path.exists(path) and os.stat(path).st_mtime_ns != before:
                os.unlink(path)
            raise KeyboardInterrupt
        record = dict(final.last_render)
        for message in record.get("warnings", []):
            if message not in seen_warnings:
                seen_warnings.add(message)
                print(f"snell: warning: {message}", file=stream)
        if error is None and record.get("error"):
            error = record["error"]
        if error is None and record.get("cancelled"):
            error = "cancelled"
        if error is None and (not os.path.exists(path) or os.stat(path).st_mtime_ns == before):
            error = f"no image written to {path}"
        if error:
            failed += 1
            reasons.add(error)
            if len(frame_list) > 1:     # one frame's reason is the error line's (printed once)
                print(f"{head}: FAILED: {error}", file=stream, flush=True)
            continue
        if exact is not None and path != exact:
            os.replace(path, exact)
            path = exact
        if path.lower().endswith(".exr"):
            _add_render_channels(path, record.get("exr_channels"))
        rate = record.get("rays_per_second", 0.0) / 1e6
        samples = record.get("adaptive") or f"{record.get('spp', 0)} spp"
        print(f"{head}: {path}: {samples} in {time.perf_counter() - start:.1f}s "
              f"({rate:.2f} M rays/s)", file=stream, flush=True)
    if failed:
        # One reason for all (no camera, a NaN matrix) is repeated on the error line.
        reason = f" ({next(iter(reasons))})" if len(reasons) == 1 else ""
        print(f"snell: error: {blend_path}: {failed} of {len(frame_list)} frames failed{reason}",
              file=stream)
    return 1 if failed else 0
