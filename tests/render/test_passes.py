"""`snell render --passes` (#33): Blender's data and light passes as layers of the EXR, exact on
a scene whose answers are known, and the passes Snell cannot make left out with a warning. Against
Cycles' own passes: tests/validation/test_data_passes_compare.py."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from snell import cli
from snell.tracer import image
from snell.tracer.data_passes import BACKGROUND_DEPTH, data_passes
from snell.tracer.integrator import Renderer
from snell.tracer.scene import save
from support.builders import EMISSION, tiny_scene


def quad_scene():
    """tiny_scene: the camera at the origin looking down -Z at a quad at z = -2 over the top
    half of the 8x8 view; its object's pass index 7."""
    scene = tiny_scene()
    scene.objects = [{**scene.objects[0], "pass_index": 7}]
    return scene


def test_data_passes_of_a_known_quad():
    scene = quad_scene()
    passes = data_passes(Renderer(scene, scene.settings(threads=1)),
                         ["Depth", "Position", "Normal", "Object Index"])
    top, bottom = slice(0, 3), slice(5, 8)
    np.testing.assert_allclose(passes["Depth"][top], 2.0, rtol=1e-6)
    assert np.all(passes["Depth"][bottom] == BACKGROUND_DEPTH)
    np.testing.assert_allclose(passes["Position"][top][..., 2], -2.0, rtol=1e-6)
    # The quad faces +Z, towards the camera: its normal as is.
    np.testing.assert_allclose(passes["Normal"][top], np.broadcast_to([0, 0, 1], (3, 8, 3)),
                               atol=1e-6)
    assert np.all(passes["Normal"][bottom] == 0.0)
    assert np.all(passes["Object Index"][top] == 7.0) and np.all(passes["Object Index"][bottom] == 0.0)


def test_back_faces_normal_faces_the_viewer():
    scene = quad_scene()
    scene.positions = scene.positions[[1, 0, 3, 2]]        # the same quad, wound the other way
    passes = data_passes(Renderer(scene, scene.settings(threads=1)), ["Normal"])
    np.testing.assert_allclose(passes["Normal"][:3], np.broadcast_to([0, 0, 1], (3, 8, 3)),
                               atol=1e-6)


def test_snell_render_writes_the_passes_as_blender_names_them(tmp_path):
    path, out = tmp_path / "quad.snell", tmp_path / "quad.exr"
    save(quad_scene(), str(path))
    proc = subprocess.run([sys.executable, "-m", "snell.cli", "render", str(path), "-o",
                           str(out), "--threads", "1",
                           "--passes", "depth,Normal,object index,Debug Sample Count,Mist,"
                                       "Emission,environment,Diffuse Color,Glossy Direct"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "pass 'Mist' is not rendered by Snell yet: left out" in proc.stderr
    assert "Emission" not in proc.stderr
    assert np.allclose(image.read_channel(str(out), "Depth.Z")[:3], 2.0)
    assert np.all(image.read_channel(str(out), "Object Index.X")[:3] == 7.0)
    assert np.allclose(image.read_channel(str(out), "Normal.Z")[:3], 1.0)
    assert np.all(image.read_channel(str(out), "Debug Sample Count.X") == 4)
    # The light passes (tracer/light_passes.py): the emissive quad seen directly is Emission,
    # the black world Environment; no surface scatters, so no Color and no Direct light.
    assert np.allclose(image.read_channel(str(out), "Emission.R")[:3], EMISSION)
    assert np.all(image.read_channel(str(out), "Emission.G")[5:] == 0.0)
    assert np.all(image.read_channel(str(out), "Environment.B") == 0.0)
    assert np.all(image.read_channel(str(out), "Diffuse Color.R") == 0.0)
    assert np.all(image.read_channel(str(out), "Glossy Direct.G") == 0.0)
    with pytest.raises(OSError):
        image.read_channel(str(out), "Mist.R")


def test_an_unknown_pass_is_a_usage_error(tmp_path, capsys):
    path = tmp_path / "quad.snell"
    save(quad_scene(), str(path))
    with pytest.raises(SystemExit) as exit_:
        cli.main(["render", str(path), "-o", str(tmp_path / "x.exr"), "--passes", "Depht"])
    assert exit_.value.code == 2
    assert "no pass 'Depht'" in capsys.readouterr().err
