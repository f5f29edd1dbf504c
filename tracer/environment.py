"""An equirectangular environment map and its importance sampling, as Cycles does it.

Directions map to image coordinates as Cycles' Environment Texture with Blender's default range
(src/kernel/camera/projection.h, direction_to_equirectangular with range (-2 pi, pi, -pi, pi)):

    u = (pi - atan2(y, x)) / (2 pi)      +X at u = 0.5, +Y at u = 0.25, -Y at 0.75, -X at 0 / 1
    v = 1 - acos(z) / pi                 +Z at v = 1, -Z at v = 0

The image is stored top row first (as OpenImageIO reads it), and Cycles' v = 0 is the image's
bottom row, so row r of the array spans polar angles theta in [pi r / H, pi (r + 1) / H]: row 0
is the sky. The distribution is piecewise constant over texels in (u, v), each texel weighted by
its luminance times sin(theta) at the row's centre (scene/light.cpp, background_cdf); its density
in solid angle is p(u, v) / (2 pi^2 sin theta) at the direction's own theta
(kernel/light/background.h, background_map_sample). A Mapping node's Z rotation (Point type,
kernel/svm/mapping_util.h) turns the world direction d into the texture coordinate Rz(angle) d,
so the image appears turned by -angle about Z.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .jit import jit

REC709 = np.array([0.2126, 0.7152, 0.0722])


class EnvironmentMap(NamedTuple):
    """An equirectangular map and its sampling distribution, as tables for compiled code."""
    image: np.ndarray     # (H, W, 3) float32 linear RGB, top row first
    marginal: np.ndarray  # (H + 1,) float64 CDF over rows, marginal[H] = 1
    conditional: np.ndarray  # (H, W + 1) float64 CDF over each row's texels, last column 1
    strength: float
    rot_cos: float        # cos and sin of the Mapping node's Z rotation
    rot_sin: float


def build_environment(image, strength=1.0, rotation=0.0) -> EnvironmentMap:
    """The map of a float32 (H, W, 3) linear RGB image (top row first), its strength and the Z
    rotation in radians of a Mapping node in front of it."""
    image = np.ascontiguousarray(image, dtype=np.float32)
    if image.ndim != 3 or image.shape[2] != 3 or image.shape[0] < 1 or image.shape[1] < 1:
        raise ValueError(f"environment image must be (H, W, 3), got {image.shape}")
    if not np.isfinite(image).all():
        raise ValueError("environment image has NaN or Inf")
    h, w = image.shape[:2]
    sin_row = np.sin(np.pi * (np.arange(h) + 0.5) / h)
    # Negative luminance (an EXR may hold negative components) would make the CDF decrease.
    weights = np.maximum(image @ REC709.astype(np.float32), 0.0).astype(np.float64)
    weights *= sin_row[:, None]
    if not weights.sum() > 0.0:
        # A black map is never worth sampling; a uniform-ish distribution keeps the tables valid.
        weights = np.broadcast_to(sin_row[:, None], (h, w)).copy()
    row_sums = weights.sum(axis=1)
    conditional = np.empty((h, w + 1))
    conditional[:, 0] = 0.0
    np.cumsum(weights, axis=1, out=conditional[:, 1:])
    del weights
    black = row_sums == 0.0
    conditional[~black] /= row_sums[~black, None]
    # A black row is never picked (its marginal step is 0), but keep its CDF increasing.
    conditional[black] = np.arange(w + 1) / w
    conditional[:, w] = 1.0
    marginal = np.empty(h + 1)
    marginal[0] = 0.0
    np.cumsum(row_sums, out=marginal[1:])
    marginal /= marginal[h]
    marginal[h] = 1.0
    return EnvironmentMap(image, marginal, conditional, float(strength), math.cos(rotation),
                          math.sin(rotation))


@jit
def direction_to_equirectangular(d):
    """Cycles' (u, v) of a unit direction (default range: +X at u = 0.5, +Z at v = 1)."""
    u = (math.pi - math.atan2(d[1], d[0])) / (2.0 * math.pi)
    v = 1.0 - math.acos(min(1.0, max(-1.0, d[2]))) / math.pi
    return u, v


@jit
def equirectangular_to_direction(u, v):
    """The unit direction at Cycles' (u, v) (the inverse of direction_to_equirectangular)."""
    phi = math.pi - 2.0 * math.pi * u
    theta = math.pi * (1.0 - v)
    s = math.sin(theta)
    return (s * math.cos(phi), s * math.sin(phi), math.cos(theta))


@jit
def to_texture(env, d):
    """The texture coordinate of world direction d: Rz(rotation) d."""
    c, s = env.rot_cos, env.rot_sin
    return (c * d[0] - s * d[1], s * d[0] + c * d[1], d[2])


