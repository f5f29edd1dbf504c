"""The viewport's Rendered mode, headless: camera mapping, update classification, the render
session with a real renderer, and view_update / view_draw with stand-ins for the region and gpu.

Blender never calls the viewport callbacks in background mode and its gpu module refuses to
draw there, so the engine's callbacks are called as unbound functions with a stand-in engine,
context and drawing module.
"""
import os
import threading
import time
import types

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from snell.addon import engine as engine_mod  # noqa: E402
from snell.addon import registration, view_camera, view_draw, view_session, viewport  # noqa: E402
from snell.addon.export import export_depsgraph  # noqa: E402
from snell.addon.view_camera import ViewUnsupported, camera_from_view  # noqa: E402
from snell.addon.view_export import LiveExport  # noqa: E402
from snell.addon.view_updates import classify, full, snapshot  # noqa: E402
from snell.tracer.camera import Camera  # noqa: E402
from snell.tracer.settings import LIGHT_PATHS_PER_CAMERA_PATH  # noqa: E402
from snell.tracer.integrator import Renderer  # noqa: E402

from support.paths import ROOT  # noqa: E402
SPHERES = os.path.join(ROOT, "scenes", "cornell_spheres.blend")


@pytest.fixture(scope="module", autouse=True)
def registered():
    registration.ensure_registered()
    yield


def evaluated():
    """The current file's evaluated depsgraph."""
    return bpy.context.evaluated_depsgraph_get()


def open_spheres():
    bpy.ops.wm.open_mainfile(filepath=SPHERES)
    bpy.context.scene.render.engine = "SNELL"
    return bpy.context.scene


def matrices(cam_obj, width, height):
    """(view matrix, window matrix) of a camera for a width x height frame, as numpy."""
    depsgraph = evaluated()
    window = np.array(cam_obj.calc_matrix_camera(depsgraph, x=width, y=height))
    return np.array(cam_obj.matrix_world.inverted()), window


def pixel_centres_land(camera, view, window, through_focus=None):
    """Where window @ view projects points on the camera's pixel-centre rays, minus the pixel
    centres (raster units, y from the bottom); through_focus: lens samples and focus distance."""
    cam = Camera(camera)
    w, h = cam.width, cam.height
    pixel = np.arange(w * h)
    half = np.full((2, len(pixel)), 0.5)
    lens = None
    if through_focus is not None:
        lens = np.random.default_rng(1).random((2, len(pixel)))
    o, d, _ = cam.generate(pixel, half, lens)
    if through_focus is None:
        points = o + 3.0 * d
    else:
        # Every lens ray meets its pixel's pinhole ray on the focus plane (view-space depth).
        axis = -cam.rotation[:, 2]
        depth = (through_focus - (o.T - cam.position) @ axis) / (d.T @ axis)
        points = o + depth * d
    clip = window @ view @ np.vstack([points, np.ones(len(pixel))])
    ndc = clip[:2] / clip[3]
    col, row = pixel % w, pixel // w
    x = (ndc[0] + 1.0) * 0.5 * w - (col + 0.5)
    y = (ndc[1] + 1.0) * 0.5 * h - ((h - 1 - row) + 0.5)
    return np.abs(np.concatenate([x, y])).max()


# ---------------------------------------------------------------------------------------------
# The viewport camera


@pytest.mark.parametrize("kind, fit, shift, size", [
    ("PERSP", "AUTO", (0.0, 0.0), (48, 27)),
    ("PERSP", "VERTICAL", (0.13, -0.21), (31, 40)),   # an off-centre window, as camera-view offsets
    ("PERSP", "HORIZONTAL", (-0.3, 0.05), (64, 20)),
    ("ORTHO", "AUTO", (0.0, 0.0), (48, 27)),
    ("ORTHO", "VERTICAL", (0.13, -0.21), (31, 40)),
])
def test_rays_through_pixel_centres_land_where_the_matrices_project_them(kind, fit, shift, size):
    scene = open_spheres()
    cam = scene.camera
    cam.data.type = kind
    cam.data.sensor_fit, (cam.data.shift_x, cam.data.shift_y) = fit, shift
    cam.rotation_euler.z += 0.3                  # not axis-aligned
    view, window = matrices(cam, *size)
    camera = camera_from_view(view, window, *size, lens=cam.data.lens)
    assert camera.get("type", "PERSP") == kind
    # Blender's matrices are float32: a thousandth of a pixel is far below any error that
    # matters, and far above what float32 leaves.
    assert pixel_centres_land(camera, view, window) < 2e-3


