"""`snell render --denoise`: the denoised image as the EXR's main layer, the noisy image and the
guiding passes as layers named as Blender names them, the PNG denoised; without OIDN, or at 1x1,
a clear message and a written image."""
from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import OpenImageIO as oiio
import pytest

from snell.tracer import image
from snell.tracer.denoise import ENV_LIBRARY
from snell.tracer.scene import save
from support.builders import camera, make_scene, quad

WALL = (0.8, 0.3, 0.1)
LAYERS = ("Noisy Image", "Denoising Albedo", "Denoising Normal")


def run(*args, env=None):
    return subprocess.run([sys.executable, "-m", "snell.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=900,
                          env=None if env is None else {**os.environ, **env})


@pytest.fixture(scope="module")
def warm():
    from snell.tracer import integrator
    if not integrator.kernels_compiled():
        integrator.warm_up()


def wall_scene(tmp_path, resolution=(24, 24)):
    """A diffuse wall under a white world, filling the view."""
    wall = (*quad((0.0, 0.0, -1.0), 10.0, 10.0), 0)
    scene = make_scene([wall], [{"name": "Wall", "kind": "diffuse", "color": list(WALL)}],
                       camera(resolution=resolution), world=(1.0, 1.0, 1.0), spp=2)
    path = tmp_path / "wall.snell"
    save(scene, str(path))
    return path


def channels(path):
    inp = oiio.ImageInput.open(str(path))
    try:
        return list(inp.spec().channelnames)
    finally:
        inp.close()


def layer(path, name):
    return np.stack([image.read_channel(path, f"{name}.{c}") for c in "RGB"], axis=-1)


def test_denoise_writes_the_denoised_image_and_the_passes_as_layers(tmp_path, warm):
    out, png = tmp_path / "wall.exr", tmp_path / "wall.png"
    proc = run("render", wall_scene(tmp_path), "-o", out, "--png", png, "--denoise",
               "--threads", "2")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == "" and "denoised in" in proc.stdout
    names = channels(out)
    assert names[:3] == ["R", "G", "B"] and "samples" in names
    for name in LAYERS:
        assert [f"{name}.{c}" for c in "RGB"] == [n for n in names if n.startswith(name + ".")]
    main, noisy = image.read_exr(out), layer(out, "Noisy Image")
    truth = np.array(WALL)     # a diffuse wall under a white world: radiance = albedo
    assert np.abs(main - truth).mean() < 0.5 * np.abs(noisy - truth).mean()
    assert np.allclose(layer(out, "Denoising Albedo"), WALL, atol=1e-6)
    assert np.allclose(layer(out, "Denoising Normal"), (0.0, 0.0, -1.0), atol=1e-6)
    written = oiio.ImageInput.open(str(png))
    try:
        assert np.array_equal(written.read_image("uint8"), image.to_srgb8(main))
    finally:
        written.close()


def test_without_denoise_the_exr_is_as_before(tmp_path, warm):
    out = tmp_path / "plain.exr"
    proc = run("render", wall_scene(tmp_path), "-o", out, "--threads", "2")
    assert proc.returncode == 0, proc.stderr
    assert channels(out) == ["R", "G", "B", "samples"]


def test_a_missing_oidn_writes_the_noisy_image_with_a_warning(tmp_path, warm):
    out = tmp_path / "wall.exr"
    proc = run("render", wall_scene(tmp_path), "-o", out, "--denoise", "--threads", "2",
               env={ENV_LIBRARY: str(tmp_path / "libOpenImageDenoise.so.2")})
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("snell: warning: ")
    assert "Open Image Denoise" in lines[0] and "undenoised" in lines[0]
    assert "Traceback" not in proc.stderr and "not denoised" in proc.stdout
    assert np.array_equal(image.read_exr(out), layer(out, "Noisy Image"))
    assert np.allclose(layer(out, "Denoising Albedo"), WALL, atol=1e-6)


def test_a_1x1_render_denoises(tmp_path, warm):
    out = tmp_path / "one.exr"
    proc = run("render", wall_scene(tmp_path, (1, 1)), "-o", out, "--denoise", "--spp", "64",
               "--threads", "1")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    main = image.read_exr(out)
    assert main.shape == (1, 1, 3) and np.allclose(main, WALL, rtol=0.15)
