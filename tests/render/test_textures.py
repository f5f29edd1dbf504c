"""Image textures (textures.py): Cycles' lookups, and textures on a material's colour, roughness
and metallic in the renderer."""
import numba
import numpy as np
import pytest

from support.builders import camera, make_scene, quad
from snell.tracer import textures
from snell.tracer.integrator import Renderer, render
from snell.tracer.scene import validate


@numba.njit(cache=True)
def _lookups(pixels, w, h, xy, closest, extension, out):
    for i in range(xy.shape[0]):
        c = textures.sample_image(pixels, 0, w, h, xy[i, 0], xy[i, 1], closest, extension)
        out[i, 0], out[i, 1], out[i, 2] = c


def lookup(image, xy, closest, extension):
    """sample_image at every (x, y) row of xy for an (H, W, 3) image, top row first."""
    h, w = image.shape[:2]
    out = np.zeros((len(xy), 3))
    _lookups(np.ascontiguousarray(image.reshape(-1, 3), np.float32), w, h,
             np.asarray(xy, np.float64), closest, extension, out)
    return out


def ramp(h=4, w=8):
    """Texel (row r from the top, column c) holds c + 100 r."""
    image = np.zeros((h, w, 3), np.float32)
    image[:] = (np.arange(w)[None, :] + 100.0 * np.arange(h)[:, None])[:, :, None]
    return image


def test_lookups_follow_cycles():
    """Cycles' interp_closest / interp_linear (device/cpu/image.h): y = 0 is the bottom row,
    texel centres at (i + 0.5) / n; Repeat wraps, Extend clamps, Clip is black outside, Mirror
    reflects."""
    image = ramp()
    h, w = image.shape[:2]
    # Closest: the texel the point falls in. (x, y) = (2.5 / 8, 0.5 / 4): column 2, bottom row 3.
    assert lookup(image, [(2.5 / w, 0.5 / h)], True, textures.REPEAT)[0, 0] == 2 + 300
    # Linear at a texel centre is the texel; halfway between two columns their mean.
    assert lookup(image, [(2.5 / w, 0.5 / h)], False, textures.EXTEND)[0, 0] == pytest.approx(302)
    assert lookup(image, [(3.0 / w, 1.5 / h)], False, textures.EXTEND)[0, 0] == \
        pytest.approx(2.5 + 200)
    # Outside the image: Repeat wraps, Extend clamps, Clip is black, Mirror reflects.
    x = [(-0.5 / w, 0.5 / h)]
    assert lookup(image, x, True, textures.REPEAT)[0, 0] == 7 + 300
    assert lookup(image, x, True, textures.EXTEND)[0, 0] == 0 + 300
    assert lookup(image, x, True, textures.CLIP)[0, 0] == 0
    assert lookup(image, x, True, textures.MIRROR)[0, 0] == 0 + 300
    # Linear at the left edge: Repeat blends the last and first columns, Clip blends with black.
    edge = [(0.0, 0.5 / h)]
    assert lookup(image, edge, False, textures.REPEAT)[0, 0] == pytest.approx(300 + 3.5)
    assert lookup(image, edge, False, textures.CLIP)[0, 0] == pytest.approx(0.5 * 300)
    assert lookup(image, [(-2.0, 0.5)], False, textures.CLIP)[0, 0] == 0


CHECKER = 8


def checker(n=CHECKER, dark=0.2, light=0.7):
    """An n x n checkerboard (top-left texel light), float32 (n, n, 3)."""
    rows, cols = np.indices((n, n))
    values = np.where((rows + cols) % 2 == 0, light, dark)
    return np.repeat(values[:, :, None], 3, axis=2).astype(np.float32)


def textured_plane(image, colorspace="linear", interpolation="closest", kind="diffuse",
                   spp=64, slot="color", lamp=True):
    """A unit-albedo plane z = 0 spanning [-1, 1]^2 with UVs (x + 1) / 2, (y + 1) / 2, its
    texture on `slot`, under a white world of radiance 1, seen straight down by a pinhole
    camera whose 32 x 32 pixels each cover 1 / 16 of a texel of the 8 x 8 image."""
    pos, tri = quad((0.0, 0.0, 0.0), 1.0, 1.0)
    corners = pos[tri].astype(np.float64)
    coords = np.zeros((len(tri), 3, 3), np.float32)
    coords[:, :, 0] = (corners[:, :, 0] + 1) / 2
    coords[:, :, 1] = (corners[:, :, 1] + 1) / 2
    # A 50 mm lens on a 36 mm sensor sees 36 / 50 of the distance across: the 2 m plane fills it.
    cam = camera((0.0, 0.0, 2.0 * 50.0 / 36.0), (32, 32))
    mat = {"name": "floor", "kind": kind, "color": [1.0, 1.0, 1.0]}
    scene = make_scene([(pos, tri, 0)], [mat], cam, world=(1.0, 1.0, 1.0), spp=spp, max_depth=1)
    scene.materials[0]["textures"] = {slot: {
        "image": 0, "texcoord": 0, "interpolation": interpolation, "extension": "repeat",
        "matrix": np.eye(3).tolist(), "offset": [0.0, 0.0, 0.0]}}
    scene.images = [{"name": "checker", "source": "test", "colorspace": colorspace,
                     "pixels": image}]
    scene.texcoords = [{"kind": "uv", "name": "", "coords": coords}]
    return validate(scene)


def test_checker_renders_its_values_at_pixel_centres():
    """A diffuse plane of a checker texture (Closest) under a white world of radiance 1 (a
    one-bounce path: the albedo times the world) shows each checker value exactly in the pixel
    regions inside a square, within the noise of the world's sampling (far below the checker's
    contrast); the 4 x 4 pixels of each texel have its value."""
    image = checker()
    scene = textured_plane(image, spp=256)
    result = Renderer(scene, scene.settings(threads=2, sampler="independent")).render()
    assert result.stages["world"][0]
    img = result.mean()[:, :, 0].astype(np.float64)
    se = np.sqrt(result.variance_of_mean()[:, :, 0])
    # Pixel (r, c) of the 32 x 32 image sees texel (r // 4, c // 4): row 0 at the top on both.
    expected = np.repeat(np.repeat(image[:, :, 0], 4, 0), 4, 1)
    # Every pixel lies wholly inside one texel (4 x 4 pixels a texel), so each has its value.
    assert np.all(np.abs(img - expected) < 4.5 * se + 1e-6)
    assert se.max() < 0.05 * (0.7 - 0.2)


def test_srgb_and_non_color_differ_as_they_must():
    """The same pixels as sRGB decode to linear (0.7 -> 0.448, 0.2 -> 0.0331) and as Non-Color
    (linear) stay as they are."""
    image = checker()
    srgb = render(textured_plane(image, colorspace="srgb", spp=64))
    linear = render(textured_plane(image, colorspace="linear", spp=64))
    decode = lambda c: ((c + 0.055) / 1.055) ** 2.4 if c >= 0.04045 else c / 12.92  # noqa: E731
    # The 4 x 4 pixels of the top-left (light) texel and of its right neighbour (dark).
    light = lambda r: float(r.mean()[0:4, 0:4, 0].mean())  # noqa: E731
    dark = lambda r: float(r.mean()[0:4, 4:8, 0].mean())  # noqa: E731
    assert light(srgb) == pytest.approx(decode(0.7), rel=0.01)
    assert dark(srgb) == pytest.approx(decode(0.2), rel=0.01)
    assert light(linear) == pytest.approx(0.7, rel=0.01)
    assert dark(linear) == pytest.approx(0.2, rel=0.01)