def test_camera_view_with_depth_of_field_focuses_where_the_camera_does():
    scene = open_spheres()
    cam = scene.camera
    cam.data.dof.use_dof, cam.data.dof.focus_distance, cam.data.dof.aperture_fstop = True, 3.0, 0.5
    view, window = matrices(cam, 40, 30)
    dof = {"use_dof": True, "focus_distance": 3.0, "fstop": 0.5, "aperture_radius": 0.05}
    camera = camera_from_view(view, window, 40, 30, lens=cam.data.lens, dof=dof)
    assert pixel_centres_land(camera, view, window, through_focus=3.0) < 2e-3
    # Off the focus plane the lens rays spread: the check can fail.
    assert pixel_centres_land(camera, view, window, through_focus=2.0) > 0.1


def test_camera_view_at_the_render_size_is_the_f12_camera():
    scene = open_spheres()
    scene.camera.data.shift_x = 0.1
    depsgraph = evaluated()
    final, _ = export_depsgraph(depsgraph)
    w, h = Camera(final.camera).width, Camera(final.camera).height
    view, window = matrices(scene.camera, w, h)
    mine = Camera(camera_from_view(view, window, w, h, lens=final.camera["lens"]))
    theirs = Camera(final.camera)
    pixel = np.arange(w * h)[::7]
    u = np.random.default_rng(2).random((2, len(pixel)))
    (o1, d1, _), (o2, d2, _) = mine.generate(pixel, u, None), theirs.generate(pixel, u, None)
    assert np.abs(d1 - d2).max() < 1e-6 and np.abs(o1 - o2).max() < 1e-6


def test_the_viewports_orthographic_clip_range_starts_behind_the_view():
    """Blender's orthographic views clip from -clip_end / 2 to clip_end / 2 (Cycles' too)."""
    scene = open_spheres()
    scene.camera.data.type = "ORTHO"
    view, window = matrices(scene.camera, 40, 30)
    window[2, 2], window[2, 3] = -2.0 / 100.0, 0.0          # near -50, far 50
    camera = camera_from_view(view, window, 40, 30)
    assert (camera["clip_start"], camera["clip_end"]) == (pytest.approx(-50.0), pytest.approx(50.0))
    assert pixel_centres_land(camera, view, window) < 2e-3


def test_views_snell_cannot_render_say_so():
    with pytest.raises(ViewUnsupported, match="neither perspective nor orthographic"):
        camera_from_view(np.eye(4), np.diag([1.0, 1.0, 1.0, 2.0]), 40, 30)


def test_coarse_cameras_keep_the_window():
    scene = open_spheres()
    view, window = matrices(scene.camera, 101, 37)
    camera = camera_from_view(view, window, 101, 37)
    full_cam, coarse = Camera(camera), Camera(view_camera.scaled(camera, 8))
    assert (coarse.width, coarse.height) == (12, 4)
    assert coarse.half_x == pytest.approx(full_cam.half_x, rel=1e-12)
    assert coarse.half_y == pytest.approx(full_cam.half_y, rel=1e-12)


# ---------------------------------------------------------------------------------------------
# depsgraph.updates -> what to redo


@pytest.fixture
def captured():
    """The depsgraph updates of each edit, captured with a depsgraph_update_post handler, in
    cornell_spheres (opened first: loading a file drops the handlers)."""
    open_spheres()
    log = []

    def handler(scene, depsgraph):
        log.extend(snapshot(depsgraph))

    def edit(change):
        log.clear()
        change()
        bpy.context.view_layer.update()
        return list(log)

    bpy.app.handlers.depsgraph_update_post.append(handler)
    yield edit
    if handler in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(handler)


