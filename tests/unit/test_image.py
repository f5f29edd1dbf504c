"""tracer/image.py: EXR/PNG round trips, the sRGB curve, NaN/Inf clean-up, write errors."""
import os

import numpy as np
import pytest

from snell.tracer import image


def _ramp(h=5, w=7):
    rng = np.random.default_rng(1)
    rgb = rng.random((h, w, 3)).astype(np.float32) * 20.0
    rgb[0, 0] = [1e-8, 65504.0 * 4, 0.0]  # beyond half range and denormal-ish: float32 must survive
    return rgb


def test_exr_round_trip_is_exact_float32(tmp_path):
    rgb = _ramp()
    path = tmp_path / "a.exr"
    assert image.write_exr(path, rgb) == 0
    back = image.read_exr(path)
    assert back.dtype == np.float32 and back.shape == rgb.shape
    assert np.array_equal(back, rgb)


def test_exr_extra_channels_are_kept_and_rgb_reads_alone(tmp_path):
    """A "samples" channel (`snell render`'s sample counts) after R, G, B: read_exr still reads
    the RGB, read_channel the counts, and a fourth channel is not taken for alpha."""
    rng = np.random.default_rng(1)
    rgb = rng.random((4, 6, 3)).astype(np.float32)
    counts = rng.integers(16, 1025, (4, 6))
    path = tmp_path / "a.exr"
    image.write_exr(path, rgb, channels={"samples": counts})
    assert np.array_equal(image.read_exr(path), rgb)
    assert np.array_equal(image.read_channel(path, "samples"), counts)
    with pytest.raises(OSError, match="no channel 'depth'"):
        image.read_channel(path, "depth")
    with pytest.raises(ValueError, match="channel 'samples'"):
        image.write_exr(tmp_path / "b.exr", rgb, channels={"samples": counts[:2]})
    assert not (tmp_path / "b.exr").exists()


@pytest.mark.parametrize("count", [2 ** 24 + 1, 2 ** 31 - 1])
def test_sample_counts_beyond_float32_are_exact(tmp_path, count):
    """Sample counts as a 32-bit unsigned channel: 2^24 + 1 (the first integer float32 cannot
    hold) and 2^31 - 1 (the most spp a user can ask for) come back exact, with their neighbours.
    Deliberate error: the counts written as float32 (the channel as it was) read 16777216 and
    2147483648, and OpenImageIO's own per-channel UINT write (a float buffer) gave 16777218 and
    2147483648: both fail here."""
    rgb = np.full((2, 3, 3), 0.25, np.float32)
    counts = np.array([[count - 1, count, count + 1], [0, 1, count]], np.int64)
    if count == 2 ** 31 - 1:
        counts[0, 2] = count        # result.samples() is int32: nothing above 2^31 - 1
    path = tmp_path / "counts.exr"
    image.write_exr(path, rgb, channels={"samples": counts.astype(np.int32)})
    back = image.read_channel(path, "samples")
    assert back.dtype == np.uint32
    assert np.array_equal(back.astype(np.int64), counts)
    assert np.array_equal(image.read_exr(path), rgb)
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    try:
        formats = [str(f) for f in inp.spec().channelformats]
        assert list(inp.spec().channelnames) == ["R", "G", "B", "samples"]
    finally:
        inp.close()
    assert formats == ["float", "float", "float", "uint"]


def test_sample_counts_out_of_range_are_refused(tmp_path):
    """A negative count or one beyond 2^32 - 1 is a ValueError naming the channel, and no file
    is left (uint32 would wrap it silently)."""
    rgb = np.zeros((1, 2, 3), np.float32)
    for bad in ([[-1, 4]], [[2 ** 32, 4]]):
        with pytest.raises(ValueError, match="channel 'samples': counts must lie in 0"):
            image.write_exr(tmp_path / "a.exr", rgb, channels={"samples": np.array(bad, np.int64)})
    assert os.listdir(tmp_path) == []


