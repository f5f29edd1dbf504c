"""The world as a light: a uniform colour, or an equirectangular environment map (the HDRI
world) and its importance sampling, as Cycles does it.

Directions map to image coordinates as Cycles' Environment Texture with Blender's default range
(src/kernel/camera/projection.h, direction_to_equirectangular with range (-2 pi, pi, -pi, pi)):

    u = (pi - atan2(y, x)) / (2 pi)      +X at u = 0.5, +Y at u = 0.25, -Y at 0.75, -X at 0 / 1
    v = 1 - acos(z) / pi                 +Z at v = 1, -Z at v = 0

The image is stored top row first (as OpenImageIO reads it), and Cycles' v = 0 is the image's
bottom row, so row r of the array spans polar angles theta in [pi r / H, pi (r + 1) / H]: row 0
is the sky. The distribution is piecewise constant over texels in (u, v), each texel weighted by
its luminance times sin(theta) at the row's centre (scene/light.cpp, background_cdf); its density
in solid angle is p(u, v) / (2 pi^2 sin theta) at the direction's own theta
(kernel/light/background.h, background_map_sample). One deliberate difference: Cycles weighs a
texel by the luminance at its centre, but Linear interpolation spreads a texel's light over its
neighbours' areas, where a dark neighbour then has no density and only BSDF sampling finds that
light (a one-texel sun lost about half its light to next-event estimation that way, rendering
it as noise); here a texel's weight is the integral of the interpolated luminance over its area.
A Mapping node's Z rotation (Point type,
kernel/svm/mapping_util.h) turns the world direction d into the texture coordinate Rz(angle) d,
so the image appears turned by -angle about Z. A Mapping node in general (any type, rotation,
scale, location) makes the texture coordinate an affine function A d + b of the direction,
which the Environment Texture normalises; for b = 0 the map samples its image's distribution
in texture space and carries the density to world directions by the Jacobian
|det A| / |A d|^3, and with a location (b != 0, rare for a world) it samples directions
uniformly.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..jit import jit, jit_inline
from ..sampling import sample_uniform_sphere
from ..textures import REC709, REPEAT, sample_image
from ..vec import mat_vec


class EnvironmentMap(NamedTuple):
    """An equirectangular map and its sampling distribution, as tables for compiled code."""
    image: np.ndarray     # (H, W, 3) float32 linear RGB, top row first
    marginal: np.ndarray  # (H + 1,) float64 CDF over rows, marginal[H] = 1
    conditional: np.ndarray  # (H, W + 1) float64 CDF over each row's texels, last column 1
    strength: float
    matrix: np.ndarray    # (3, 3) A: texture coordinate = A d + offset for world direction d
    inverse: np.ndarray   # (3, 3) A^-1
    offset: np.ndarray    # (3,) b
    det: float            # |det A|
    uniform: bool         # sample directions uniformly (a location in the mapping, or asked)
    closest: bool         # Closest interpolation (else Linear)
    pixels: np.ndarray    # (H W, 3) the image's texels as rows (a view of image)


def rotation_matrix(euler) -> np.ndarray:
    """Blender's XYZ Euler rotation, Rz Ry Rx (Cycles' euler_to_transform)."""
    x, y, z = (float(a) for a in euler)
    rx = np.array([[1, 0, 0], [0, math.cos(x), -math.sin(x)], [0, math.sin(x), math.cos(x)]])
    ry = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
    rz = np.array([[math.cos(z), -math.sin(z), 0], [math.sin(z), math.cos(z), 0], [0, 0, 1]])
    return rz @ ry @ rx


def mapping_transform(kind, location, rotation, scale):
    """(A, b) of a Mapping node of kind POINT, TEXTURE, VECTOR or NORMAL: its output is A v + b
    up to a positive factor (Cycles' svm_mapping; the Environment Texture normalises it)."""
    r = rotation_matrix(rotation)
    s = np.asarray(scale, np.float64)
    location = np.asarray(location, np.float64)
    # Cycles' safe_divide: a zero scale gives a zero component.
    inv_s = np.divide(1.0, s, out=np.zeros(3), where=s != 0.0)
    if kind == "POINT":
        return r @ np.diag(s), location
    if kind == "TEXTURE":
        a = np.diag(inv_s) @ r.T
        return a, -(a @ location)
    if kind == "VECTOR":
        return r @ np.diag(s), np.zeros(3)
    if kind == "NORMAL":
        return r @ np.diag(inv_s), np.zeros(3)
    raise ValueError(f"unknown mapping type {kind!r}")


# The share of a texel's own area that Linear interpolation gives to it and to each neighbour,
# along one axis: between texel centres it blends two texels, so over a texel's area the one to
# each side weighs 1/8 and the texel itself 3/4.
LINEAR_SPREAD = (0.125, 0.75, 0.125)


def _luminance_rows(image, rows, closest):
    """Luminance (>= 0) of image rows `rows` (a range), each texel's as Linear interpolation
    spreads it: the integral of the interpolated luminance over the texel's area (neighbours
    wrap in u and v, as Cycles' Repeat extension), so that every texel whose area sees light has
    a weight. Closest reads each texel alone."""
    h = image.shape[0]
    weights = np.array(REC709, np.float32)
    if closest:
        return np.maximum(image[rows.start:rows.stop] @ weights, 0.0).astype(np.float64)
    index = np.arange(rows.start - 1, rows.stop + 1) % h
    lum = np.maximum(image[index] @ weights, 0.0).astype(np.float64)
    a, b, c = LINEAR_SPREAD
    lum = a * np.roll(lum, 1, axis=1) + b * lum + c * np.roll(lum, -1, axis=1)
    return a * lum[:-2] + b * lum[1:-1] + c * lum[2:]


def _distribution(image, closest=False):
    """(marginal, conditional) CDFs over texels of luminance x sin(theta), a band of rows at a
    time (no full-size temporary beyond the conditional table itself)."""
    h, w = image.shape[:2]
    conditional = np.empty((h, w + 1))
    conditional[:, 0] = 0.0
    row_sums = np.empty(h)
    band = max(1, (1 << 18) // w)    # rows per band: a few MB of temporaries
    for r in range(0, h, band):
        rows = range(r, min(h, r + band))
        sin_row = np.sin(np.pi * (np.arange(rows.start, rows.stop) + 0.5) / h)
        lum = _luminance_rows(image, rows, closest) * sin_row[:, None]
        np.cumsum(lum, axis=1, out=conditional[rows.start:rows.stop, 1:])
        row_sums[rows.start:rows.stop] = conditional[rows.start:rows.stop, w]
    if not row_sums.sum() > 0.0:
        # A black map is never worth sampling; a uniform-ish distribution keeps the tables valid.
        sin_row = np.sin(np.pi * (np.arange(h) + 0.5) / h)
        conditional[:, 1:] = sin_row[:, None] * np.arange(1, w + 1)[None, :]
        row_sums = conditional[:, w].copy()
    black = row_sums == 0.0
    conditional /= np.where(black, 1.0, row_sums)[:, None]     # in place: no copy of the table
    # A black row is never picked (its marginal step is 0), but keep its CDF increasing.
    conditional[black] = np.arange(w + 1) / w
    conditional[:, w] = 1.0
    marginal = np.empty(h + 1)
    marginal[0] = 0.0
    np.cumsum(row_sums, out=marginal[1:])
    marginal /= marginal[h]
    marginal[h] = 1.0
    return marginal, conditional


def build_environment(image, strength=1.0, rotation=0.0, matrix=None, offset=None,
                      closest=False, uniform=False) -> EnvironmentMap:
    """The map of a float32 (H, W, 3) linear RGB image (top row first) and its strength, seen
    through a Mapping node: a Z rotation in radians, or the node's (matrix, offset) from
    mapping_transform. uniform=True samples directions uniformly (for measurements)."""
    image = np.ascontiguousarray(image, dtype=np.float32)
    if image.ndim != 3 or image.shape[2] != 3 or image.shape[0] < 1 or image.shape[1] < 1:
        raise ValueError(f"environment image must be (H, W, 3), got {image.shape}")
    if not np.isfinite(image).all():
        raise ValueError("environment image has NaN or Inf")
    if matrix is None:
        matrix = rotation_matrix((0.0, 0.0, rotation))
    matrix = np.ascontiguousarray(matrix, np.float64)
    offset = np.zeros(3) if offset is None else np.ascontiguousarray(offset, np.float64)
    det = abs(float(np.linalg.det(matrix)))
    if not (np.isfinite(matrix).all() and np.isfinite(offset).all()) or not det > 1e-12:
        raise ValueError("environment mapping is singular (a zero scale) or not finite")
    marginal, conditional = _distribution(image, closest)
    return EnvironmentMap(image, marginal, conditional, float(strength), matrix,
                          np.linalg.inv(matrix), offset, det,
                          bool(uniform or np.any(offset != 0.0)), bool(closest),
                          image.reshape(-1, 3))


def environment_peak(env: EnvironmentMap) -> float:
    """The map's second moment of luminance over the sphere of directions over its squared mean
    (1 for a constant map; large for a small bright sun): how rarely BSDF samples find its
    light."""
    h = env.image.shape[0]
    sin_row = np.sin(np.pi * (np.arange(h) + 0.5) / h)[:, None]
    lum = np.maximum(env.image.astype(np.float64) @ np.array(REC709), 0.0)
    mean = (lum * sin_row).sum()
    if not mean > 0.0:
        return 1.0
    return float((lum * lum * sin_row).sum() * (sin_row.sum() * env.image.shape[1]) / mean ** 2)


def empty_environment() -> EnvironmentMap:
    """A 1 x 1 black map: the tables' placeholder when the world has no image."""
    return build_environment(np.zeros((1, 1, 3), np.float32), strength=0.0)


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
    """The texture coordinate of world direction d, A d + b (not normalised)."""
    t = mat_vec(env.matrix, d)
    return (t[0] + env.offset[0], t[1] + env.offset[1], t[2] + env.offset[2])


@jit
def _unit(t):
    """t / |t| and |t| (a zero vector stays zero, as Cycles' safe_normalize)."""
    n = math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2])
    if n == 0.0:
        return t, 0.0
    return (t[0] / n, t[1] / n, t[2] / n), n


