"""The scene's camera as the scene file's camera dict (convert_camera)."""
from __future__ import annotations

import numpy as np

from ...tracer.scene import SceneError


def unit_columns(m):
    """The matrix with its 3x3 columns normalised (object scale removed, handedness kept)."""
    out = m.copy()
    out[:3, :3] = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    return out


def convert_camera(scene, depsgraph):
    """Camera dict from scene.camera; SceneError if there is none or it is panoramic."""
    cam_obj = scene.camera
    if cam_obj is None:
        raise SceneError(f"scene {scene.name!r} has no camera")
    cam_obj = cam_obj.evaluated_get(depsgraph)
    cam = cam_obj.data
    if cam.type not in ("PERSP", "ORTHO"):
        raise SceneError(f"camera {cam_obj.name!r}: only perspective and orthographic cameras "
                         f"are supported (got {cam.type})")
    m = np.array(cam_obj.matrix_world, np.float64)
    if not np.all(np.isfinite(m)):
        raise SceneError(f"camera {cam_obj.name!r}: world matrix contains NaN or Inf")
    m = unit_columns(m)
    dof = cam.dof
    focus = float(dof.focus_distance)
    if dof.focus_object is not None:
        target = np.array(dof.focus_object.evaluated_get(depsgraph).matrix_world.translation)
        view_dir = -m[:3, 2]
        focus = abs(float(np.dot(view_dir, m[:3, 3] - target)))
    r = scene.render
    ortho = {"type": "ORTHO", "ortho_scale": float(cam.ortho_scale)} if cam.type == "ORTHO" else {}
    return {
        **ortho, "name": cam_obj.name, "matrix": m.tolist(), "lens": float(cam.lens),
        "sensor_width": float(cam.sensor_width), "sensor_height": float(cam.sensor_height),
        "sensor_fit": cam.sensor_fit, "shift_x": float(cam.shift_x), "shift_y": float(cam.shift_y),
        "clip_start": float(cam.clip_start), "clip_end": float(cam.clip_end),
        "resolution": [int(r.resolution_x), int(r.resolution_y)],
        "resolution_percentage": int(r.resolution_percentage),
        "pixel_aspect": [float(r.pixel_aspect_x), float(r.pixel_aspect_y)],
        "dof": {"use_dof": bool(dof.use_dof), "focus_distance": focus,
                "fstop": float(dof.aperture_fstop), "blades": int(dof.aperture_blades),
                "rotation": float(dof.aperture_rotation), "ratio": float(dof.aperture_ratio)},
    }
