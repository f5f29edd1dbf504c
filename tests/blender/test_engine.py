"""The Snell render engine inside the bpy module: F12 renders, progress, cancel, border, errors,
`snell batch`, registration hygiene, and Cycles and Snell renders alternating in one process."""
import contextlib
import io
import subprocess
import sys
import time
import types

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
oiio = pytest.importorskip("OpenImageIO")

from snell.addon import final, registration, ui, window  # noqa: E402
from snell.addon.export import export_depsgraph  # noqa: E402
from snell.tracer import passes  # noqa: E402
from snell.tracer.integrator import Renderer  # noqa: E402
from support.windows import sample_windows  # noqa: E402

SIZE = 32


@pytest.fixture(scope="session")
def blends(blender_scenes):
    """The test scenes (tests/support/blender_scenes.py at SIZE), built once (tests/conftest.py)."""
    return blender_scenes


@pytest.fixture(scope="module", autouse=True)
def registered():
    registration.ensure_registered()
    yield


def read_exr(path):
    img = oiio.ImageBuf(str(path))
    assert not img.has_error, img.geterror()
    return img.get_pixels(oiio.FLOAT)[:, :, :3]


def read_channel(path, name):
    img = oiio.ImageBuf(str(path))
    assert not img.has_error, img.geterror()
    return img.get_pixels(oiio.FLOAT)[:, :, list(img.spec().channelnames).index(name)]


def open_scene(path, exr_path=None):
    bpy.ops.wm.open_mainfile(filepath=str(path))
    scene = bpy.context.scene
    scene.render.engine = "SNELL"
    if exr_path is not None:
        settings = scene.render.image_settings
        settings.file_format, settings.color_depth, settings.color_mode = "OPEN_EXR", "32", "RGB"
        scene.render.filepath = str(exr_path)
    return scene


def tracer_image(spp=None, passes=None):
    """What the tracer renders for the open scene, exported from the viewport depsgraph
    (with `passes`, a render of `spp` samples stopped after that many passes)."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    scene, _ = export_depsgraph(depsgraph)
    progress = None if passes is None else (lambda result, done, total: done < passes)
    settings = scene.settings() if spp is None else scene.settings(spp=spp)
    return Renderer(scene, settings).render(progress=progress).mean()


@pytest.fixture
def small_passes(monkeypatch):
    """1 sample per pixel per pass at 32x32, so a render has several passes."""
    sample_windows(monkeypatch, SIZE * SIZE, 1)


class Spy:
    """Stands in for the engine inside final.render: records or changes some calls, passes the
    rest to the real engine (RNA methods cannot be overridden in a RenderEngine subclass)."""

    def __init__(self, engine):
        self.engine = engine

    def __getattr__(self, name):
        return getattr(self.engine, name)


def recording(calls, on_result=None):
    """A Spy class that appends ("result",), ("progress", value) and ("stats", info) to calls
    for the engine's updates; on_result(result), if given, sees each result first."""
    class Recording(Spy):
        def update_result(self, result):
            calls.append(("result",))
            if on_result is not None:
                on_result(result)
            self.engine.update_result(result)

        def update_progress(self, value):
            calls.append(("progress", value))
            self.engine.update_progress(value)

        def update_stats(self, stats, info):
            calls.append(("stats", info))
            self.engine.update_stats(stats, info)
    return Recording


def sample_count_pass(result):
    """The Sample Count pass of a render result, (SIZE * SIZE,) float32, bottom row first."""
    rect = np.empty(SIZE * SIZE, np.float32)
    result.layers[0].passes[final.SAMPLE_COUNT_PASS].rect.foreach_get(rect)
    return rect


def pass_grabber(names, into):
    """An on_result for recording(): stores each named pass of a result in the dict into, as
    (SIZE, SIZE, channels) float32 with the top row first; a pass the result lacks is skipped."""
    def grab(result):
        for name in names:
            rpass = result.layers[0].passes.get(name)
            if rpass is not None:
                rect = np.empty(SIZE * SIZE * rpass.channels, np.float32)
                rpass.rect.foreach_get(rect)
                into[name] = rect.reshape(SIZE, SIZE, rpass.channels)[::-1]
    return grab