def test_batch_adds_exact_counts_to_blenders_exr(tmp_path):
    """`snell batch` adds each pixel's samples to the EXR Blender wrote: counts of 2^24 + 1 and
    2^31 - 1 read back exact and the RGB unchanged (deliberate error, counts cast to float32
    before the write: 16777216 and 2147483648, caught)."""
    from snell.addon.batch import _add_render_channels
    import OpenImageIO as oiio

    rgb = np.full((1, 2, 3), 0.5, np.float32)
    path = str(tmp_path / "frame.exr")
    out = oiio.ImageOutput.create(path)      # Blender's EXR: float RGB, no samples channel
    assert out.open(path, oiio.ImageSpec(2, 1, 3, "float")) and out.write_image(rgb)
    out.close()
    counts = np.array([[2 ** 24 + 1, 2 ** 31 - 1]], np.int32)
    _add_render_channels(path, {"samples": counts})
    assert np.array_equal(image.read_channel(path, "samples"), counts)
    assert np.array_equal(image.read_exr(path), rgb)


def test_float_channels_stay_float(tmp_path):
    """A float channel (a denoising pass) is still float32, read as written."""
    rgb = np.zeros((1, 2, 3), np.float32)
    albedo = np.array([[0.125, 3.0e38]], np.float32)
    image.write_exr(tmp_path / "a.exr", rgb, channels={"Denoising Albedo.R": albedo})
    back = image.read_channel(tmp_path / "a.exr", "Denoising Albedo.R")
    assert back.dtype == np.float32 and np.array_equal(back, albedo)


def test_exr_top_row_first(tmp_path):
    rgb = np.zeros((4, 3, 3), np.float32)
    rgb[0] = [1.0, 0.0, 0.0]  # top row red
    path = tmp_path / "top.exr"
    image.write_exr(path, rgb)
    import OpenImageIO as oiio
    buf = oiio.ImageBuf(str(path))
    assert buf.getpixel(1, 0)[:3] == (1.0, 0.0, 0.0)  # OIIO's y = 0 is the top scanline
    assert buf.getpixel(1, 3)[:3] == (0.0, 0.0, 0.0)
    assert np.array_equal(image.read_exr(path)[0, :, 0], [1.0, 1.0, 1.0])


@pytest.mark.parametrize("linear, code", [
    (0.0, 0), (1.0, 255), (0.5, 188), (0.18, 118),
    (0.0031308, 10),           # the curve's breakpoint: 12.92 * 0.0031308 * 255 = 10.31
    (0.0031309, 10),           # just above it, the power branch gives the same value (continuous)
    (-1.0, 0), (7.0, 255),     # clamped after the curve
])
def test_srgb_test_vectors(linear, code):
    assert image.to_srgb8(np.full((1, 1, 3), linear, np.float32))[0, 0, 0] == code


def test_srgb_curve_is_continuous_at_the_breakpoint():
    below = image.srgb_oetf(0.0031308)
    above = image.srgb_oetf(np.nextafter(0.0031308, 1.0))
    assert abs(below - 0.040449936) < 1e-8
    assert abs(above - below) < 1e-7


def test_sanitize_counts_pixels_not_channels():
    rgb = np.ones((3, 4, 3), np.float32)
    rgb[0, 0, 0] = np.nan
    rgb[0, 0, 2] = np.inf       # same pixel: counted once
    rgb[2, 3, :] = -np.inf
    clean, bad = image.sanitize(rgb)
    assert bad == 2
    assert np.all(np.isfinite(clean)) and clean.dtype == np.float32
    assert clean[0, 0].tolist() == [0.0, 1.0, 0.0] and clean[2, 3].tolist() == [0.0, 0.0, 0.0]
    assert np.isnan(rgb[0, 0, 0])  # the input is not modified
    assert image.sanitize(np.ones((2, 2, 3)))[1] == 0


def test_non_finite_pixels_never_reach_the_files(tmp_path):
    rgb = np.full((2, 2, 3), 0.5, np.float32)
    rgb[1, 1] = [np.nan, np.inf, -np.inf]
    assert image.write_exr(tmp_path / "n.exr", rgb) == 1
    back = image.read_exr(tmp_path / "n.exr")
    assert np.all(np.isfinite(back)) and back[1, 1].tolist() == [0.0, 0.0, 0.0]
    assert image.write_png(tmp_path / "n.png", rgb) == 1
    assert image.to_srgb8(rgb)[1, 1].tolist() == [0, 0, 0]


