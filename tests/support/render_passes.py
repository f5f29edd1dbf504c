"""Render passes written and read back, as the light passes' and light groups' tests hold them:
F12's multilayer EXR against the tracer's passes (tests/blender), Cycles' passes against
Snell's with the validator's statistics (tests/validation). Callers import bpy first (through
pytest.importorskip); this module imports it, and scenes/common.py, only when a helper runs."""
from __future__ import annotations

import importlib
import os
import tempfile

import numpy as np

from support.cycles_reference import verdict

F12_SIZE = (16, 12)
FLOOR = (0.8, 0.5, 0.3)
SKY = (0.2, 0.3, 0.5)
# The Cycles comparisons: image size, samples per seed (in both renderers), seeds, max depth.
COMPARE_SIZE, COMPARE_SPP, COMPARE_SEEDS, COMPARE_DEPTH = (48, 36), 128, 8, 6


def saves_multilayer_exr(scene, path):
    """Make a render of the scene save a 32-bit multilayer EXR (every pass) to path."""
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):
        settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format, settings.color_depth = "OPEN_EXR_MULTILAYER", "32"
    scene.render.filepath = str(path)


def lamp_over_floor(path, lamps=(("Lamp", (0.0, 0.0, 2.0), ""),)):
    """A fresh file at F12_SIZE, 4 samples: a diffuse floor (FLOOR) under 100 W point lamps
    (name, location, light group) and a blue world, Snell the engine, F12 saving a multilayer
    EXR to path."""
    import bpy
    common = importlib.import_module("common")
    scene = common.reset()
    common.setup_render(scene, F12_SIZE, samples=4, max_bounces=3)
    common.set_world(scene, SKY)
    common.floor("Floor", 1, common.material("Floor", "diffuse", FLOOR))
    for name, location, group in lamps:
        obj = bpy.data.objects.new(name, bpy.data.lights.new(name, "POINT"))
        obj.data.energy = 100.0
        obj.location = location
        obj.lightgroup = group
        scene.collection.objects.link(obj)
    common.camera(scene, (0.0, -3.0, 2.0), (0.0, 0.0, 0.0), lens=35.0)
    scene.render.engine = "SNELL"
    saves_multilayer_exr(scene, path)
    return scene


def registered_passes(scene) -> list:
    """The (name, channels, channel ids, kind) passes Snell's engine registers for the
    compositor on the scene's first view layer."""
    from snell.addon.engine import SnellRenderEngine
    registered = []

    class Recorder:
        def register_pass(self, scene, layer, name, channels, ids, kind):
            registered.append((name, channels, ids, kind))

    SnellRenderEngine.update_render_passes(Recorder(), scene, scene.view_layers[0])
    return registered


def f12_against_tracer(path, names, images, **switches):
    """F12 the current file (saving path) and assert that each named pass it wrote equals the
    tracer's for the exported scene rendered with switches (images: the result's method that
    gives its passes); returns ({name: the pass read back}, the tracer's result)."""
    import bpy

    from snell.addon import final
    from snell.addon.export import export_depsgraph
    from snell.tracer.integrator import Renderer
    from snell.validation.cycles import read_pass
    bpy.ops.render.render(write_still=True)
    assert final.last_render["error"] is None, final.last_render
    written = {name: read_pass(str(path), name) for name in names}
    exported, _ = export_depsgraph(bpy.context.evaluated_depsgraph_get())
    result = Renderer(exported, exported.settings(**switches)).render()
    expected = getattr(result, images)()
    for name in names:
        np.testing.assert_allclose(written[name], expected[name], rtol=1e-5, atol=1e-6,
                                   err_msg=name)
    return written, result


def exr_channels(path) -> dict:
    """{channel name: float32 (H, W)} of every channel of every part of an EXR."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    out = {}
    try:
        part = 0
        while inp.seek_subimage(part, 0):
            spec = inp.spec()
            pixels = inp.read_image(part, 0, 0, spec.nchannels, "float")
            for k, name in enumerate(spec.channelnames):
                out[name] = np.asarray(pixels)[..., k].copy()
            part += 1
    finally:
        inp.close()
    return out


def floor_for_compare():
    """A fresh file for a Cycles comparison of passes: COMPARE_SIZE, COMPARE_SPP, COMPARE_DEPTH,
    a one-pixel box filter, a blue world (SKY) and a 6 m diffuse floor (FLOOR)."""
    common = importlib.import_module("common")
    scene = common.reset()
    common.setup_render(scene, COMPARE_SIZE, samples=COMPARE_SPP, max_bounces=COMPARE_DEPTH - 1)
    # A one-pixel box filter: a pixel next to an edge gets the far side's samples in proportion
    # to its cover, not from the rare tails of a wider filter (where one renderer's few hits
    # against the other's none fail the pixel test of a zero-variance pixel).
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    common.set_world(scene, SKY)
    common.floor("Floor", 3, common.material("Floor", "diffuse", FLOOR))
    return scene


def compare_scene(blend):
    """The file exported for Snell's renders of a comparison (max depth COMPARE_DEPTH)."""
    from snell.validation import compare
    scene, _ = compare.load_snell_scene(blend)
    return scene.with_render(max_depth=COMPARE_DEPTH)


def cycles_passes(blend, names, combined=False) -> dict:
    """{pass: (COMPARE_SEEDS, H, W, 3)} of Cycles' renders of the file, one per seed (the
    validator's seeds), row 0 at the top; with combined, Combined's RGB too."""
    from snell.validation import cycles
    images = {name: [] for name in names + (("Combined",) if combined else ())}
    with tempfile.TemporaryDirectory(prefix="snell-passes-") as workdir:
        out = os.path.join(workdir, "passes.exr")
        for seed in cycles.seeds_for(COMPARE_SEEDS, 7):
            settings = cycles.forced_settings(COMPARE_DEPTH, COMPARE_SPP, seed, 2) + [
                ("output", cycles.DENOISING_OUTPUT, "the passes, read back")]
            with cycles.stdout_silenced(True):
                cycles._render_file(blend, settings, None, out)
            for name in names:
                images[name].append(cycles.read_pass(out, name))
            if combined:
                images["Combined"].append(cycles.read_pass(out, "Combined"))
            os.remove(out)
    return {name: np.stack(stack) for name, stack in images.items()}


def snell_renders(scene, **switches):
    """Snell's independent renders of the scene, as many as Cycles' seeds (the independent
    sampler, COMPARE_SPP), each with the switches (light_passes=True, ...): their results."""
    from snell.tracer.integrator import Renderer
    for k in range(COMPARE_SEEDS):
        settings = scene.settings(threads=2, sampler="independent", spp=COMPARE_SPP,
                                  seed=2000 + k,
                                  noise_threshold=0.0, time_limit=0.0, **switches)
        yield Renderer(scene, settings).render()


def pass_verdict(ours, theirs, light=None) -> tuple:
    """(verdict, detail) of Snell's renders of a pass (renders, H, W, 3) against Cycles'; light:
    the light tracer's share of each of Snell's renders (the validator's allowance for light
    only a light tracer carries)."""
    from snell.validation import metrics
    result = metrics.compare_estimates(metrics.Estimate.from_images(ours, light),
                                       metrics.Estimate.from_images(theirs),
                                       error_metrics=False)
    return verdict(result)
