"""Render border (region) support: the camera that renders only a window of the full frame.

A window of a perspective image is itself a perspective image with a narrower field of view and
an off-centre shift (of an orthographic one, an orthographic image of a smaller scale). The window
camera uses sensor fit HORIZONTAL with the sensor width that gives
the window's horizontal extent, and the shift that puts it where it was, so every window pixel
sees exactly the rays of the same pixel of the full frame (depth of field too: the lens does not
depend on the sensor). Only the random sample streams differ from a full-frame render. No bpy here.
"""
from __future__ import annotations

import copy

from ..tracer.camera import Camera


def border_pixels(full_w, full_h, border=None):
    """(x0, y0, w, h) in pixels, y from the bottom, as Blender computes its render region.

    border is (min_x, max_x, min_y, max_y) in [0, 1] or None for the full frame. Blender truncates
    (render_init_from_main: disprect = border * winx), so this does too.
    """
    if border is None:
        return 0, 0, full_w, full_h
    min_x, max_x, min_y, max_y = border
    x0, x1 = int(min_x * full_w), int(max_x * full_w)
    y0, y1 = int(min_y * full_h), int(max_y * full_h)
    return x0, y0, max(1, x1 - x0), max(1, y1 - y0)


def window_camera(cam: dict, x0: int, y0: int, w: int, h: int) -> dict:
    """The camera dict (scene format) that renders pixels [x0, x0+w) x [y0, y0+h) of cam's frame."""
    full = Camera(cam)
    if (x0, y0, w, h) == (0, 0, full.width, full.height):
        return cam
    out = copy.deepcopy(cam)
    lens = float(cam["lens"])
    # Extents on the plane z = -1 of the full frame, and of the window inside it.
    half_x = full.half_x * w / full.width
    half_y = full.half_y * h / full.height
    centre_x = -full.half_x + 2.0 * full.half_x * (x0 + 0.5 * w) / full.width + full.shift_x
    centre_y = -full.half_y + 2.0 * full.half_y * (y0 + 0.5 * h) / full.height + full.shift_y
    sensor = 2.0 * lens * half_x
    out.update({"resolution": [int(w), int(h)], "resolution_percentage": 100,
                "sensor_fit": "HORIZONTAL", "sensor_width": sensor,
                "shift_x": centre_x * lens / sensor, "shift_y": centre_y * lens / sensor})
    if full.ortho:      # the same window in scene units: ortho_scale spans it across
        out["ortho_scale"] = 2.0 * half_x
    # The vertical extent follows from the pixel aspect: check it is the window's.
    check = Camera(out)
    assert abs(check.half_y - half_y) <= 1e-9 * max(1.0, half_y), (check.half_y, half_y)
    return out
