"""The film (#30): its alpha (Film > Transparent and the Holdout closure) and its exposure,
exactly where every path does the same thing (tiny_scene: an emissive quad over the top half of
an 8x8 view, a coloured world below), and through `snell render`'s EXR and PNG. The alpha
against Cycles: tests/validation/test_alpha_compare.py."""
from __future__ import annotations

import subprocess
import sys

import numpy as np

from snell.tracer import image
from snell.tracer.integrator import Renderer
from snell.tracer.scene import save
from snell.tracer.shader import closures
from support.builders import EMISSION, tiny_scene

SKY = [0.2, 0.3, 0.4]


def program(*code, constants=(), **extra):
    """A shader program material of these rows (extra: the program's other keys)."""
    rows = [list(row) + [0] * (8 - len(row)) for row in code]
    return {"name": "P", "kind": "program",
            "program": {"registers": len(constants) + 16, "constants": list(constants),
                        "code": rows, **extra}}


def scene(material=None, **render):
    """tiny_scene under a SKY world, its quad's material replaced if given."""
    s = tiny_scene(spp=8, **render)
    s.world = {"color": SKY}
    if material is not None:
        s.materials = [material]
    return s


def render(s):
    return Renderer(s, s.settings(threads=1)).render()


def test_an_opaque_film_has_no_alpha():
    result = render(scene())
    assert not result.has_alpha
    assert np.all(result.alpha() == 1.0)
    np.testing.assert_allclose(result.mean()[6:], np.broadcast_to(SKY, (2, 8, 3)), rtol=1e-6)


def test_a_transparent_film_hides_the_world_and_clears_its_pixels():
    result = render(scene(film_transparent=True))
    rgb, alpha = result.mean(), result.alpha()
    assert result.has_alpha and result.alpha_nan_count == 0
    np.testing.assert_allclose(rgb[:3], EMISSION, rtol=1e-4)     # the lamp is still seen
    assert np.all(alpha[:3] == 1.0)
    assert np.all(rgb[5:] == 0.0) and np.all(alpha[5:] == 0.0)  # the world is not
    assert set(result.exr_channels()) == {"A", "samples"}


def test_a_transparent_surface_lets_the_film_show_through():
    """A Transparent BSDF of colour 0.25 (no bounce): the world behind clears 0.25 of the pixel."""
    clear = program((closures.TRANSPARENT_BSDF, -1, 0), constants=[0.25, 0.25, 0.25])
    alpha = render(scene(clear, film_transparent=True)).alpha()
    np.testing.assert_allclose(alpha[:3], 0.75, atol=1e-6)
    assert np.all(alpha[5:] == 0.0)


def test_a_holdout_clears_its_share_even_on_an_opaque_film():
    """Mix(Holdout, Emission) by 0.6: 0.4 of the quad is held out, as Cycles does with or
    without Film > Transparent; the emission's share still shines."""
    code = [(closures.MIX_CLOSURE, 5, 6, -1, 0),
            (closures.HOLDOUT, 5),
            (closures.EMISSION, 6, 1, 4)]
    # Its emission run at every hit (the exporter's flag for emission it cannot fold).
    held = program(*code, constants=[0.6, 1.0, 1.0, 1.0, EMISSION], emission_varies=True)
    result = render(scene(held))
    assert result.has_alpha
    alpha, rgb = result.alpha(), result.mean()
    np.testing.assert_allclose(alpha[:3], 0.6, atol=1e-6)
    np.testing.assert_allclose(rgb[:3], 0.6 * EMISSION, rtol=1e-4)
    assert np.all(alpha[5:] == 1.0)          # an opaque film: the world is seen
    np.testing.assert_allclose(rgb[6:], np.broadcast_to(SKY, (2, 8, 3)), rtol=1e-6)


def test_snell_render_writes_the_alpha_channel(tmp_path):
    """The EXR's A channel and an RGBA PNG (straight alpha, as PNGs keep it)."""
    import OpenImageIO as oiio
    path, out, png = tmp_path / "clear.snell", tmp_path / "clear.exr", tmp_path / "clear.png"
    save(scene(), str(path))
    proc = subprocess.run([sys.executable, "-m", "snell.cli", "render", str(path), "-o",
                           str(out), "--png", str(png), "--film-transparent", "on",
                           "--threads", "1"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    alpha = image.read_channel(str(out), "A")
    assert np.all(alpha[:3] == 1.0) and np.all(alpha[5:] == 0.0)
    assert np.all(image.read_exr(str(out))[5:] == 0.0)
    written = oiio.ImageInput.open(str(png))
    try:
        assert written.spec().nchannels == 4
        pixels = written.read_image("uint8")
    finally:
        written.close()
    assert np.all(pixels[:3, :, 3] == 255) and np.all(pixels[5:, :, 3] == 0)


def test_film_exposure_scales_the_image_only():
    """Film > Exposure 0.5: half the radiance in the image; the sums (and so adaptive sampling,
    which reads them) and the alpha are the exposure-1 render's."""
    plain = render(scene(film_transparent=True))
    half = render(scene(film_transparent=True, film_exposure=0.5))
    np.testing.assert_array_equal(half.sum, plain.sum)
    np.testing.assert_allclose(half.mean(), 0.5 * plain.mean(), rtol=1e-6)
    np.testing.assert_array_equal(half.alpha(), plain.alpha())