@contextlib.contextmanager
def spying(spy_class):
    """The SNELL engine renders through spy_class(engine) while the context is active."""
    real = final.render
    final_module_render = lambda engine, depsgraph: real(spy_class(engine), depsgraph)  # noqa: E731
    registration.engine.final.render = final_module_render
    try:
        yield
    finally:
        registration.engine.final.render = real


# ---------------------------------------------------------------------------------------------
# Registration


def _snell_traces():
    panels = [name for name in dir(bpy.types)
              if "SNELL" in (getattr(getattr(bpy.types, name), "COMPAT_ENGINES", None) or ())]
    names = [name for name in dir(bpy.types) if "snell" in name.lower()]
    return panels, names, hasattr(bpy.types.Scene, "snell")


def test_unregister_leaves_blender_clean_and_register_again_works(blends):
    panels, _, has_prop = _snell_traces()
    assert "DATA_PT_lens" in panels and "DATA_PT_camera_dof" in panels and "RENDER_PT_format" in panels
    assert "EEVEE_MATERIAL_PT_surface" in panels and "EEVEE_WORLD_PT_surface" in panels
    assert has_prop
    registration.unregister()
    try:
        assert _snell_traces() == ([], [], False)
        assert not registration.is_registered()
        with pytest.raises(TypeError):
            bpy.context.scene.render.engine = "SNELL"
    finally:
        registration.register()
    assert registration.is_registered() and hasattr(bpy.types.Scene, "snell")
    scene = open_scene(blends / "cornell.blend")
    assert scene.render.engine == "SNELL"
    assert (scene.snell.spp, scene.snell.seed, scene.snell.max_depth) == (8, 5, 6)


def test_settings_tooltips_and_defaults():
    props = bpy.types.Scene.bl_rna.properties["snell"].fixed_type.properties
    assert "max_bounces = Max Depth - 1" in props["max_depth"].description
    assert [i.identifier for i in props["fresnel"].enum_items] == ["EXACT", "SCHLICK"]
    assert props["fresnel"].default == "EXACT"
    assert {"spp", "max_depth", "seed", "threads", "fresnel"} <= set(props.keys())


def test_the_properties_are_the_schemas():
    """One Blender property per setting Blender shows, with the schema's description, default,
    range and choices; none for the estimator switches."""
    from snell.tracer.settings import ESTIMATOR, RUN, SCENE, VIEWPORT, of_scope
    props = bpy.types.Scene.bl_rna.properties["snell"].fixed_type.properties
    for s in of_scope(SCENE, RUN, VIEWPORT):
        prop = props[s.name]
        assert prop.description == s.doc, s.name
        if s.type is str:
            assert [i.identifier.lower() for i in prop.enum_items] == list(s.values)
            assert prop.default == s.default.upper()
            continue
        assert prop.default == pytest.approx(s.default), s.name
        if s.type is not bool:
            # Blender keeps float limits as 32-bit floats (filter_width's 0.01).
            assert prop.hard_min == pytest.approx(s.least, rel=1e-7), s.name
            assert prop.hard_max == pytest.approx(s.greatest if s.greatest is not None
                                                  else prop.hard_max, rel=1e-7)
    for s in of_scope(ESTIMATOR):
        assert s.name not in props


class Layout:
    """Records what a panel draws: (property, label) of every prop() in any row or column."""

    def __init__(self, drawn=None):
        self.drawn = [] if drawn is None else drawn

    def column(self, **options):
        return Layout(self.drawn)

    row = column

    def prop(self, data, name, text=None, **options):
        self.drawn.append((name, text))

    def label(self, text="", **options):
        self.drawn.append(("label", text))


SNELL_SAMPLING = dict(noise_threshold=0.01, spp=1024, min_spp=0)
CYCLES_SAMPLING = dict(samples=64, adaptive_threshold=0.01, adaptive_min_samples=0, seed=0,
                       use_animated_seed=False)


