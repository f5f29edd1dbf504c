"""The scene's camera as the scene file's camera dict (convert_camera)."""
from __future__ import annotations

import numpy as np

from ...tracer.scene import SceneError


# A camera's 3x3 whose columns are shorter than this, or that is this close to singular (its
# determinant over the product of its column lengths), has no direction to look in.
SINGULAR = 1e-12


def unit_columns(m):
    """The matrix with its 3x3 columns normalised (object scale removed, handedness kept); None
    if a column has no length or the columns are (nearly) parallel: a zero scale."""
    lengths = np.linalg.norm(m[:3, :3], axis=0)
    if not np.all(lengths > SINGULAR):
        return None
    out = m.copy()
    out[:3, :3] = m[:3, :3] / lengths
    if not abs(np.linalg.det(out[:3, :3])) > SINGULAR:
        return None
    return out


def convert_camera(scene, depsgraph):
    """Camera dict from scene.camera; SceneError if there is none, it is not a camera object,
    it is panoramic or its scale is zero."""
    cam_obj = scene.camera
    if cam_obj is None:
        raise SceneError(f"scene {scene.name!r} has no camera")
    if cam_obj.type != "CAMERA":
        # Blender lets any object be the scene's camera; Cycles then renders through its axes
        # with a default lens. Snell asks for a camera.
        raise SceneError(f"scene {scene.name!r}: its camera {cam_obj.name!r} is a "
                         f"{cam_obj.type.lower()} object, not a camera (set Scene > Camera to "
                         "a camera object)")
    cam_obj = cam_obj.evaluated_get(depsgraph)
    cam = cam_obj.data
    if cam.type not in ("PERSP", "ORTHO"):
        raise SceneError(f"camera {cam_obj.name!r}: only perspective and orthographic cameras "
                         f"are supported (got {cam.type})")
    world = np.array(cam_obj.matrix_world, np.float64)
    if not np.all(np.isfinite(world)):
        raise SceneError(f"camera {cam_obj.name!r}: world matrix contains NaN or Inf")
    m = unit_columns(world)
    if m is None:
        raise SceneError(f"camera {cam_obj.name!r}: its scale is zero in some axis (its world "
                         "matrix is singular), so it has no view direction")
    if not cam.clip_end > cam.clip_start:
        raise SceneError(f"camera {cam_obj.name!r}: Clip Start {cam.clip_start:g} is not below "
                         f"Clip End {cam.clip_end:g}, so nothing is in view")
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
