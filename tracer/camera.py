"""Blender's perspective camera, built as Cycles builds it, with the thin lens.

Camera space is Blender's: looking down -Z with +Y up. Raster y = 0 is the bottom row (Cycles);
images are returned top row first, so the integrator maps image row r to raster row H - 1 - r.
"""
from __future__ import annotations

import numpy as np

from . import bsdf
from .scene import aperture_radius


class Camera:
    """Turns pixel and lens samples into world-space rays."""

    def __init__(self, cam: dict):
        pct = cam.get("resolution_percentage", 100)
        # Blender truncates: BKE_render_resolution does (res * percentage) / 100 in integers.
        self.width = max(1, cam["resolution"][0] * pct // 100)
        self.height = max(1, cam["resolution"][1] * pct // 100)
        aspect_x, aspect_y = cam.get("pixel_aspect", [1.0, 1.0])
        xratio, yratio = self.width * aspect_x, self.height * aspect_y
        fit = cam.get("sensor_fit", "AUTO")
        if fit == "AUTO":
            horizontal, sensor = xratio > yratio, cam["sensor_width"]
        elif fit == "HORIZONTAL":
            horizontal, sensor = True, cam["sensor_width"]
        else:
            horizontal, sensor = False, cam["sensor_height"]
        # The fitted dimension spans +-sensor / (2 lens) on the plane z = -1; the other one
        # follows the aspect ratio. Shift moves the window by shift * sensor / lens.
        half = sensor / (2.0 * cam["lens"])
        if horizontal:
            self.half_x, self.half_y = half, half * yratio / xratio
        else:
            self.half_x, self.half_y = half * xratio / yratio, half
        self.shift_x = cam.get("shift_x", 0.0) * sensor / cam["lens"]
        self.shift_y = cam.get("shift_y", 0.0) * sensor / cam["lens"]
        self.clip_start = float(cam["clip_start"])
        self.clip_end = float(cam["clip_end"])
        m = np.asarray(cam["matrix"], dtype=np.float64)
        # Object scale plays no part in a Blender camera: keep only the rotation.
        self.rotation = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0, keepdims=True)
        self.position = m[:3, 3].copy()
        dof = cam["dof"]
        self.lens_radius = aperture_radius(cam)
        self.focus_distance = float(dof.get("focus_distance", 10.0))
        self.blades = int(dof.get("blades", 0))
        self.blade_rotation = float(dof.get("rotation", 0.0))
        self.inv_ratio = 1.0 / float(dof.get("ratio", 1.0))

    @property
    def has_lens(self) -> bool:
        """Whether rays need lens samples (depth of field on with a non-zero aperture)."""
        return self.lens_radius > 0.0

    def raster_to_camera(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Points (3, n) on the plane z = -1 (camera space) for raster coordinates (y = 0 at the bottom)."""
        cx = -self.half_x + (2.0 * self.half_x / self.width) * x + self.shift_x
        cy = -self.half_y + (2.0 * self.half_y / self.height) * y + self.shift_y
        return np.stack([cx, cy, np.full_like(cx, -1.0)])

    def lens_samples(self, u: np.ndarray) -> np.ndarray:
        """Points (2, n) on the aperture (camera space, z = 0) for uniform samples u (2, n)."""
        if self.blades >= 3:
            p = bsdf.sample_regular_polygon(u, self.blades, self.blade_rotation)
        else:
            p = bsdf.sample_uniform_disk(u)
        p[0] *= self.inv_ratio
        return p * self.lens_radius

    def generate(self, pixel: np.ndarray, u_pixel: np.ndarray, u_lens: np.ndarray | None):
        """Rays for image pixels (index = row * width + col, row 0 at the top).

        u_pixel and u_lens are (2, n) uniform samples. Returns world-space origins and unit
        directions, both (3, n) float64, and the distance from origin to the far clip. Origins
        already sit on the near clip plane, because Embree's tnear is fixed at 0.
        """
        row, col = np.divmod(pixel, self.width)
        x = col + u_pixel[0]
        y = (self.height - 1 - row) + u_pixel[1]
        d_pinhole = bsdf.normalize(self.raster_to_camera(x, y))
        z_inv = -1.0 / d_pinhole[2]
        if self.has_lens and u_lens is not None:
            lens = self.lens_samples(u_lens)
            # Cycles focuses on a plane: P_focus = D * focus / D.z, then D = P_focus - P_lens.
            p_focus = d_pinhole * (self.focus_distance * z_inv)
            p_focus[:2] -= lens
            d = bsdf.normalize(p_focus)
            origin = np.zeros_like(d)
            origin[:2] = lens
        else:
            origin = np.zeros_like(d_pinhole)
            d = d_pinhole
        origin += d * (self.clip_start * z_inv)
        far = (self.clip_end - self.clip_start) * z_inv
        world_o = self.rotation @ origin + self.position[:, None]
        world_d = self.rotation @ d
        return world_o, world_d, far

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pinhole raster coordinates (2, n), y from the bottom, of world points (3, n)."""
        local = self.rotation.T @ (np.asarray(points, dtype=np.float64) - self.position[:, None])
        plane = local[:2] / -local[2]
        x = (plane[0] - self.shift_x + self.half_x) / (2.0 * self.half_x) * self.width
        y = (plane[1] - self.shift_y + self.half_y) / (2.0 * self.half_y) * self.height
        return np.stack([x, y])
