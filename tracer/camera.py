"""Blender's perspective and orthographic cameras, built as Cycles builds them, with the thin lens.

Camera space is Blender's: looking down -Z with +Y up. Raster y = 0 is the bottom row (Cycles);
images are returned top row first, so image row r is raster row H - 1 - r.
`Camera` works out the parameters once; `camera_ray` turns one pixel and lens sample into a ray
in compiled code.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .sampling import sample_regular_polygon, sample_uniform_disk
from .jit import jit, jit_inline
from .scene import aperture_radius, exact_unit_scale
from .vec import madd, mul, normalize


class CameraParams(NamedTuple):
    """What camera_ray needs, as plain numbers and arrays."""
    width: int
    height: int
    half_x: float
    half_y: float
    shift_x: float
    shift_y: float
    clip_start: float
    clip_end: float
    rotation: np.ndarray        # (3, 3) camera-to-world, scale removed
    position: np.ndarray        # (3,)
    lens_radius: float
    focus_distance: float
    blades: int
    blade_rotation: float
    inv_ratio: float
    ortho: bool                 # orthographic: half_x, half_y and shifts in scene units


class Camera:
    """A scene camera's parameters, and rays for arrays of samples (tests, tools)."""

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
        # Orthographic: the fitted dimension spans ortho_scale in scene units, and shift moves
        # the window by shift * ortho_scale (the same numbers with sensor / lens = ortho_scale).
        self.ortho = cam.get("type", "PERSP") == "ORTHO"
        half = (0.5 * cam["ortho_scale"] if self.ortho else sensor / (2.0 * cam["lens"]))
        if horizontal:
            self.half_x, self.half_y = half, half * yratio / xratio
        else:
            self.half_x, self.half_y = half * xratio / yratio, half
        unit = cam["ortho_scale"] if self.ortho else sensor / cam["lens"]
        self.shift_x = cam.get("shift_x", 0.0) * unit
        self.shift_y = cam.get("shift_y", 0.0) * unit
        self.clip_start = float(cam["clip_start"])
        self.clip_end = float(cam["clip_end"])
        m = np.asarray(cam["matrix"], dtype=np.float64)
        # Object scale plays no part in a Blender camera: keep only the rotation. A huge matrix
        # (a scene file's) is scaled by a power of two first (exact), so its norms stay finite.
        m3 = m[:3, :3] if np.abs(m[:3, :3]).max() < 1e150 else exact_unit_scale(m[:3, :3])
        self.rotation = m3 / np.linalg.norm(m3, axis=0, keepdims=True)
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

    def params(self) -> CameraParams:
        """The parameters for compiled code."""
        return CameraParams(self.width, self.height, self.half_x, self.half_y, self.shift_x,
                            self.shift_y, self.clip_start, self.clip_end,
                            np.ascontiguousarray(self.rotation), self.position.copy(),
                            float(self.lens_radius), self.focus_distance, self.blades,
                            self.blade_rotation, self.inv_ratio, self.ortho)

    def raster_to_camera(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Points (3, n) on the plane z = -1 (camera space) for raster coordinates (y = 0 at the
        bottom)."""
        cx = -self.half_x + (2.0 * self.half_x / self.width) * x + self.shift_x
        cy = -self.half_y + (2.0 * self.half_y / self.height) * y + self.shift_y
        return np.stack([cx, cy, np.full_like(cx, -1.0)])

    def lens_samples(self, u: np.ndarray) -> np.ndarray:
        """Points (2, n) on the aperture (camera space, z = 0) for uniform samples u (2, n)."""
        out = np.empty((2, u.shape[1]))
        _lens_points(self.params(), np.ascontiguousarray(u, dtype=np.float64), out)
        return out

    def generate(self, pixel: np.ndarray, u_pixel: np.ndarray, u_lens: np.ndarray | None):
        """Rays for image pixels (index = row * width + col, row 0 at the top): world-space
        origins and unit directions (3, n) and the distance to the far clip (n)."""
        n = len(pixel)
        o, d, far = np.empty((n, 3)), np.empty((n, 3)), np.empty(n)
        u_lens = np.zeros((2, n)) if u_lens is None or not self.has_lens else u_lens
        _camera_rays(self.params(), np.asarray(pixel, np.int64), np.asarray(u_pixel, np.float64),
                     np.asarray(u_lens, np.float64), o, d, far)
        return o.T, d.T, far

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pinhole raster coordinates (2, n), y from the bottom, of world points (3, n)."""
        local = self.rotation.T @ (np.asarray(points, dtype=np.float64) - self.position[:, None])
        plane = local[:2] if self.ortho else local[:2] / -local[2]
        x = (plane[0] - self.shift_x + self.half_x) / (2.0 * self.half_x) * self.width
        y = (plane[1] - self.shift_y + self.half_y) / (2.0 * self.half_y) * self.height
        return np.stack([x, y])


@jit_inline
def lens_point(cam, u0, u1):
    """A point (x, y) on the aperture in camera space (z = 0): disk or polygon, anamorphic ratio."""
    if cam.blades >= 3:
        x, y = sample_regular_polygon(u0, u1, cam.blades, cam.blade_rotation)
    else:
        x, y = sample_uniform_disk(u0, u1)
    return x * cam.inv_ratio * cam.lens_radius, y * cam.lens_radius


@jit_inline
def to_world(cam, o, d):
    """A camera-space point and direction in world space."""
    r, t = cam.rotation, cam.position
    world_o = (r[0, 0] * o[0] + r[0, 1] * o[1] + r[0, 2] * o[2] + t[0],
               r[1, 0] * o[0] + r[1, 1] * o[1] + r[1, 2] * o[2] + t[1],
               r[2, 0] * o[0] + r[2, 1] * o[1] + r[2, 2] * o[2] + t[2])
    world_d = (r[0, 0] * d[0] + r[0, 1] * d[1] + r[0, 2] * d[2],
               r[1, 0] * d[0] + r[1, 1] * d[1] + r[1, 2] * d[2],
               r[2, 0] * d[0] + r[2, 1] * d[1] + r[2, 2] * d[2])
    return world_o, world_d


@jit_inline
def camera_ray(cam, pixel, u0, u1, lens0, lens1):
    """The world-space ray (origin, unit direction, distance to the far clip) through image pixel
    `pixel` (row 0 at the top) at offset (u0, u1) in the pixel, through lens sample (lens0, lens1).

    Origins sit on the near clip plane, because Embree's tnear is fixed at 0. Cycles focuses on a
    plane: P_focus = D * focus / D.z, then D = P_focus - P_lens. Orthographic (Cycles'
    camera_sample_orthographic): parallel rays from the window's point, or with a lens from the
    window's point moved by the lens sample towards the window's point on the focus plane; the
    ray runs clip_end - clip_start from the near clip plane (which may lie behind the camera).
    """
    row = pixel // cam.width
    col = pixel - row * cam.width
    x = col + u0
    y = (cam.height - 1 - row) + u1
    cx = -cam.half_x + (2.0 * cam.half_x / cam.width) * x + cam.shift_x
    cy = -cam.half_y + (2.0 * cam.half_y / cam.height) * y + cam.shift_y
    if cam.ortho:
        d = (0.0, 0.0, -1.0)
        o = (cx, cy, 0.0)
        if cam.lens_radius > 0.0:
            lx, ly = lens_point(cam, lens0, lens1)
            d = normalize((-lx, -ly, -cam.focus_distance))
            o = (cx + lx, cy + ly, 0.0)
        o = madd(o, cam.clip_start / -d[2], d)
        world_o, world_d = to_world(cam, o, d)
        return world_o, world_d, cam.clip_end - cam.clip_start
    d = normalize((cx, cy, -1.0))
    z_inv = -1.0 / d[2]
    o = (0.0, 0.0, 0.0)
    if cam.lens_radius > 0.0:
        lx, ly = lens_point(cam, lens0, lens1)
        p_focus = mul(d, cam.focus_distance * z_inv)
        d = normalize((p_focus[0] - lx, p_focus[1] - ly, p_focus[2]))
        o = (lx, ly, 0.0)
    o = madd(o, cam.clip_start * z_inv, d)
    far = (cam.clip_end - cam.clip_start) * z_inv
    world_o, world_d = to_world(cam, o, d)
    return world_o, world_d, far


@jit_inline
def camera_connection(cam, x, lens0, lens1, margin):
    """The camera ray that sees the world point x through lens sample (lens0, lens1), as
    camera_ray makes it: (pixel, or -1 outside the image grown by `margin` pixels on each side
    (the pixel filter's reach past its pixel) or the clip range, else the image pixel nearest;
    raster x and y (y from the bottom); the ray's origin on the near clip plane; its unit
    direction; the distance from the lens point to x; the cosine of the direction to the optical
    axis; raster pixels per unit of image-plane area at distance 1)."""
    r, t = cam.rotation, cam.position
    w = (x[0] - t[0], x[1] - t[1], x[2] - t[2])
    xc = (r[0, 0] * w[0] + r[1, 0] * w[1] + r[2, 0] * w[2],      # R^T (x - t)
          r[0, 1] * w[0] + r[1, 1] * w[1] + r[2, 1] * w[2],
          r[0, 2] * w[0] + r[1, 2] * w[1] + r[2, 2] * w[2])
    lx, ly = 0.0, 0.0
    if cam.lens_radius > 0.0:
        lx, ly = lens_point(cam, lens0, lens1)
    v = (xc[0] - lx, xc[1] - ly, xc[2])
    density = (cam.width / (2.0 * cam.half_x)) * (cam.height / (2.0 * cam.half_y))
    none = (-1, 0.0, 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.0, 0.0, density)
    if cam.ortho or not v[2] < 0.0:       # the light tracer is off for orthographic cameras
        return none
    if cam.lens_radius > 0.0:
        # The line from the lens point through x meets the focus plane where the pinhole ray
        # of the same raster position does.
        s = cam.focus_distance / -v[2]
        tx, ty = (lx + v[0] * s) / cam.focus_distance, (ly + v[1] * s) / cam.focus_distance
    else:
        tx, ty = xc[0] / -xc[2], xc[1] / -xc[2]
    rx = (tx - cam.shift_x + cam.half_x) * cam.width / (2.0 * cam.half_x)
    ry = (ty - cam.shift_y + cam.half_y) * cam.height / (2.0 * cam.half_y)
    if not (-margin <= rx < cam.width + margin and -margin <= ry < cam.height + margin):
        return none
    col = min(max(int(math.floor(rx)), 0), cam.width - 1)
    row = cam.height - 1 - min(max(int(math.floor(ry)), 0), cam.height - 1)
    length = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    d = (v[0] / length, v[1] / length, v[2] / length)
    z_inv = math.sqrt(tx * tx + ty * ty + 1.0)      # -1 / d_pinhole.z, as camera_ray uses it
    near = cam.clip_start * z_inv
    if not (near < length <= cam.clip_end * z_inv):
        return none
    o = madd((lx, ly, 0.0), near, d)
    world_o, world_d = to_world(cam, o, d)
    return row * cam.width + col, rx, ry, world_o, world_d, length, -d[2], density


@jit
def _camera_rays(cam, pixel, u_pixel, u_lens, o, d, far):
    for i in range(pixel.shape[0]):
        ro, rd, f = camera_ray(cam, pixel[i], u_pixel[0, i], u_pixel[1, i], u_lens[0, i],
                               u_lens[1, i])
        for k in range(3):
            o[i, k] = ro[k]
            d[i, k] = rd[k]
        far[i] = f


@jit
def _lens_points(cam, u, out):
    for i in range(u.shape[1]):
        out[0, i], out[1, i] = lens_point(cam, u[0, i], u[1, i])