@pytest.mark.parametrize("follow, adaptive, drawn", [
    (False, True, [("use_cycles_settings", None), ("use_adaptive_sampling", ""),
                   ("noise_threshold", ""), ("spp", "Max Samples"), ("min_spp", "Min Samples"),
                   ("time_limit", None), ("seed", None)]),
    (False, False, [("use_cycles_settings", None), ("use_adaptive_sampling", ""),
                    ("noise_threshold", ""), ("spp", "Samples"), ("time_limit", None),
                    ("seed", None)]),
    # Following Cycles: Cycles' own properties, and why 64 samples do not sample adaptively.
    (True, True, [("use_cycles_settings", None), ("use_adaptive_sampling", ""),
                  ("adaptive_threshold", ""), ("samples", "Max Samples"),
                  ("adaptive_min_samples", "Min Samples"),
                  ("label", "Automatic minimum 64: no adaptive saving"), ("time_limit", None),
                  ("seed", None), ("use_animated_seed", ""),
                  ("label", "Not rendered by Snell: light tree, path guiding")]),
])
def test_sampling_panel_is_laid_out_as_cycles(follow, adaptive, drawn):
    """Follow Cycles' Settings, then Noise Threshold's checkbox and value, Max and Min Samples
    (Samples when off), Time Limit and Seed: Snell's own properties, or Cycles' when following."""
    props = bpy.types.Scene.bl_rna.properties["snell"].fixed_type.properties
    assert (props["use_adaptive_sampling"].default, props["noise_threshold"].default,
            props["min_spp"].default, props["use_cycles_settings"].default) == \
        (True, pytest.approx(0.01), 0, True)
    panel = types.SimpleNamespace(layout=Layout())
    panel.column = lambda **options: ui.SnellPanel.column(panel, **options)
    context = types.SimpleNamespace(scene=types.SimpleNamespace(
        snell=types.SimpleNamespace(use_adaptive_sampling=adaptive, use_cycles_settings=follow,
                                    **SNELL_SAMPLING),
        cycles=types.SimpleNamespace(use_adaptive_sampling=adaptive, **CYCLES_SAMPLING)))
    ui.RENDER_PT_snell_sampling.draw(panel, context)
    assert panel.layout.drawn == drawn


# ---------------------------------------------------------------------------------------------
# F12