def move_glass():
    bpy.data.objects["GlassSphere"].location.z += 0.1


def edit_glass_mesh():
    mesh = bpy.data.objects["GlassSphere"].data
    mesh.vertices[0].co.z += 0.02
    mesh.update()


def set_glass_ior():
    bpy.data.materials["Glass"].node_tree.nodes["Glass BSDF"].inputs["IOR"].default_value = 1.33


def set_fstop():
    bpy.data.cameras[0].dof.aperture_fstop = 1.4


def test_real_updates_are_classified_into_the_least_work(captured):
    moved = classify(captured(move_glass))
    assert (moved.restart(), moved.transform) == ("transform", {"GlassSphere"})
    assert not moved.geometry
    edited = classify(captured(edit_glass_mesh))
    assert (edited.restart(), edited.geometry) == ("geometry", {"GlassSphere"})
    shaded = classify(captured(set_glass_ior))
    assert shaded.restart() == "tables" and shaded.materials and not shaded.lights
    assert not shaded.geometry and not shaded.transform
    focused = classify(captured(set_fstop))
    assert focused.restart() == "camera" and not focused.content

    def add_lamp():
        lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
        bpy.context.scene.collection.objects.link(lamp)

    added = classify(captured(add_lamp))
    assert added.settings and added.restart() == "tables"     # the objects walk again
    lamp = classify(captured(lambda: setattr(bpy.data.lights["Lamp"], "energy", 50.0)))
    assert lamp.lights and lamp.restart() == "tables" and not lamp.materials
    lamp_object = bpy.data.objects["Lamp"]
    moved_lamp = classify(captured(lambda: setattr(lamp_object, "location", (0, 0, 1.5))))
    assert moved_lamp.lights and moved_lamp.restart() == "tables"   # lamps are not in the BVH
    bpy.context.scene.world = bpy.data.worlds.new("World")
    bpy.context.view_layer.update()
    world = classify(captured(lambda: setattr(bpy.context.scene.world, "color", (0.2, 0.2, 0.2))))
    assert world.world and world.restart() == "tables" and not world.geometry


def test_live_export_redoes_only_what_changed_and_equals_a_fresh_export(captured):
    live = LiveExport()
    depsgraph = evaluated()
    first = live.update(depsgraph, full())
    assert len(live.extracted) == 8 and first.geometry_version == 1

    def check(edit, extracted, transformed, version):
        plan = classify(captured(edit))
        content = live.update(evaluated(), plan)
        assert (live.extracted, live.transformed, content.geometry_version) == (
            extracted, transformed, version)
        fresh, _ = export_depsgraph(evaluated())
        for key in ("positions", "normals", "triangles", "material_ids", "object_ids"):
            assert np.array_equal(getattr(content.scene, key), getattr(fresh, key)), key
        assert content.scene.materials == fresh.materials and content.scene.lights == fresh.lights
        return content

    check(move_glass, [], ["GlassSphere"], 2)
    check(edit_glass_mesh, ["GlassSphere"], ["GlassSphere"], 3)
    shaded = check(set_glass_ior, [], [], 3)      # the BVH's arrays stay
    assert shaded.scene.materials[[m["name"] for m in shaded.scene.materials].index("Glass")][
        "ior"] == pytest.approx(1.33)
    assert live.update(evaluated(), classify(captured(set_fstop))) is None


# ---------------------------------------------------------------------------------------------
# The session with a real renderer

REGION = (48, 27)


def viewport_scene(content):
    scene = bpy.context.scene
    view, window = matrices(scene.camera, *REGION)
    camera = camera_from_view(view, window, *REGION)
    return content.with_camera(camera)


def snell_threads():
    return [t for t in threading.enumerate() if t.name == "snell-viewport"]


