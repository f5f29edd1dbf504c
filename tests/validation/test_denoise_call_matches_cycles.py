"""Snell's Open Image Denoise call (tracer/denoise.py) is Cycles' own: Cycles' noisy image and its
Denoising Albedo and Normal passes, denoised by Snell's call, give Cycles' denoised image, with
each prefilter. So any difference between Snell + OIDN and Cycles + OIDN comes from the inputs.

Not a statistical comparison: the same inputs through the same OIDN library (the `bpy` wheel's,
which Cycles links) must give the same pixels. Teeth: OIDN's network is not symmetric under a
vertical flip, and Cycles hands it the rows bottom first (its render buffer's order); handing it
the rows top first, as the image is stored, gave a mean difference of 2.1-2.5% of the image's
mean here (2.5% on cornell_spheres at 4 spp) and failed each case, measured.
"""
from __future__ import annotations

import importlib
import os

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")


def build(path):
    """The Cornell box with a glass and a diffuse sphere, 72x48 (not square: a transposed or
    flipped image cannot match)."""
    scene = common.reset()
    common.setup_render(scene, resolution=(72, 48))
    common.cornell_box()
    common.uv_sphere("Glass", (-0.4, 0.0, 0.3), 0.3,
                     common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5))
    common.uv_sphere("Plastic", (0.45, 0.1, 0.3), 0.3,
                     common.material("Plastic", "diffuse", (0.2, 0.4, 0.8)))
    common.camera(scene, (0.0, -2.4, 0.75), (0.0, 0.0, 0.45), lens=35.0)
    return common.save(path)


@pytest.fixture(scope="module")
def blend(tmp_path_factory):
    return build(str(tmp_path_factory.mktemp("denoise_call") / "box.blend"))


def cycles_denoised_render(blend, prefilter, directory):
    """Cycles at 4 spp denoised by its own OIDN (the bench's settings): {name: (H, W, 3)} of its
    denoised image, its noisy image and its two guiding passes, read back from its EXR."""
    from snell.addon.console import stdout_silenced
    from snell.validation import cycles
    from snell.validation.bench import cycles_denoised
    settings = cycles_denoised(cycles.forced_settings(8, 4, 5, threads=1), prefilter, "high")
    settings += [("view_layers.cycles.denoising_store_passes", True, "the passes OIDN is given"),
                 ("output", cycles.DENOISING_OUTPUT, "read back")]
    out = os.path.join(directory, f"{prefilter}.exr")
    with stdout_silenced(True):
        cycles._render_file(blend, settings, None, out)
    return {name: cycles.read_pass(out, layer).astype(np.float32) for name, layer in (
        ("denoised", "Combined"), ("noisy", "Noisy Image"), ("albedo", "Denoising Albedo"),
        ("normal", "Denoising Normal"))}


@pytest.mark.parametrize("prefilter", ["none", "fast", "accurate"])
def test_cycles_inputs_through_snells_call_give_cycles_denoised_image(blend, prefilter, tmp_path):
    from snell.tracer import denoise
    try:
        denoise.load()
    except denoise.DenoiseError as exc:
        pytest.skip(f"no Open Image Denoise here: {exc}")
    c = cycles_denoised_render(blend, prefilter, str(tmp_path))
    assert not np.array_equal(c["denoised"], c["noisy"])            # Cycles did denoise
    ours = denoise.denoise(c["noisy"], c["albedo"], c["normal"], prefilter, "high", threads=1)
    scale = float(c["denoised"].mean())
    # Same library, same inputs: equal up to float rounding (threads split the work alike).
    assert np.abs(ours.image - c["denoised"]).max() <= 1e-4 * max(scale, 1e-6), (
        prefilter, float(np.abs(ours.image - c["denoised"]).mean()) / scale)
