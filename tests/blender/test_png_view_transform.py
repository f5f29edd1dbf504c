"""`snell render --png` of a .blend goes through the file's view transform, look, exposure and
gamma (addon/display.py), as Blender saves a render: held against Cycles' own PNG of the same
scene. The scene is emissive patches of strengths from 0.02 to 40 seen directly, so both
renderers' linear values are exact (no noise) and the PNGs must agree at every patch's centre
to within one 8-bit level; Snell's old Standard-only PNG is caught on every other transform."""
import importlib
import os
import subprocess
import sys

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from snell.addon.blendfile import open_blend, render_still  # noqa: E402
from snell.tracer import image  # noqa: E402

common = importlib.import_module("common")

STRENGTHS = (0.02, 0.1, 0.3, 0.7, 1.0, 2.0, 5.0, 12.0, 40.0)
COLOURS = ((1.0, 1.0, 1.0), (1.0, 0.3, 0.1), (0.2, 0.5, 1.0))
SIZE = 54                     # pixels: 3 x 3 patches of 18
VIEWS = [("Standard", "None", 0.0, 1.0), ("Filmic", "None", 0.0, 1.0),
         ("AgX", "None", 0.0, 1.0), ("AgX", "AgX - Punchy", 1.0, 1.2),
         ("Khronos PBR Neutral", "None", -0.5, 1.0)]


def build(path, view, look, exposure, gamma):
    scene = common.reset()
    common.setup_render(scene, (SIZE, SIZE), samples=2)
    for k, strength in enumerate(STRENGTHS):
        row, col = divmod(k, 3)
        x0, y0 = -1.5 + col, 0.5 - row
        mat = common.material(f"Glow{k}", "emission", COLOURS[k % 3], Strength=strength)
        common.quad(f"Patch{k}", [(x0, y0 - 1, 0), (x0 + 1, y0 - 1, 0), (x0 + 1, y0, 0),
                                  (x0, y0, 0)], mat)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 3.0
    cam.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    vs = scene.view_settings
    vs.view_transform, vs.look, vs.exposure, vs.gamma = view, look, exposure, gamma
    scene.render.dither_intensity = 0.0
    return common.save(path)


def centres(png_path):
    """The 8-bit RGB at the centre 8 x 8 pixels of each patch, (9, 64, 3)."""
    import OpenImageIO as oiio
    pixels = oiio.ImageBuf(png_path).get_pixels(oiio.UINT8)[..., :3].astype(int)
    step = SIZE // 3
    return np.stack([pixels[r * step + 5:r * step + 13, c * step + 5:c * step + 13].reshape(-1, 3)
                     for r in range(3) for c in range(3)])


def cycles_png(blend, out):
    open_blend(blend)
    scene = bpy.context.scene
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_depth = "8"
    scene.render.filepath = out
    render_still(blend)
    return out


@pytest.mark.parametrize("view", VIEWS, ids=lambda v: f"{v[0]}-{v[1]}-{v[2]}")
def test_png_follows_the_files_view_transform(tmp_path, view):
    blend = build(str(tmp_path / "patches.blend"), *view)
    ours = tmp_path / "snell.png"
    out = subprocess.run([sys.executable, "-m", "snell.cli", "render", blend, "-o",
                          str(tmp_path / "snell.exr"), "--png", str(ours), "--spp", "2",
                          "--quiet"], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    theirs = centres(cycles_png(blend, str(tmp_path / "cycles.png")))
    got = centres(str(ours))
    assert np.abs(got - theirs).max() <= 1, (view, got[:, 0], theirs[:, 0])
    if view[0] != "Standard" or view[2] != 0.0:
        # Teeth: the Standard transform of the same linear image is far off.
        standard = str(tmp_path / "standard.png")
        image.write_png(standard, image.read_exr(str(tmp_path / "snell.exr"))[..., :3])
        assert np.abs(centres(standard) - theirs).max() > 10
    assert os.path.getsize(ours) > 0