def test_session_restarts_on_an_edit_and_renders_what_a_fresh_render_does(captured):
    live = LiveExport()
    content = live.update(evaluated(), full())
    session = view_session.ViewSession(threads=2)
    try:
        first = session.submit(viewport_scene(content), content.geometry_version, 4096)
        frame = session.wait(lambda f: f.generation == first and f.divisor == 1, 120)
        assert frame is not None and frame.samples >= 1 and not frame.final
        assert session.refining
        edited = live.update(evaluated(), classify(captured(set_glass_ior)))
        scene = viewport_scene(edited)
        second = session.submit(scene, edited.geometry_version, 6)
        assert second == first + 1
        done = session.wait(lambda f: f.generation == second and f.final, 120)
        assert done is not None and done.samples == 6 and done.stats["bvh_reused"]
        fresh, _ = export_depsgraph(evaluated())
        fresh = fresh.with_camera(**scene.camera).with_render(spp=6, noise_threshold=0.0)
        # The viewport's fixed light share, not a final render's pilot (view_session).
        expected = Renderer(fresh, fresh.settings(
            threads=2, light_paths_per_camera_path=LIGHT_PATHS_PER_CAMERA_PATH)).render().mean()
        assert np.array_equal(done.image, expected)
        # The first generation stopped within a pass: it never finished its 4096 samples.
        assert session.done_generation == second and not session.refining
        # A move: new geometry arrays, a new BVH, and again the fresh render's image.
        moved = live.update(evaluated(), classify(captured(move_glass)))
        third = session.submit(viewport_scene(moved), moved.geometry_version, 2)
        done = session.wait(lambda f: f.generation == third and f.final, 120)
        assert not done.stats["bvh_reused"]
        fresh, _ = export_depsgraph(evaluated())
        fresh = fresh.with_camera(**scene.camera).with_render(spp=2, noise_threshold=0.0)
        # The viewport's fixed light share, not a final render's pilot (view_session).
        expected = Renderer(fresh, fresh.settings(
            threads=2, light_paths_per_camera_path=LIGHT_PATHS_PER_CAMERA_PATH)).render().mean()
        assert np.array_equal(done.image, expected)
    finally:
        assert session.stop(timeout=60)
    assert not snell_threads()


@pytest.fixture
def spheres_session():
    """The spheres' live export and a one-thread session without coarse passes; stopped after
    the test, and no worker thread left."""
    open_spheres()
    content = LiveExport().update(evaluated(), full())
    session = view_session.ViewSession(threads=1, coarse=())
    yield content, session
    assert session.stop(timeout=60)
    assert not snell_threads()


def test_session_reports_a_scene_it_cannot_render_and_goes_on(spheres_session):
    content, session = spheres_session
    bad = viewport_scene(content)
    bad.positions = bad.positions.copy()
    bad.positions[0, 0] = np.nan
    gen = session.submit(bad, 99, 1)
    frame = session.wait(lambda f: f.generation == gen, 60)
    assert frame.final and frame.image is None and "cannot render this scene" in frame.error
    assert "positions" in frame.error
    gen = session.submit(viewport_scene(content), content.geometry_version, 1)
    frame = session.wait(lambda f: f.generation == gen and f.final, 60)
    assert frame.error is None and frame.image.shape == (REGION[1], REGION[0], 3)


def test_time_limit_ends_a_generation(spheres_session):
    content, session = spheres_session
    gen = session.submit(viewport_scene(content), content.geometry_version, 0, 0.3)
    frame = session.wait(lambda f: f.generation == gen and f.final, 60)
    assert frame is not None and 1 <= frame.samples < 100000


