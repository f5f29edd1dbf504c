"""The object and camera tables of shader programs (tracer/shader/object_inputs.py) without
Blender: Cycles' random number of a random id, the Window coordinate against the camera's own
projection (which the light tracer splats through), the object-space normal, and the scene
loader's checks of the objects' optional fields (tests/validation/test_object_inputs.py holds
the nodes against Cycles)."""
from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from snell.tracer import scene as scene_mod
from snell.tracer.camera import Camera
from snell.tracer.scene import SceneError
from snell.tracer.shader import object_inputs as oi
from support.builders import camera, tiny_scene


def test_random_number_is_cycles_float32_scaling():
    """float32(random_id) * 2^-32 (scene/object.cpp): 0, 1/2, and 1 for ids that round up
    to 2^32 in float32. Teeth: the exact quotient id / (2^32 - 1) differs from it at 2^31 + 1
    (where float32 rounds the id), caught."""
    assert oi.random_number(0) == 0.0
    assert oi.random_number(2 ** 31) == 0.5
    assert oi.random_number(2 ** 32 - 1) == 1.0
    assert oi.random_number(2 ** 31 + 1) == 0.5          # float32 has 24 bits
    assert (2 ** 31 + 1) / (2 ** 32 - 1) != 0.5


@pytest.mark.parametrize("kind", ["PERSP", "ORTHO"])
def test_window_is_the_camera_projection(kind):
    """The Window coordinate of points in view equals the camera's raster position (Camera.
    project) over the resolution, for a rotated, shifted camera of a 40 x 24 frame. Teeth: the
    shift left out of the view plane moves it by 0.1 or more, caught."""
    m = np.eye(4)
    angle = 0.3
    m[:3, :3] = [[math.cos(angle), 0.0, math.sin(angle)], [0.0, 1.0, 0.0],
                 [-math.sin(angle), 0.0, math.cos(angle)]]
    m[:3, 3] = (0.5, -0.2, 4.0)
    cam = Camera(camera(resolution=(40, 24), type=kind, ortho_scale=3.0, shift_x=0.1,
                        shift_y=-0.05, matrix=m.tolist()))
    rng = np.random.default_rng(1)
    points = cam.position + cam.rotation @ np.array([0, 0, -3.0]) + rng.uniform(-1, 1, (50, 3))
    table = oi.camera_table(cam)
    got = np.array([oi.window(table, tuple(p)) for p in points])
    raster = cam.project(points.T).T / [cam.width, cam.height]
    assert np.allclose(got[:, :2], raster, atol=1e-12) and not got[:, 2].any()
    unshifted = table.copy()
    unshifted[oi.CAM_LEFT] -= cam.shift_x
    wrong = np.array([oi.window(unshifted, tuple(p)) for p in points])
    assert np.abs(wrong[:, :2] - raster).max() > 0.1


def test_object_normal_is_the_inverse_normal_transform():
    """normalize(M^T n): the world normal of an object-space normal a (normalize(M^-T a))
    goes back to a; under an unequal scale, M^-1 n does not."""
    m = np.diag([1.5, 0.5, 2.0]) @ np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0, 0, 1.0]])
    row = np.hstack([m, [[1.0], [2.0], [3.0]]]).ravel()
    a = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    n = np.linalg.inv(m).T @ a
    n /= np.linalg.norm(n)
    assert np.allclose(oi.object_normal(row, tuple(n)), a, atol=1e-12)
    wrong = np.linalg.inv(m) @ n
    assert not np.allclose(wrong / np.linalg.norm(wrong), a, atol=1e-3)


def test_object_table_defaults_and_fields():
    """Objects without the optional fields read Blender's defaults; with them, their values."""
    table = oi.object_table([{"name": "a"}, {"name": "b", "matrix": np.eye(4).tolist(),
                                              "color": [0.1, 0.2, 0.3, 0.4], "pass_index": 5,
                                              "random_id": 2 ** 31}])
    assert table[0, oi.OBJ_COLOR:oi.OBJ_ALPHA + 1].tolist() == [1, 1, 1, 1]
    assert table[0, oi.OBJ_RANDOM] == 0.0 and table[0, oi.OBJ_PASS_INDEX] == 0.0
    assert table[1, oi.OBJ_COLOR:oi.OBJ_RANDOM + 1].tolist() == [0.1, 0.2, 0.3, 0.4, 5, 0.5]


@pytest.mark.parametrize("field, value, message", [
    ("matrix", [[1, 0, 0]], "objects[0].matrix: expected a 4x4 matrix"),
    ("color", [1, 1, 1], "objects[0].color: expected 4 numbers"),
    ("color", [1, 1, float("nan"), 1], "objects[0].color: contains NaN or Inf"),
    ("pass_index", -1, "objects[0].pass_index: expected integer from 0"),
    ("pass_index", 1.5, "objects[0].pass_index: expected integer from 0"),
    ("random_id", 2 ** 32, "objects[0].random_id: expected a 32-bit unsigned integer"),
    ("random_id", True, "objects[0].random_id: expected a 32-bit unsigned integer"),
])
def test_bad_object_fields_are_errors_naming_them(field, value, message):
    scene = copy.copy(tiny_scene())
    scene.objects = [{"name": "Quad", "closed": False, field: value}]
    with pytest.raises(SceneError, match=message.replace("[", r"\[").replace("]", r"\]")):
        scene_mod.validate(scene)


def test_object_fields_survive_a_scene_file(tmp_path):
    """Saved and loaded, the objects keep their fields; a scene without them still loads."""
    scene = copy.copy(tiny_scene())
    scene.objects = [{"name": "Quad", "closed": False, "matrix": np.eye(4).tolist(),
                      "color": [0.1, 0.2, 0.3, 0.4], "pass_index": 2, "random_id": 123}]
    scene_mod.save(scene, tmp_path / "a.snell")
    assert scene_mod.load(tmp_path / "a.snell").objects == scene.objects
    scene_mod.save(tiny_scene(), tmp_path / "b.snell")
    assert scene_mod.load(tmp_path / "b.snell").objects == [{"name": "Quad", "closed": False}]


def test_a_renderer_with_another_camera_has_its_camera_table():
    """Renderer.with_camera (the viewport's moving view) gives programs the new camera's
    Camera, Window and Camera Data; the first renderer keeps its own."""
    from snell.tracer.integrator import Renderer
    scene = tiny_scene()
    renderer = Renderer(scene)
    assert np.array_equal(renderer.materials.camera, oi.camera_table(Camera(scene.camera)))
    moved = dict(scene.camera, matrix=camera(position=(1.0, 2.0, 3.0))["matrix"])
    other = renderer.with_camera(moved)
    assert np.array_equal(other.materials.camera, oi.camera_table(Camera(moved)))
    assert not np.array_equal(other.materials.camera, renderer.materials.camera)