def test_f12_render_matches_the_tracer_and_updates_progressively(blends, tmp_path, small_passes):
    scene = open_scene(blends / "cornell.blend", tmp_path / "f12.exr")
    calls = []
    with spying(recording(calls)):
        bpy.ops.render.render(write_still=True)
    record = dict(final.last_render)
    assert record["error"] is None and not record["cancelled"]
    assert record["spp"] == 8 and record["passes"] == 8
    assert sum(c[0] == "result" for c in calls) == 8
    progress = [c[1] for c in calls if c[0] == "progress"]
    assert progress == pytest.approx([k / 8 for k in range(1, 9)])
    stats = [c[1] for c in calls if c[0] == "stats"]
    assert any("Sample 3/8" in s and "Remaining" in s and "M rays/s" in s for s in stats), stats
    assert "Done: 8/8 samples" in stats[-1]
    written = read_exr(tmp_path / "f12.exr")
    assert written.shape == (SIZE, SIZE, 3)
    # The same exporter and tracer with the same seed: the same image, rows the same way up.
    np.testing.assert_allclose(written, tracer_image(), rtol=1e-6, atol=1e-7)
    assert written[0].mean() > 1.5 * written[-1].mean() or written[: SIZE // 4].max() > 1.0  # lamp at the top


def test_f12_adaptive_progress_status_and_sample_count_pass(blends, tmp_path):
    """Noise threshold on: the bar follows samples over the budget, the status says how many
    pixels still sample and, at the end, how many samples were saved; the Sample Count pass
    holds the tracer's own counts (rows bottom first)."""
    scene = open_scene(blends / "cornell.blend", tmp_path / "adaptive.exr")
    # A minimum that is no multiple of the 16-sample windows: the first check comes after the
    # third window (48), while the bar moves window by window.
    scene.snell.spp, scene.snell.noise_threshold, scene.snell.min_spp = 256, 0.05, 40
    calls, counts = [], []
    with spying(recording(calls, lambda r: counts.append(sample_count_pass(r).reshape(SIZE, SIZE)))):
        bpy.ops.render.render(write_still=True)
    record = dict(final.last_render)
    assert record["error"] is None and record["adaptive"].startswith("adaptive 0.05: ")
    progress = [c[1] for c in calls if c[0] == "progress"]
    assert progress[0] == pytest.approx(16 / 256) and progress == sorted(progress)
    stats = [c[1] for c in calls if c[0] == "stats"]
    assert any("Sample 64/256 | " in s and "% of pixels sampling | " in s for s in stats), stats
    assert stats[-1].endswith(record["adaptive"]) and "% of samples saved" in stats[-1]
    exported, _ = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    expected = Renderer(exported).render().samples()
    assert expected.min() == 48 and expected.max() > 48 and record["saved_share"] > 0.3
    assert np.array_equal(counts[-1], expected[::-1])


def test_f12_keeps_the_last_pass_when_every_pixel_converges(blends, tmp_path):
    """A threshold so high that every pixel stops at the minimum: the last (and only) pass still
    reaches the image and the Sample Count pass (the integrator calls back after it too)."""
    scene = open_scene(blends / "cornell.blend", tmp_path / "converged.exr")
    scene.snell.spp, scene.snell.noise_threshold, scene.snell.min_spp = 64, 0.5, 4
    counts = []
    with spying(recording([], lambda r: counts.append(sample_count_pass(r)))):
        bpy.ops.render.render(write_still=True)
    # The minimum rounded up to a window of each half: 32.
    assert final.last_render["spp"] == 32 and np.all(counts[-1] == 32)
    np.testing.assert_allclose(read_exr(tmp_path / "converged.exr"), tracer_image(),
                               rtol=1e-6, atol=1e-7)


def test_esc_after_the_first_pass_keeps_that_pass(blends, tmp_path, small_passes):
    scene = open_scene(blends / "cornell.blend", tmp_path / "cancel.exr")
    scene.snell.spp = 64
    passes = []

    class CancelAfterFirstPass(Spy):
        def update_result(self, result):
            passes.append(time.perf_counter())
            self.engine.update_result(result)

        def test_break(self):
            return len(passes) >= 1

    with spying(CancelAfterFirstPass):
        start = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        elapsed = time.perf_counter() - start
    record = dict(final.last_render)
    assert record["cancelled"] and record["spp"] == 1 and len(passes) == 1
    assert record["error"] is None
    assert elapsed - (passes[0] - start) < 1.0  # stopped right after the pass
    written = read_exr(tmp_path / "cancel.exr")
    # The stratified sampler orders a pixel's samples by the render's total count, so the first
    # pass of a 64-sample render is compared with the tracer's own 64-sample render stopped there.
    np.testing.assert_allclose(written, tracer_image(spp=64, passes=1), rtol=1e-6, atol=1e-7)


def test_border_crop_and_resolution_percentage(blends, tmp_path):
    scene = open_scene(blends / "cornell.blend", tmp_path / "border.exr")
    scene.snell.spp = 2
    scene.render.resolution_percentage = 50
    bpy.ops.render.render(write_still=True)
    assert read_exr(tmp_path / "border.exr").shape == (SIZE // 2, SIZE // 2, 3)
    scene.render.resolution_percentage = 100
    scene.render.use_border = True
    scene.render.border_min_x, scene.render.border_max_x = 0.25, 0.75
    scene.render.border_min_y, scene.render.border_max_y = 0.5, 1.0
    scene.render.use_crop_to_border = True
    bpy.ops.render.render(write_still=True)
    assert read_exr(tmp_path / "border.exr").shape == (SIZE // 2, SIZE // 2, 3)
    scene.render.use_crop_to_border = False
    bpy.ops.render.render(write_still=True)
    full = read_exr(tmp_path / "border.exr")
    assert full.shape == (SIZE, SIZE, 3)
    inside = full[: SIZE // 2, SIZE // 4: 3 * SIZE // 4]  # top half (EXR rows top first), middle
    assert inside.mean() > 0.05
    outside = full.copy()
    outside[: SIZE // 2, SIZE // 4: 3 * SIZE // 4] = 0
    assert outside.max() == 0.0


@pytest.mark.parametrize("ortho", [False, True])
def test_window_camera_sees_the_same_pixels_as_the_full_frame(ortho):
    """Exact: an emissive quad whose edges fall on pixel boundaries (pixels are 0 or 1).

    With lens 50, sensor 36 (AUTO fit, 12x8) and the shifts below, the view on the plane z = -1
    spans x in [-0.18, 0.54] and y in [-0.276, 0.204] in 0.06 pixels: the quad's edges x = 0 and
    y = 0.024 (0.048 at z = -2) are pixel boundaries. Orthographic of scale 0.72: the same
    window on every plane."""
    from snell.tracer.scene import Scene
    y = 0.024 if ortho else 0.048
    positions = np.array([[0, y, -2], [2, y, -2], [2, 2, -2], [0, 2, -2]], np.float32)
    cam = {"name": "Camera", "matrix": np.eye(4).tolist(), "lens": 50.0, "sensor_width": 36.0,
           "sensor_height": 24.0, "sensor_fit": "AUTO", "shift_x": 0.25, "shift_y": -0.05,
           "clip_start": 0.1, "clip_end": 100.0, "resolution": [12, 8],
           "resolution_percentage": 100, "pixel_aspect": [1.0, 1.0],
           "dof": {"use_dof": False, "focus_distance": 10.0, "fstop": 2.8, "blades": 0,
                   "rotation": 0.0, "ratio": 1.0}}
    if ortho:
        cam.update(type="ORTHO", ortho_scale=0.72)
    scene = Scene(positions=positions, triangles=np.array([[0, 1, 2], [0, 2, 3]], np.int32),
                  material_ids=np.zeros(2, np.int32), object_ids=np.zeros(2, np.int32),
                  objects=[{"name": "Quad", "closed": False}],
                  materials=[{"name": "L", "kind": "emission", "color": [1, 1, 1], "strength": 1.0}],
                  lights=[], camera=cam, render={"spp": 16, "max_depth": 1, "seed": 0, "fresnel": "exact"})
    full = Renderer(scene).render().mean()
    x0, y0, w, h = window.border_pixels(12, 8, (0.25, 0.75, 0.25, 1.0))
    assert (x0, y0, w, h) == (3, 2, 6, 6)
    part = Renderer(scene.with_camera(**window.window_camera(cam, x0, y0, w, h))).render().mean()
    # Rows are top first: window rows from the bottom y0..y0+h are full rows H-y0-h..H-y0.
    assert set(np.unique(full)) == {0.0, 1.0}
    np.testing.assert_array_equal(part, full[8 - y0 - h: 8 - y0, x0: x0 + w])
    assert 0 < part.mean() < 1


# ---------------------------------------------------------------------------------------------
# Bad input


def test_unsupported_node_warns_and_renders_the_fallback(blends, tmp_path):
    scene = open_scene(blends / "unsupported.blend", tmp_path / "toon.exr")
    bpy.ops.render.render(write_still=True)
    warnings = final.last_render["warnings"]
    assert any("'Toon BSDF' (a toon surface), which Snell does not render" in w
               for w in warnings), warnings
    assert final.last_render["error"] is None
    assert read_exr(tmp_path / "toon.exr").mean() > 0


def test_no_camera_is_a_clear_error(blends, tmp_path):
    open_scene(blends / "nocamera.blend", tmp_path / "nocam.exr")
    with pytest.raises(RuntimeError, match="(?i)no camera"):
        bpy.ops.render.render(write_still=True)
    assert not (tmp_path / "nocam.exr").exists()


def test_export_failure_is_one_message_and_no_image(blends, tmp_path):
    open_scene(blends / "pano.blend", tmp_path / "pano.exr")
    with pytest.raises(RuntimeError, match="Snell: cannot render this scene: camera .*PANO"):
        bpy.ops.render.render(write_still=True)
    assert "perspective and orthographic" in final.last_render["error"]
    assert not (tmp_path / "pano.exr").exists()


def test_empty_scene_renders_black_with_a_warning(blends, tmp_path):
    open_scene(blends / "empty.blend", tmp_path / "empty.exr")
    bpy.ops.render.render(write_still=True)
    assert any("no geometry" in w for w in final.last_render["warnings"])
    image = read_exr(tmp_path / "empty.exr")
    assert image.shape == (SIZE, SIZE, 3) and image.max() == 0.0


# ---------------------------------------------------------------------------------------------
# Headless batch renders


def snell_cli(*args):
    return subprocess.run([sys.executable, "-m", "snell.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=600)


def test_batch_renders_one_image_per_frame(blends, tmp_path):
    proc = snell_cli("batch", blends / "animated.blend", "--frames", "1-3", "-o", tmp_path / "anim_####.exr")
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.startswith("snell: frame")]
    assert len(lines) == 3 and all("8 spp" in line for line in lines), proc.stderr
    images = [read_exr(tmp_path / f"anim_{f:04d}.exr") for f in (1, 2, 3)]
    for a, b in ((0, 1), (1, 2), (0, 2)):
        assert np.abs(images[a] - images[b]).mean() > 1e-3
    assert proc.stdout == ""  # Blender's chatter stays out of stdout


def test_batch_on_dask_workers_writes_the_local_images(blends, tmp_path):
    """`snell batch --workers 2`: each frame rendered adaptively on two Dask worker processes,
    the same EXRs (and sample counts) as without them, bit for bit."""
    pytest.importorskip("distributed")
    args = ("batch", blends / "animated.blend", "--frames", "1-2", "--spp", "32",
            "--noise-threshold", "0.1", "--min-spp", "4")
    local = snell_cli(*args, "-o", tmp_path / "local_####.exr")
    farm = snell_cli(*args, "-o", tmp_path / "farm_####.exr", "--workers", "2")
    assert local.returncode == 0 and farm.returncode == 0, farm.stderr
    assert "snell: rendering on 2 Dask workers" in farm.stderr
    assert "Traceback" not in farm.stderr
    for frame in (1, 2):
        a, b = (read_exr(tmp_path / f"{name}_{frame:04d}.exr") for name in ("local", "farm"))
        assert np.array_equal(a, b), f"frame {frame} differs"
    assert not np.array_equal(read_exr(tmp_path / "farm_0001.exr"),
                              read_exr(tmp_path / "farm_0002.exr"))


def test_batch_png_goes_through_colour_management(blends, tmp_path):
    proc = snell_cli("batch", blends / "cornell.blend", "-o", tmp_path / "still_####.png")
    assert proc.returncode == 0, proc.stderr
    img = oiio.ImageBuf(str(tmp_path / "still_0001.png"))
    assert img.spec().format == oiio.UINT8 and img.spec().width == SIZE


def test_batch_setting_options_reach_the_engine(blends, tmp_path):
    """--noise-threshold and --min-spp reach the engine (a copy of the file with 64 samples, no
    minimum set), and the frame line says what adaptive sampling saved; settings reach the render
    without being written into the file's properties, and only while the frames render."""
    open_scene(blends / "cornell.blend", tmp_path / "unused.exr").snell.spp = 64
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "cornell64.blend"), copy=True)
    proc = snell_cli("batch", tmp_path / "cornell64.blend", "-o", tmp_path / "a_####.exr",
                     "--noise-threshold", "0.05", "--min-spp", "4")
    assert proc.returncode == 0, proc.stderr
    line = next(line for line in proc.stderr.splitlines() if line.startswith("snell: frame"))
    assert "adaptive 0.05: " in line and ", 64 max, " in line and "% of samples saved in " in line
    from snell.addon import batch, final
    status = batch.run(str(tmp_path / "cornell64.blend"), output=str(tmp_path / "b_####.exr"),
                       stream=io.StringIO(), settings={"spp": 8, "noise_threshold": 0.0})
    assert status == 0 and final.last_render["spp"] == 8 and final.overrides == {}
    props = bpy.context.scene.snell
    assert (props.spp, props.use_adaptive_sampling) == (64, True)
    assert props.noise_threshold == pytest.approx(0.01)


def cycles_configured(blends, tmp_path):
    """cornell.blend following its Cycles settings, set to non-default ones: 3 samples (no
    adaptive sampling), max bounces 2 (max depth 3), seed 11."""
    scene = open_scene(blends / "cornell.blend", tmp_path / "f12.exr")
    scene.snell.use_cycles_settings = True
    c = scene.cycles
    c.samples, c.use_adaptive_sampling, c.max_bounces, c.seed = 3, False, 2, 11
    path = tmp_path / "follow.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    return scene, path


def test_f12_snell_render_and_batch_follow_the_files_cycles_settings(blends, tmp_path):
    """The same file's Cycles samples, bounces and seed in F12, `snell render` and `snell batch`;
    the same image from each, and the same EXR channels from render and batch."""
    scene, path = cycles_configured(blends, tmp_path)
    exported, _ = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert {k: exported.render[k] for k in ("spp", "max_depth", "seed", "noise_threshold")} == \
        {"spp": 3, "max_depth": 3, "seed": 11, "noise_threshold": 0.0}
    bpy.ops.render.render(write_still=True)
    assert final.last_render["spp"] == 3 and final.last_render["error"] is None
    f12 = read_exr(tmp_path / "f12.exr")
    np.testing.assert_allclose(f12, tracer_image(), rtol=1e-6, atol=1e-7)
    # Another seed in Cycles' panel is another image: the comparison above could fail.
    scene.cycles.seed = 12
    assert np.abs(tracer_image() - f12).max() > 1e-3

    proc = snell_cli("render", path, "-o", tmp_path / "cli.exr")
    assert proc.returncode == 0, proc.stderr
    assert "3 spp" in proc.stdout, proc.stdout
    np.testing.assert_allclose(read_exr(tmp_path / "cli.exr"), f12, rtol=1e-5, atol=1e-6)

    proc = snell_cli("batch", path, "-o", tmp_path / "b_####.exr")
    assert proc.returncode == 0, proc.stderr
    assert "3 spp" in proc.stderr, proc.stderr
    batch_exr = tmp_path / f"b_{scene.frame_current:04d}.exr"
    np.testing.assert_allclose(read_exr(batch_exr), f12, rtol=1e-5, atol=1e-6)
    channels = [oiio.ImageInput.open(str(p)).spec().channelnames
                for p in (tmp_path / "cli.exr", batch_exr)]
    assert channels[0] == channels[1] == ("R", "G", "B", "samples"), channels


def test_f12_snell_render_and_batch_write_the_same_alpha(blends, tmp_path):
    """Film > Transparent (the camera pulled back so that the world shows around the box): the
    same alpha in F12's still, `snell render`'s EXR and `snell batch`'s, clear around the box
    and opaque on it; render and batch write the same channels (R, G, B, A, samples)."""
    scene, _ = cycles_configured(blends, tmp_path)
    scene.render.film_transparent = True
    scene.render.image_settings.color_mode = "RGBA"
    scene.camera.location = tuple(3.0 * v for v in scene.camera.location)
    path = tmp_path / "clear.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    bpy.ops.render.render(write_still=True)
    assert final.last_render["error"] is None
    f12 = read_channel(str(tmp_path / "f12.exr"), "A")
    assert f12.min() == 0.0 and f12.max() == 1.0
    assert snell_cli("render", path, "-o", tmp_path / "cli.exr").returncode == 0
    proc = snell_cli("batch", path, "-o", tmp_path / "b_####.exr")
    assert proc.returncode == 0, proc.stderr
    batch_exr = tmp_path / f"b_{scene.frame_current:04d}.exr"
    for other in (tmp_path / "cli.exr", batch_exr):
        np.testing.assert_allclose(read_channel(str(other), "A"), f12, atol=1e-6)
        assert oiio.ImageInput.open(str(other)).spec().channelnames == \
            ("R", "G", "B", "A", "samples")


def test_f12_follows_cycles_denoise_and_keeps_the_noisy_image_as_a_pass(blends, tmp_path):
    """Cycles' Denoise on: F12 writes the denoised image as Combined (and the still), the
    tracer's own image as the Noisy Image pass, and the Denoising Albedo and Normal passes."""
    scene, _ = cycles_configured(blends, tmp_path)
    c = scene.cycles
    c.use_denoising, c.denoising_prefilter, c.denoising_quality = True, "FAST", "FAST"
    exported, _ = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    assert (exported.render["denoise"], exported.render["denoising_prefilter"],
            exported.render["denoising_quality"]) == (True, "fast", "fast")
    grabbed = {}
    names = ("Combined", "Noisy Image", "Denoising Albedo", "Denoising Normal")
    with spying(recording([], pass_grabber(names, grabbed))):
        bpy.ops.render.render(write_still=True)
    layers = {name: rect[:, :, :3] for name, rect in grabbed.items()}
    record = final.last_render
    assert record["error"] is None and record["denoised"], record
    noisy = tracer_image()
    np.testing.assert_allclose(layers["Noisy Image"], noisy, rtol=1e-6, atol=1e-7)
    f12 = read_exr(tmp_path / "f12.exr")
    np.testing.assert_allclose(f12, layers["Combined"], rtol=1e-6, atol=1e-6)
    assert np.abs(f12 - noisy).max() > 1e-3          # the still is the denoised image
    assert layers["Denoising Albedo"].max() > 0.1 and np.abs(layers["Denoising Normal"]).max() > 0.5


def test_f12_fills_the_data_passes_the_view_layer_asks_for(blends, tmp_path):
    """View Layer > Passes > Data: Z, Normal, Position and Object Index switched on are passes
    of F12's result, the values tracer/data_passes.py makes for the scene and camera."""
    from snell.tracer.data_passes import data_passes
    scene, _ = cycles_configured(blends, tmp_path)
    layer = scene.view_layers[0]
    layer.use_pass_z = layer.use_pass_normal = layer.use_pass_position = True
    layer.use_pass_object_index = True
    layers = {}
    with spying(recording([], pass_grabber(("Depth", "Normal", "Position", "Object Index"),
                                           layers))):
        bpy.ops.render.render(write_still=True)
    assert final.last_render["error"] is None and set(layers) == {"Depth", "Normal",
                                                                  "Position", "Object Index"}
    exported, _ = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    expected = data_passes(Renderer(exported, exported.settings(threads=1)), list(layers))
    for name, values in layers.items():
        np.testing.assert_allclose(values, expected[name], rtol=1e-6, atol=1e-6)
    assert layers["Depth"].min() > 0.0 and np.abs(layers["Normal"]).max() > 0.9


def test_batch_spp_threads_and_scale_options(blends, tmp_path):
    """--spp and --threads over the file's settings, --scale its resolution percentage."""
    _, path = cycles_configured(blends, tmp_path)
    proc = snell_cli("batch", path, "-o", tmp_path / "s_####.exr", "--spp", "2", "--threads", "1",
                     "--scale", "50")
    assert proc.returncode == 0, proc.stderr
    assert "2 spp" in proc.stderr, proc.stderr
    out = next(tmp_path.glob("s_*.exr"))
    assert read_exr(out).shape == (SIZE // 2, SIZE // 2, 3)
    from snell.tracer.image import read_channel
    assert np.all(read_channel(out, "samples") == 2)


def test_a_snell_override_wins_only_when_asked(blends, tmp_path):
    """Follow Cycles' Settings off: Snell's own samples (8), not Cycles' (3)."""
    scene, _ = cycles_configured(blends, tmp_path)
    scene.snell.use_cycles_settings = False
    bpy.ops.render.render(write_still=True)
    assert final.last_render["spp"] == 8


def test_batch_failing_frames_exit_non_zero(blends, tmp_path):
    proc = snell_cli("batch", blends / "nocamera.blend", "--frames", "1,2", "-o", tmp_path / "x_####.exr")
    assert proc.returncode == 1
    assert proc.stderr.count("FAILED") == 2 and "camera" in proc.stderr
    proc = snell_cli("batch", blends / "cornell.blend", "--frames", "3-1", "-o", tmp_path / "x.exr")
    # a bad option: status 2, as for every command
    assert proc.returncode == 2 and "snell: error: argument --frames" in proc.stderr
    proc = snell_cli("batch", tmp_path / "missing.blend")
    assert proc.returncode == 1 and "no such file" in proc.stderr


# ---------------------------------------------------------------------------------------------
# bpy (with its own libembree4) and embreex in one process


def test_cycles_and_snell_alternate_in_one_process(blends, tmp_path):
    images = {}
    for i, engine in enumerate(["CYCLES", "SNELL", "CYCLES", "SNELL"]):
        scene = open_scene(blends / "cornell.blend", tmp_path / f"{i}.exr")
        scene.render.engine = engine
        scene.cycles.samples, scene.cycles.seed = 8, 5
        scene.render.threads_mode, scene.render.threads = "FIXED", 2
        bpy.ops.render.render(write_still=True)
        images.setdefault(engine, []).append(read_exr(tmp_path / f"{i}.exr"))
    for engine, (first, second) in images.items():
        np.testing.assert_array_equal(first, second, err_msg=engine)
    cycles, snell_img = images["CYCLES"][0].mean(), images["SNELL"][0].mean()
    assert 0.75 < snell_img / cycles < 1.33, (snell_img, cycles)