@jit
def to_world(env, t):
    """The unit world direction whose texture direction is unit t (offset 0): A^-1 t, normalised."""
    return _unit(mat_vec(env.inverse, t))[0]


@jit
def texture_radiance(env, t):
    """The image at unit texture direction t times the strength: Cycles' Linear or Closest
    interpolation with the Environment Texture's Repeat extension (wrapping in u, and in v: half
    a row from a pole, the top and bottom rows blend)."""
    h, w = env.image.shape[0], env.image.shape[1]
    u, v = direction_to_equirectangular(t)
    c = sample_image(env.pixels, 0, w, h, u, v, env.closest, REPEAT)
    k = env.strength
    return (k * c[0], k * c[1], k * c[2])


@jit
def env_lookup(env, direction):
    """The radiance seen along unit world direction."""
    return texture_radiance(env, _unit(to_texture(env, direction))[0])


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
    """The density in solid angle of a texture direction in texel (row, col) at sin(theta)."""
    h, w = env.image.shape[0], env.image.shape[1]
    p_uv = (h * w * (env.marginal[row + 1] - env.marginal[row])
            * (env.conditional[row, col + 1] - env.conditional[row, col]))
    if sin_theta <= 0.0:
        return 0.0
    return p_uv / (2.0 * math.pi * math.pi * sin_theta)