def test_viewport_denoises_from_its_start_sample(spheres_session):
    """Sampling > Viewport > Denoise: frames before the start sample are the render's own;
    from it on each frame is the render denoised with the viewport's passes and quality, as
    the final render's denoiser makes it (the same image), and says so."""
    from snell.addon.final import oidn_dirs
    from snell.tracer.denoise import denoise_result
    content, session = spheres_session
    how = view_session.ViewDenoise("albedo", "fast", "fast", 4, tuple(oidn_dirs()))
    scene = viewport_scene(content)
    seen = []
    gen = session.submit(scene, content.geometry_version, 4, denoise=how)
    done = session.wait(lambda f: seen.append(f) or (f.generation == gen and f.final), 120)
    assert done is not None and done.samples == 4
    assert done.stats["denoised"], done.stats
    early = [f for f in seen if f.generation == gen and f.samples < 4]
    assert all(not f.stats.get("denoised") for f in early)
    fresh = scene.with_render(spp=4, noise_threshold=0.0)
    settings = fresh.settings(threads=1, denoising_passes=True, denoising_input_passes="albedo",
                              denoising_prefilter="fast", denoising_quality="fast")
    result = Renderer(fresh, settings).render()
    expected = denoise_result(result, settings, how.oidn_dirs)
    assert expected.denoised
    np.testing.assert_allclose(done.image, expected.image, rtol=1e-5, atol=1e-6)
    assert np.abs(done.image - result.mean()).max() > 1e-3     # not the noisy image


# ---------------------------------------------------------------------------------------------
# view_update / view_draw with a stand-in engine, context and gpu


class StandInEngine:
    """What view_update and view_draw call on the engine, recorded."""

    def __init__(self):
        self.calls = []

    def bind_display_space_shader(self, scene):
        self.calls.append(("bind", scene.name))

    def unbind_display_space_shader(self):
        self.calls.append(("unbind",))

    def tag_redraw(self):
        self.calls.append(("tag_redraw",))

    def update_stats(self, stats, info):
        self.calls.append(("stats", info))

    def report(self, level, message):
        self.calls.append(("report", next(iter(level)), message))


class StandInDrawing:
    """Stands in for view_draw.GpuDrawing: textures are the pixel arrays."""

    def __init__(self):
        self.calls = []

    def texture(self, rgba):
        return rgba

    def draw_texture(self, texture, x, y, width, height):
        self.calls.append(("texture", texture.shape, x, y, width, height))

    def text(self, x, y, lines, size=13.0):
        self.calls.append(("text", " ".join(lines)))


def region_context(cam_obj, size, perspective="PERSP"):
    view, window = matrices(cam_obj, *size)
    return types.SimpleNamespace(
        region=types.SimpleNamespace(width=size[0], height=size[1]),
        region_data=types.SimpleNamespace(view_perspective=perspective, view_matrix=view,
                                          window_matrix=window),
        space_data=types.SimpleNamespace(lens=50.0, camera=None, use_local_camera=False))


def draw_until(engine, context, drawing, predicate, timeout=120):
    end = time.perf_counter() + timeout
    while time.perf_counter() < end:
        engine_mod.SnellRenderEngine.view_draw(engine, context, evaluated())
        if predicate():
            return True
        time.sleep(0.01)
    return False


