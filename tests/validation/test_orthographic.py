"""Orthographic cameras (the viewport's orthographic views, and F12) against Cycles.

The Cornell box with two spheres seen through an orthographic camera, with an off-centre
shift, without and with depth of field (focused on the front sphere); Cycles renders it once
per session (8 seeds) and Snell with the same samples per pixel must be `snell compare`
consistent. A 1% error in the
orthographic scale, or 15% in the aperture, must be caught.
"""
from __future__ import annotations

import importlib

import numpy as np
import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")
from mathutils import Vector  # noqa: E402

common = importlib.import_module("common")

FULL = {"resolution_percentage": 100}
SIZE = (48, 40)
SPP = 256


def build(path, fstop=None):
    """cornell_spheres' room and sphere positions through an orthographic camera (shifted; with
    depth of field focused on the front sphere at fstop, if given)."""
    scene = common.reset()
    common.setup_render(scene, SIZE)
    # A 1-pixel box: the test is of the lens's blur, which Cycles' default Blackman-Harris 1.5
    # (3 pixels wide) partly hides at 48 x 40: with it the 15% aperture error below passed
    # (image mean z -2.1 to -2.6, sharpness within bounds). The filters' own test is
    # test_pixel_filter_compare.py.
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "BOX", 1.0
    common.cornell_box()
    # Diffuse spheres: the test is of the camera, and mirror and glass would add caustics
    # whose fireflies (the light tracer does not run for orthographic cameras) make the
    # sharpness test a matter of a few samples.
    yellow = common.material("Yellow", "diffuse", (0.8, 0.7, 0.2))
    white = common.material("Plaster", "diffuse", (0.8, 0.8, 0.8))
    common.uv_sphere("YellowSphere", (-0.45, 0.35, 0.45), 0.45, yellow)
    common.uv_sphere("WhiteSphere", (0.45, -0.3, 0.45), 0.45, white)
    cam = common.camera(scene, (0.3, -3.4, 1.3), (0.0, 0.0, 0.9))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 2.3
    cam.data.shift_x, cam.data.shift_y = 0.04, -0.03
    cam.data.clip_start = 0.5
    if fstop is not None:
        cam.data.dof.use_dof = True
        cam.data.dof.aperture_fstop = fstop
        cam.data.dof.focus_distance = float((cam.location - Vector((0.45, -0.3, 0.45))).length)
    return common.save(path)


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    out = tmp_path_factory.mktemp("ortho")
    refs = {}
    for name, fstop in (("pinhole", None), ("lens", 1.0)):
        blend = build(str(out / f"{name}.blend"), fstop)
        refs[name] = Reference(blend, framing=FULL, spp=SPP)
        assert not refs[name].warnings, refs[name].warnings
    return refs


def scaled(scene, factor):
    return scene.with_camera(ortho_scale=scene.camera["ortho_scale"] * factor)


def wider_aperture(scene, factor):
    from snell.tracer.scene import aperture_radius
    return scene.with_camera(dof={"aperture_radius": aperture_radius(scene.camera) * factor})


# Measured (seed 0, 2 threads; seeds 1 and 2 alike): pinhole consistent, sharpness z 1.9, mean
# ratio 1.0048, 1.0048, 1.0031; lens (f/1: Cycles' orthographic aperture radius 1 / (2 f-stop),
# 0.5 m) consistent, z -1.1. ortho_scale x 1.01 fails the pixel, tile and image-mean tests;
# aperture x 1.15 the image mean and sharpness (z 3.2), x 1.3 also the tiles (z 6.9); the
# perspective rule lens / (2 f-stop) (x 0.035) fails everything (z -16.6).
@pytest.mark.parametrize("name", ["pinhole", "lens"])
def test_orthographic_camera_matches_cycles(references, name):
    reference = references[name]
    assert reference.scene.camera["type"] == "ORTHO"
    result = reference.compare()
    assert _verdict(result)[0] == "consistent", _verdict(result)


def test_a_one_percent_scale_error_is_caught(references):
    result = references["pinhole"].compare(lambda s: scaled(s, 1.01))
    assert _verdict(result)[0] == "inconsistent", _verdict(result)


def test_an_aperture_error_is_caught(references):
    result = references["lens"].compare(lambda s: wider_aperture(s, 1.15))
    assert _verdict(result)[0] == "inconsistent", _verdict(result)


def test_orthographic_rays_are_parallel_and_start_at_the_near_clip():
    from snell.tracer.camera import Camera
    cam = {"type": "ORTHO", "ortho_scale": 2.0, "matrix": np.eye(4).tolist(), "lens": 50.0,
           "sensor_width": 36.0, "sensor_height": 24.0, "clip_start": -1.5, "clip_end": 4.0,
           "resolution": [4, 2], "dof": {"use_dof": False, "focus_distance": 10.0, "fstop": 2.8}}
    o, d, far = Camera(cam).generate(np.arange(8), np.full((2, 8), 0.5), None)
    assert np.allclose(d, [[0.0] * 8, [0.0] * 8, [-1.0] * 8]) and np.allclose(far, 5.5)
    assert np.allclose(o[2], 1.5)                          # behind the camera: z = -clip_start
    assert np.allclose(o[0], [-0.75, -0.25, 0.25, 0.75] * 2)
    assert np.allclose(o[1], [0.25] * 4 + [-0.25] * 4)     # row 0 is the top