@jit
def to_world(env, t):
    """The world direction of texture coordinate t: Rz(-rotation) t."""
    c, s = env.rot_cos, env.rot_sin
    return (c * t[0] + s * t[1], -s * t[0] + c * t[1], t[2])


@jit
def _texel(image, row, col):
    """The texel's RGB as float64."""
    return (float(image[row, col, 0]), float(image[row, col, 1]), float(image[row, col, 2]))


@jit
def env_lookup(env, direction):
    """The radiance seen along unit world direction: bilinear in the image (Cycles' Linear
    interpolation), wrapping in u and clamped in v, times the strength."""
    h, w = env.image.shape[0], env.image.shape[1]
    u, v = direction_to_equirectangular(to_texture(env, direction))
    # Texel centres sit at (i + 0.5) / W, as in Cycles' image lookup; rows count from the top.
    x = u * w - 0.5
    y = (1.0 - v) * h - 0.5
    x0f, y0f = math.floor(x), math.floor(y)
    tx, ty = x - x0f, y - y0f
    x0 = int(x0f) % w
    x1 = (x0 + 1) % w
    y0 = min(max(int(y0f), 0), h - 1)
    y1 = min(max(int(y0f) + 1, 0), h - 1)
    a, b = _texel(env.image, y0, x0), _texel(env.image, y0, x1)
    c, d = _texel(env.image, y1, x0), _texel(env.image, y1, x1)
    k = env.strength
    return (k * ((1 - ty) * ((1 - tx) * a[0] + tx * b[0]) + ty * ((1 - tx) * c[0] + tx * d[0])),
            k * ((1 - ty) * ((1 - tx) * a[1] + tx * b[1]) + ty * ((1 - tx) * c[1] + tx * d[1])),
            k * ((1 - ty) * ((1 - tx) * a[2] + tx * b[2]) + ty * ((1 - tx) * c[2] + tx * d[2])))


@jit
def _upper_index(cdf, x):
    """The i with cdf[i] <= x < cdf[i + 1], skipping empty steps (x in [0, 1), cdf from 0 to 1)."""
    count = cdf.shape[0] - 1
    lo, hi = 0, count
    while lo < hi:
        mid = (lo + hi) >> 1
        if cdf[mid + 1] <= x:
            lo = mid + 1
        else:
            hi = mid
    return min(lo, count - 1)


@jit
def _solid_angle_pdf(env, row, col, sin_theta):
    """The density in solid angle of a direction in texel (row, col) at sin(theta)."""
    h, w = env.image.shape[0], env.image.shape[1]
    p_uv = (h * w * (env.marginal[row + 1] - env.marginal[row])
            * (env.conditional[row, col + 1] - env.conditional[row, col]))
    if sin_theta <= 0.0:
        return 0.0
    return p_uv / (2.0 * math.pi * math.pi * sin_theta)


@jit
def sample_env(env, u0, u1):
    """A world direction from the map's distribution (u0 picks the row, u1 the texel in it), the
    radiance along it and its density in solid angle (0 at the poles)."""
    h, w = env.image.shape[0], env.image.shape[1]
    row = _upper_index(env.marginal, u0)
    m0, m1 = env.marginal[row], env.marginal[row + 1]
    dy = (u0 - m0) / (m1 - m0) if m1 > m0 else 0.5
    col = _upper_index(env.conditional[row], u1)
    c0, c1 = env.conditional[row, col], env.conditional[row, col + 1]
    dx = (u1 - c0) / (c1 - c0) if c1 > c0 else 0.5
    dy = min(max(dy, 0.0), 1.0)
    dx = min(max(dx, 0.0), 1.0)
    theta = math.pi * (row + dy) / h
    phi = math.pi - 2.0 * math.pi * (col + dx) / w
    sin_theta = math.sin(theta)
    t = (sin_theta * math.cos(phi), sin_theta * math.sin(phi), math.cos(theta))
    direction = to_world(env, t)
    return direction, env_lookup(env, direction), _solid_angle_pdf(env, row, col, sin_theta)


@jit
def pdf_env(env, direction):
    """The density in solid angle with which sample_env picks unit world direction."""
    h, w = env.image.shape[0], env.image.shape[1]
    t = to_texture(env, direction)
    u, v = direction_to_equirectangular(t)
    # sin(theta) from x and y: exact near the poles, where sin(acos(z)) loses digits.
    sin_theta = math.sqrt(t[0] * t[0] + t[1] * t[1])
    col = min(max(int(u * w), 0), w - 1)
    row = min(max(int((1.0 - v) * h), 0), h - 1)
    return _solid_angle_pdf(env, row, col, sin_theta)