def test_view_update_and_view_draw_send_and_draw(monkeypatch):
    scene = open_spheres()
    scene.cycles.preview_samples = 3      # the file's Cycles setting, which Snell follows
    drawing = StandInDrawing()
    monkeypatch.setattr(viewport, "DRAWING", drawing)
    monkeypatch.setattr(viewport, "RESIZE_DELAY", 0.0)
    engine, size = StandInEngine(), (40, 24)
    context = region_context(scene.camera, size)
    try:
        engine_mod.SnellRenderEngine.view_update(engine, context, evaluated())
        view = engine._snell_viewport
        assert view.session is None            # no camera until the first draw
        assert draw_until(engine, context, drawing, lambda: view.frame is not None
                          and view.frame.final)
        # Every texture is drawn over the whole region between the display space shader's
        # bind and unbind; coarse passes first (the mailbox keeps only the newest, so a draw
        # may skip one), the full resolution last.
        textures = [c for c in drawing.calls if c[0] == "texture"]
        assert all(c[2:] == (0, 0, 40, 24) for c in textures)
        assert textures[0][1] in ((3, 5, 4), (6, 10, 4), (12, 20, 4))
        assert textures[-1][1] == (24, 40, 4)
        heights = [c[1][0] for c in textures]
        assert heights == sorted(heights)
        i = engine.calls.index(("bind", scene.name))
        assert engine.calls[i + 1] == ("unbind",)
        assert ("tag_redraw",) in engine.calls
        assert any(c[0] == "stats" and "Sample 3/3" in c[1] and "done" in c[1]
                   for c in engine.calls)
        assert view.generations == {1: "first"}

        # Navigation (a new view matrix) restarts the camera only, in view_draw.
        turned = region_context(scene.camera, size)
        turned.region_data.view_matrix = turned.region_data.view_matrix @ _rotation_z(0.2)
        drawing.calls.clear()
        assert draw_until(engine, turned, drawing, lambda: view.frame.generation == 2
                          and view.frame.final)
        assert view.generations[2] == "camera"

        # An edit: view_update, called as Blender calls it (with the depsgraph whose updates
        # list the edit), sends a new generation that keeps the BVH.
        def handler(_, depsgraph):
            engine_mod.SnellRenderEngine.view_update(engine, turned, depsgraph)

        bpy.app.handlers.depsgraph_update_post.append(handler)
        set_glass_ior()
        bpy.context.view_layer.update()
        bpy.app.handlers.depsgraph_update_post.remove(handler)
        assert view.generations[3] == "tables"
        assert draw_until(engine, turned, drawing, lambda: view.frame.generation == 3
                          and view.frame.final)
        assert view.frame.stats["bvh_reused"]

        # An orthographic view renders orthographic.
        scene.camera.data.type = "ORTHO"
        ortho = region_context(scene.camera, size, perspective="ORTHO")
        assert draw_until(engine, ortho, drawing, lambda: view.frame.generation == 4
                          and view.frame.final)
        assert view.camera["type"] == "ORTHO" and view.generations[4] == "camera"

        # Looking through a panoramic camera draws a message, not an image.
        scene.camera.data.type = "PANO"
        through = region_context(scene.camera, size, perspective="CAMERA")
        drawing.calls.clear()
        engine_mod.SnellRenderEngine.view_draw(engine, through, evaluated())
        assert [c[0] for c in drawing.calls] == ["text"] and "PANO" in drawing.calls[0][1]
        assert any(c[0] == "report" and "PANO" in c[2] for c in engine.calls)
        assert view.session.alive
    finally:
        # Blender frees the engine when the viewport closes or the engine changes.
        engine_mod.SnellRenderEngine.__del__(engine)
    assert not snell_threads() and engine._snell_viewport is None


def test_resizes_wait_until_the_region_keeps_its_size(monkeypatch):
    scene = open_spheres()
    scene.cycles.preview_samples = 1      # the file's Cycles setting, which Snell follows
    drawing = StandInDrawing()
    monkeypatch.setattr(viewport, "DRAWING", drawing)
    monkeypatch.setattr(viewport, "RESIZE_DELAY", 0.0)
    engine = StandInEngine()
    try:
        engine_mod.SnellRenderEngine.view_update(engine, None, evaluated())
        view = engine._snell_viewport
        assert draw_until(engine, region_context(scene.camera, (32, 20)), drawing,
                          lambda: view.frame is not None and view.frame.final)
        monkeypatch.setattr(viewport, "RESIZE_DELAY", 0.5)
        for width in (33, 34, 35):           # dragging the region's edge
            engine_mod.SnellRenderEngine.view_draw(engine,
                                                   region_context(scene.camera, (width, 20)),
                                                   evaluated())
        assert len(view.generations) == 1    # not yet: the old image, stretched
        assert drawing.calls[-1][0] == "texture" and drawing.calls[-1][4:] == (35, 20)
        time.sleep(0.55)
        engine_mod.SnellRenderEngine.view_draw(engine, region_context(scene.camera, (35, 20)),
                                               evaluated())
        assert len(view.generations) == 2 and view.camera["resolution"] == [35, 20]
    finally:
        viewport.release(engine)


