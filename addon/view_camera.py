"""The 3D viewport's view as a Snell camera (scene format). No bpy here: plain matrices in.

Blender's viewport hands a draw call its region's matrices: the view matrix (world to view
space, looking down -Z with +Y up, as a Snell camera) and the window matrix (an OpenGL
projection: Blender's viewport sensor, lens, zoom, camera-view offset and clip range all folded
in). A perspective frustum is a pinhole camera with an off-centre window, an orthographic box an
orthographic camera with a shifted window, so the camera here is exact: the ray through every
pixel centre passes through the points the window matrix projects onto that pixel centre
(tests/blender/test_viewport.py holds it to that against `calc_matrix_camera`).
"""
from __future__ import annotations

import numpy as np

from ..tracer.scene import DEFAULT_DOF


class ViewUnsupported(Exception):
    """A view Snell cannot render; the message says what to do instead."""


def frustum(window_matrix) -> tuple[bool, float, float, float, float, float, float]:
    """(orthographic, half_x, half_y, centre_x, centre_y, near, far) of a window matrix: the
    window on the plane z = -1 of view space (orthographic: on any plane, in scene units) and
    the clip distances."""
    p = np.asarray(window_matrix, np.float64)
    if p.shape != (4, 4) or not np.isfinite(p).all():
        raise ViewUnsupported("the view's window matrix is not a finite 4x4 matrix")
    if p[0, 0] <= 0.0 or p[1, 1] <= 0.0 or abs(p[0, 1]) > 1e-9 * p[0, 0]:
        raise ViewUnsupported("the view's window matrix is not a camera projection")
    half_x, half_y = 1.0 / p[0, 0], 1.0 / p[1, 1]
    # The last row: (0, 0, -1, 0) for a perspective matrix, (0, 0, 0, 1) for an orthographic.
    if abs(p[3, 2] + 1.0) <= 1e-6 and abs(p[3, 3]) <= 1e-6:
        # x_ndc = p00 x / -z - p02: the plane z = -1 spans centre +- half.
        ortho, centre_x, centre_y = False, p[0, 2] / p[0, 0], p[1, 2] / p[1, 1]
        near, far = p[2, 3] / (p[2, 2] - 1.0), p[2, 3] / (p[2, 2] + 1.0)
    elif abs(p[3, 2]) <= 1e-6 and abs(p[3, 3] - 1.0) <= 1e-6:
        # x_ndc = p00 x + p03.
        ortho, centre_x, centre_y = True, -p[0, 3] / p[0, 0], -p[1, 3] / p[1, 1]
        near, far = (p[2, 3] + 1.0) / p[2, 2], (p[2, 3] - 1.0) / p[2, 2]
    else:
        raise ViewUnsupported("the view's window matrix is neither perspective nor orthographic")
    if not (far > near and (ortho or near > 0.0)):
        raise ViewUnsupported(f"the view's clip range {near:g} to {far:g} is empty")
    return ortho, half_x, half_y, centre_x, centre_y, near, far


def camera_from_view(view_matrix, window_matrix, width: int, height: int, *, lens: float = 50.0,
                     dof: dict | None = None, name: str = "viewport") -> dict:
    """The camera (scene format) whose pixel-centre rays land where window_matrix @
    view_matrix projects them, for a width x height region; dof: the scene camera's (camera
    view), None for none."""
    width, height = max(1, int(width)), max(1, int(height))
    ortho, half_x, half_y, centre_x, centre_y, near, far = frustum(window_matrix)
    view = np.asarray(view_matrix, np.float64)
    if view.shape != (4, 4) or not np.isfinite(view).all() or abs(np.linalg.det(view)) < 1e-30:
        raise ViewUnsupported("the view matrix is not an invertible finite 4x4 matrix")
    # tracer/camera.py with sensor fit HORIZONTAL: the window spans sensor / lens (orthographic:
    # ortho_scale) across and the pixel aspect makes the height; shifts are in units of it.
    aspect_y = (half_y / half_x) * width / height
    camera = {
        "name": name, "matrix": np.linalg.inv(view).tolist(), "lens": float(lens),
        "sensor_width": 2.0 * lens * half_x, "sensor_height": 2.0 * lens * half_y,
        "sensor_fit": "HORIZONTAL", "shift_x": centre_x / (2.0 * half_x),
        "shift_y": centre_y / (2.0 * half_x), "clip_start": near, "clip_end": far,
        "resolution": [width, height], "resolution_percentage": 100,
        "pixel_aspect": [1.0, aspect_y], "dof": dict(dof) if dof else dict(DEFAULT_DOF),
    }
    if ortho:
        camera.update(type="ORTHO", ortho_scale=2.0 * half_x)
    return camera


def scaled(camera: dict, divisor: int) -> dict:
    """The same view at 1/divisor of the resolution (at least 1 pixel a side): the coarse
    first passes."""
    width, height = camera["resolution"]
    w, h = max(1, width // divisor), max(1, height // divisor)
    out = dict(camera)
    # The pixel aspect keeps the window's height: half_y = half_x (h aspect_y) / w.
    out["pixel_aspect"] = [1.0, camera["pixel_aspect"][1] * (height / width) * (w / h)]
    out["resolution"] = [w, h]
    return out