@jit
def _jacobian(env, d):
    """d(texture solid angle) / d(world solid angle) at unit world direction d (offset 0):
    |det A| / |A d|^3."""
    n = _unit(mat_vec(env.matrix, d))[1]
    return env.det / (n * n * n) if n > 0.0 else 0.0


@jit
def sample_env(env, u0, u1):
    """A world direction from the map's distribution (u0 picks the row, u1 the texel in it), the
    radiance along it and its density in solid angle (0 at the poles)."""
    if env.uniform:
        direction = sample_uniform_sphere(u0, u1)
        return direction, env_lookup(env, direction), 1.0 / (4.0 * math.pi)
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
    pdf = _solid_angle_pdf(env, row, col, sin_theta) * _jacobian(env, direction)
    return direction, env_lookup(env, direction), pdf


@jit
def pdf_env(env, direction):
    """The density in solid angle with which sample_env picks unit world direction."""
    if env.uniform:
        return 1.0 / (4.0 * math.pi)
    h, w = env.image.shape[0], env.image.shape[1]
    t, n = _unit(to_texture(env, direction))
    if n == 0.0:
        return 0.0
    u, v = direction_to_equirectangular(t)
    # sin(theta) from x and y: exact near the poles, where sin(acos(z)) loses digits.
    sin_theta = math.sqrt(t[0] * t[0] + t[1] * t[1])
    col = min(max(int(u * w), 0), w - 1)
    row = min(max(int((1.0 - v) * h), 0), h - 1)
    return _solid_angle_pdf(env, row, col, sin_theta) * env.det / (n * n * n)


# -- the world as one of the scene's lights (tables.Lights) -------------------------------------

@jit_inline
def sample_world(lights, u0, u1):
    """A direction towards the world (by its map's distribution, or uniform for a colour), its
    radiance and density in solid angle."""
    if lights.has_env:
        return sample_env(lights.env, u0, u1)
    value = (lights.world[0], lights.world[1], lights.world[2])
    return sample_uniform_sphere(u0, u1), value, 1.0 / (4.0 * math.pi)


@jit_inline
def world_emission(lights, u0, u1):
    """The direction a light path from the world travels: (direction, radiance, its density in
    solid angle), drawn as next-event estimation draws the world (sample_world: the map's
    importance distribution, uniform for a colour) and reversed: light from direction d travels
    along -d, with the same density."""
    d, value, density = sample_world(lights, u0, u1)
    return (-d[0], -d[1], -d[2]), value, density


@jit_inline
def world_radiance(lights, d):
    """The world's radiance along unit direction d (a ray that escapes)."""
    if lights.has_env:
        return env_lookup(lights.env, d)
    return (lights.world[0], lights.world[1], lights.world[2])


@jit_inline
def pdf_world(lights, d):
    """Solid-angle density of light sampling picking the world in unit direction d."""
    if lights.has_env:
        return lights.world_pmf * pdf_env(lights.env, d)
    return lights.world_pmf / (4.0 * math.pi)