def test_worker_errors_are_drawn_and_reported(monkeypatch):
    scene = open_spheres()
    drawing = StandInDrawing()
    monkeypatch.setattr(viewport, "DRAWING", drawing)

    def broken(self, job):
        raise RuntimeError("a deliberate bug")

    monkeypatch.setattr(view_session.ViewSession, "_render", broken)
    engine = StandInEngine()
    context = region_context(scene.camera, (32, 20))
    try:
        engine_mod.SnellRenderEngine.view_update(engine, context, evaluated())
        view = engine._snell_viewport
        assert draw_until(engine, context, drawing, lambda: view.frame is not None, 30)
        engine_mod.SnellRenderEngine.view_draw(engine, context, evaluated())
        assert any(c[0] == "text" and "a deliberate bug" in c[1] for c in drawing.calls)
        assert any(c[0] == "report" and c[1] == "ERROR" and "a deliberate bug" in c[2]
                   for c in engine.calls)
    finally:
        viewport.release(engine)


def test_a_drawing_failure_is_reported_not_raised(monkeypatch):
    scene = open_spheres()
    scene.cycles.preview_samples = 1      # the file's Cycles setting, which Snell follows

    class Refusing(StandInDrawing):
        def draw_texture(self, *args):
            raise RuntimeError("the GPU said no")

    drawing = Refusing()
    monkeypatch.setattr(viewport, "DRAWING", drawing)
    engine, context = StandInEngine(), region_context(scene.camera, (32, 20))
    try:
        engine_mod.SnellRenderEngine.view_update(engine, context, evaluated())
        view = engine._snell_viewport
        assert draw_until(engine, context, drawing, lambda: view.frame is not None
                          and view.frame.final)
        engine_mod.SnellRenderEngine.view_draw(engine, context, evaluated())
        assert engine.calls.count(("bind", scene.name)) == engine.calls.count(("unbind",)) > 0
        assert [c for c in engine.calls if c[0] == "report"] == [
            ("report", "ERROR", "Snell: viewport drawing failed (RuntimeError: the GPU said no)")]
    finally:
        viewport.release(engine)


def test_display_pixels_are_finite_bottom_up_rgba():
    image = np.array([[[1.0, np.nan, np.inf]], [[-2.0, 3e9, 0.5]]], np.float32)   # 2 rows
    rgba = view_draw.display_pixels(image)
    assert rgba.dtype == np.float32 and rgba.shape == (2, 1, 4)
    assert np.array_equal(rgba[1, 0], [1.0, 0.0, 0.0, 1.0])          # the top row, last
    assert np.array_equal(rgba[0, 0], [0.0, view_draw.DISPLAY_LIMIT, 0.5, 1.0])
    # A transparent film's alpha goes into the texture, bottom row first as the colour.
    rgba = view_draw.display_pixels(image, np.array([[0.25], [0.75]], np.float32))
    assert rgba[1, 0, 3] == 0.25 and rgba[0, 0, 3] == 0.75


def _rotation_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    m = np.eye(4)
    m[:2, :2] = [[c, -s], [s, c]]
    return m


def test_a_texture_added_by_a_material_edit_reads_the_cached_meshes_uvs():
    """Meshes cached before any material had an image texture have no texture coordinates: the
    material edit that adds one gets them, as a fresh export does."""
    from snell.addon.view_updates import Plan
    open_spheres()
    obj, shader = next((o, n) for o in bpy.context.scene.objects
                       if o.type == "MESH" and o.active_material
                       for n in o.active_material.node_tree.nodes if n.type == "BSDF_DIFFUSE")
    if not obj.data.uv_layers:
        obj.data.uv_layers.new()
    live = LiveExport()
    live.update(evaluated(), full())
    image = bpy.data.images.new("checker", 4, 4)
    image.pixels = np.tile([0.9, 0.1, 0.1, 1.0], 16).tolist()
    tree = obj.active_material.node_tree
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image = image
    tree.links.new(node.outputs["Color"], shader.inputs[0])
    content = live.update(evaluated(), Plan(materials=True))
    fresh, _ = export_depsgraph(evaluated())
    assert live.extracted and len(content.scene.texcoords) == len(fresh.texcoords) == 1
    coords = content.scene.texcoords[0]["coords"]
    assert np.abs(coords).max() > 0
    assert np.array_equal(coords, fresh.texcoords[0]["coords"])