def test_png_is_8bit_srgb_top_row_first(tmp_path):
    rgb = np.zeros((2, 3, 3), np.float32)
    rgb[0] = 0.5
    path = tmp_path / "a.png"
    image.write_png(path, rgb)
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    try:
        assert inp.spec().format == oiio.TypeDesc("uint8") and inp.spec().nchannels == 3
        pixels = inp.read_image("uint8")
    finally:
        inp.close()
    assert pixels[0].tolist() == [[188] * 3] * 3 and pixels[1].tolist() == [[0] * 3] * 3


def test_write_errors_name_the_path_and_leave_nothing(tmp_path):
    rgb = np.zeros((2, 2, 3), np.float32)
    with pytest.raises(OSError, match="missing"):
        image.write_exr(tmp_path / "missing" / "a.exr", rgb)
    with pytest.raises(OSError, match=r"a\.unknownext"):
        image.write_exr(tmp_path / "a.unknownext", rgb)
    assert os.listdir(tmp_path) == []
    with pytest.raises(ValueError, match="shape"):
        image.write_exr(tmp_path / "a.exr", np.zeros((2, 2)))
    assert os.listdir(tmp_path) == []


def test_failed_write_keeps_the_previous_file(tmp_path, monkeypatch):
    path = tmp_path / "keep.exr"
    image.write_exr(path, np.ones((2, 2, 3), np.float32))
    import OpenEXR

    def boom(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(OpenEXR.File, "write", boom)
    with pytest.raises(KeyboardInterrupt):
        image.write_exr(path, np.zeros((2, 2, 3), np.float32))
    monkeypatch.undo()
    assert os.listdir(tmp_path) == ["keep.exr"]
    assert np.all(image.read_exr(path) == 1.0)


def test_read_errors_name_the_path(tmp_path):
    with pytest.raises(OSError, match="nope.exr"):
        image.read_exr(tmp_path / "nope.exr")
    garbage = tmp_path / "garbage.exr"
    garbage.write_bytes(b"not an image")
    with pytest.raises(OSError, match="garbage.exr"):
        image.read_exr(garbage)


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_written_files_get_ordinary_permissions(tmp_path):
    mask = os.umask(0o022)
    try:
        image.write_exr(tmp_path / "a.exr", np.zeros((2, 2, 3), np.float32))
        image.write_png(tmp_path / "a.png", np.zeros((2, 2, 3), np.float32))
    finally:
        os.umask(mask)
    assert (tmp_path / "a.exr").stat().st_mode & 0o777 == 0o644
    assert (tmp_path / "a.png").stat().st_mode & 0o777 == 0o644


def test_values_beyond_float32_become_inf_without_a_numpy_warning():
    """A colour of 1e38 times a strength makes pixels beyond float32: they are Inf (written as 0
    and counted), and NumPy's "overflow encountered in cast" never reaches the user's terminal
    (issue 31, item 4). Within range, the cast is NumPy's own (the image is bit-identical)."""
    import warnings

    from snell.tracer.result import RenderResult
    values = np.array([[[1e39, -1e39, 3.0e38]]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f32 = image.as_float32(values)
        clean, bad = image.sanitize(values)
        result = RenderResult(1, 1, values.copy(), np.zeros((1, 1, 3)), spp=1)
        mean = result.mean()
    assert f32[0, 0, 0] == np.inf and f32[0, 0, 1] == -np.inf
    assert f32[0, 0, 2] == np.float32(3.0e38) and mean[0, 0, 0] == np.inf
    assert bad == 1 and clean[0, 0].tolist() == [0.0, 0.0, np.float32(3.0e38)]
    ramp = np.random.default_rng(2).random((4, 5, 3)) * 1e3
    assert np.array_equal(image.as_float32(ramp), ramp.astype(np.float32))
