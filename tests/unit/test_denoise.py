"""Open Image Denoise through tracer/denoise.py: it denoises, with every prefilter and quality, any
size down to 1x1; NaN in a guiding pass is cleaned and counted; a missing or wrong library is a
DenoiseError naming what is missing, and denoise_result then keeps the noisy image."""
from __future__ import annotations

import ctypes.util
import os
import types

import numpy as np
import pytest

from snell.tracer import denoise
from snell.tracer.settings import RenderSettings


@pytest.fixture
def oidn():
    try:
        return denoise.load()
    except denoise.DenoiseError as exc:
        pytest.skip(f"no Open Image Denoise here: {exc}")


@pytest.fixture
def fresh(monkeypatch):
    """No library loaded yet (the module keeps the one it loaded)."""
    monkeypatch.setattr(denoise, "_loaded", {})


def _noisy(n=48, seed=1):
    """A smooth ramp under noise of mean 0 (exponential, as a path tracer's), and the ramp."""
    rng = np.random.default_rng(seed)
    ramp = np.repeat(np.linspace(0.2, 0.8, n)[None, :, None], n, axis=0) * np.ones(3)
    noise = rng.exponential(1.0, (n, n, 3)) - 1.0
    return (ramp * (1.0 + 0.5 * noise)).astype(np.float32), ramp


@pytest.mark.parametrize("prefilter", denoise.PREFILTERS)
@pytest.mark.parametrize("quality", denoise.QUALITIES)
def test_denoising_brings_a_noisy_image_closer_to_the_truth(oidn, prefilter, quality):
    color, truth = _noisy()
    albedo = np.full_like(color, 0.5)
    normal = np.zeros_like(color)
    normal[..., 2] = -1.0
    out = denoise.denoise(color, albedo, normal, prefilter, quality, threads=2)
    assert out.image.shape == color.shape and out.image.dtype == np.float32
    before, after = np.abs(color - truth).mean(), np.abs(out.image - truth).mean()
    assert after < 0.5 * before, (before, after)
    assert out.nan_guides == 0


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (5, 30), (16, 16)])
def test_small_images_keep_their_level(oidn, shape):
    """OIDN alone turned a 1x1 image of 0.5 into 0.11: small images are padded, then cropped."""
    color = np.full((*shape, 3), 0.5, np.float32)
    out = denoise.denoise(color, color, color, "accurate", "high", threads=1)
    assert out.image.shape == color.shape
    assert np.allclose(out.image, 0.5, rtol=0.1)


def test_nan_in_a_guiding_pass_is_cleaned_and_counted(oidn):
    color, _ = _noisy(16)
    albedo = np.full_like(color, 0.5)
    albedo[3, 4, 1] = np.nan
    albedo[5, 6] = np.inf
    out = denoise.denoise(color, albedo, None, "fast", "fast", threads=1)
    assert out.nan_guides == 2
    assert np.isfinite(out.image).all()


def test_a_missing_library_names_what_is_missing(fresh, monkeypatch):
    monkeypatch.setattr(denoise, "candidate_paths", lambda blender_dirs=(): [])
    with pytest.raises(denoise.DenoiseError) as err:
        denoise.load()
    message = str(err.value)
    assert "libOpenImageDenoise" in message and denoise.ENV_LIBRARY in message
    assert "snell[blender]" in message


def test_a_library_that_is_not_oidn_is_named(fresh, monkeypatch):
    libc = ctypes.util.find_library("c")
    if libc is None:
        pytest.skip("no C library to load")
    monkeypatch.setattr(denoise, "candidate_paths", lambda blender_dirs=(): [libc])
    with pytest.raises(denoise.DenoiseError, match="not an Open Image Denoise 2 library"):
        denoise.load()


def test_without_oidn_the_result_keeps_its_noisy_image(fresh, monkeypatch):
    monkeypatch.setattr(denoise, "candidate_paths", lambda blender_dirs=(): [])
    noisy, _ = _noisy(8)
    result = types.SimpleNamespace(mean=lambda: noisy, has_features=False)
    out = denoise.denoise_result(result, RenderSettings(denoise=True))
    assert not out.denoised and out.image is noisy
    assert "not available" in out.warning and "undenoised" in out.warning


# Where bpy 5.0.1's wheels keep OIDN's libraries (listed from PyPI's wheels' zip directories,
# 2026-11-27): the main library and the modules it loads beside it.
WHEEL_LAYOUTS = {
    "darwin": ["lib/libOpenImageDenoise.dylib", "lib/libOpenImageDenoise_core.dylib",
               "lib/libOpenImageDenoise_device_cpu.dylib", "lib/libtbb.dylib"],
    "win32": ["OpenImageDenoise.dll", "OpenImageDenoise_core.dll",
              "OpenImageDenoise_device_cpu.dll", "tbb12.dll"],
    "linux": ["lib/libOpenImageDenoise.so.2", "lib/libOpenImageDenoise_core.so.2.3.3",
              "lib/libOpenImageDenoise_device_cpu.so.2.3.3"],
}


@pytest.mark.parametrize("platform", sorted(WHEEL_LAYOUTS))
def test_the_bpy_wheels_library_is_found_on_each_platform(platform, tmp_path, monkeypatch):
    for name in WHEEL_LAYOUTS[platform]:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(b"")
    monkeypatch.delenv(denoise.ENV_LIBRARY, raising=False)
    monkeypatch.setattr(denoise.sys, "platform", platform)
    monkeypatch.setattr(denoise, "_package_dir", lambda name: str(tmp_path) if name == "bpy"
                        else None)
    monkeypatch.setattr(denoise.ctypes.util, "find_library", lambda name: None)
    found = [os.path.normpath(p) for p in denoise.candidate_paths()]
    assert found == [str(tmp_path / WHEEL_LAYOUTS[platform][0])]
