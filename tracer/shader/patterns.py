"""Cycles' pattern textures: Checker, Brick, Gradient, Wave, Magic and White Noise.

Follows Blender 5.0's intern/cycles/kernel/svm/checker.h (svm_checker), brick.h (brick_noise,
svm_brick), gradient.h (svm_gradient), wave.h (svm_wave), magic.h (svm_magic) and white_noise.h
(svm_node_tex_white_noise).
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import jit
from .hashes import hash_float2_to_float, hash_float2_to_float3, hash_float3_to_float, \
    hash_float3_to_float3, hash_float4_to_float, hash_float4_to_float3, hash_float_to_float, \
    hash_float_to_float3
from .noise import noise_fbm

# NodeGradientType (kernel/svm/types.h), in Cycles' order
LINEAR, QUADRATIC, EASING, DIAGONAL, RADIAL, QUADRATIC_SPHERE, SPHERICAL = range(7)
# NodeWaveType, NodeWaveBandsDirection / NodeWaveRingsDirection and NodeWaveProfile
BANDS, RINGS = range(2)
DIRECTION_X, DIRECTION_Y, DIRECTION_Z, DIRECTION_DIAGONAL_OR_SPHERICAL = range(4)
SIN, SAW, TRI = range(3)

_TWO_PI = 2.0 * math.pi


@jit
def checker(x, y, z):
    """1 on the checker's even cells, 0 on the odd ones, at an already scaled point (Cycles'
    svm_checker)."""
    # Cycles' nudge against precision issues on unit coordinates
    x = (x + 0.000001) * 0.999999
    y = (y + 0.000001) * 0.999999
    z = (z + 0.000001) * 0.999999
    xi = abs(int(math.floor(x)))
    yi = abs(int(math.floor(y)))
    zi = abs(int(math.floor(z)))
    return 1.0 if ((xi % 2 == yi % 2) == (zi % 2 == 1)) else 0.0


@jit
def brick_noise(n):
    """Cycles' fast integer noise for a brick's tint, in [0, 1)."""
    n = (n + 1013) & 0x7FFFFFFF
    n = (n >> 13) ^ n
    # n * (n * n * 60493 + 19990303) + 1376312589 in 32-bit unsigned arithmetic
    t = (((n * n) & 0xFFFFFFFF) * 60493 + 19990303) & 0xFFFFFFFF
    nn = (n * t + 1376312589) & 0x7FFFFFFF
    return 0.5 * (nn / 1073741824.0)


@jit
def _smoothstepf(f):
    if f <= 0.0:
        return 0.0
    if f >= 1.0:
        return 1.0
    ff = f * f
    return 3.0 * ff - 2.0 * ff * f


@jit
def brick(x, y, mortar_size, mortar_smooth, bias, brick_width, row_height, offset_amount,
          offset_frequency, squash_amount, squash_frequency):
    """(tint, mortar) at an already scaled point (Cycles' svm_brick)."""
    rownum = int(math.floor(y / row_height))
    offset = 0.0
    if offset_frequency != 0 and squash_frequency != 0:
        # C's % and Python's differ in sign for negative rows, not in whether they are zero
        brick_width *= 1.0 if rownum % squash_frequency != 0 else squash_amount
        offset = 0.0 if rownum % offset_frequency != 0 else brick_width * offset_amount
    bricknum = int(math.floor((x + offset) / brick_width))
    bx = (x + offset) - brick_width * bricknum
    by = y - row_height * rownum
    # (rownum << 16) + (bricknum & 0xFFFF) in 32-bit unsigned arithmetic
    key = ((rownum << 16) + (bricknum & 0xFFFF)) & 0xFFFFFFFF
    tint = min(max(brick_noise(key) + bias, 0.0), 1.0)
    min_dist = min(min(bx, by), min(brick_width - bx, row_height - by))
    if min_dist >= mortar_size:
        mortar = 0.0
    elif mortar_smooth == 0.0:
        mortar = 1.0
    else:
        min_dist = 1.0 - min_dist / mortar_size
        mortar = _smoothstepf(min_dist / mortar_smooth)
    return tint, mortar


@jit
def gradient(kind, x, y, z):
    """The Gradient texture's value, clamped to [0, 1] (Cycles' svm_gradient and
    svm_node_tex_gradient)."""
    if kind == LINEAR:
        f = x
    elif kind == QUADRATIC:
        r = max(x, 0.0)
        f = r * r
    elif kind == EASING:
        r = min(max(x, 0.0), 1.0)
        t = r * r
        f = 3.0 * t - 2.0 * t * r
    elif kind == DIAGONAL:
        f = (x + y) * 0.5
    elif kind == RADIAL:
        f = math.atan2(y, x) / _TWO_PI + 0.5
    else:
        # the bias gives exactly zero on the unit sphere
        r = max(0.999999 - math.sqrt(x * x + y * y + z * z), 0.0)
        if kind == QUADRATIC_SPHERE:
            f = r * r
        elif kind == SPHERICAL:
            f = r
        else:
            f = 0.0
    return min(max(f, 0.0), 1.0)


@jit
def wave(kind, direction, profile, x, y, z, distortion, detail, detail_scale, detail_roughness,
         phase):
    """The Wave texture's value at an already scaled point (Cycles' svm_wave); `direction` is
    the bands' or the rings' direction, as `kind` says."""
    x = (x + 0.000001) * 0.999999
    y = (y + 0.000001) * 0.999999
    z = (z + 0.000001) * 0.999999
    if kind == BANDS:
        if direction == DIRECTION_X:
            n = x * 20.0
        elif direction == DIRECTION_Y:
            n = y * 20.0
        elif direction == DIRECTION_Z:
            n = z * 20.0
        else:
            n = (x + y + z) * 10.0
    else:
        rx = 0.0 if direction == DIRECTION_X else x
        ry = 0.0 if direction == DIRECTION_Y else y
        rz = 0.0 if direction == DIRECTION_Z else z
        n = math.sqrt(rx * rx + ry * ry + rz * rz) * 20.0
    n += phase
    if distortion != 0.0:
        # Cycles leaves a linked Detail unclamped (one octave per unit); 64 octaves keep a wild
        # link from hanging the render and differ from Cycles by less than roughness^64
        detail = min(detail, 64.0)
        s = detail_scale
        n += distortion * (noise_fbm(3, x * s, y * s, z * s, 0.0, detail, detail_roughness, 2.0,
                                     True) * 2.0 - 1.0)
    if profile == SIN:
        return 0.5 + 0.5 * math.sin(n - 0.5 * math.pi)
    n /= _TWO_PI
    if profile == SAW:
        return n - math.floor(n)
    return abs(n - math.floor(n + 0.5)) * 2.0


@jit
def magic(x, y, z, scale, depth, distortion):
    """The Magic texture's colour (Cycles' svm_magic)."""
    px = np.fmod(x, _TWO_PI)
    py = np.fmod(y, _TWO_PI)
    pz = np.fmod(z, _TWO_PI)
    mx = math.sin((px + py + pz) * 5.0 * scale)
    my = math.cos((-px + py - pz) * 5.0 * scale)
    mz = -math.cos((-px - py + pz) * 5.0 * scale)
    if depth > 0:
        mx *= distortion
        my *= distortion
        mz *= distortion
        my = -math.cos(mx - my + mz)
        my *= distortion
        if depth > 1:
            mx = math.cos(mx - my - mz)
            mx *= distortion
            if depth > 2:
                mz = math.sin(-mx - my - mz)
                mz *= distortion
                if depth > 3:
                    mx = -math.cos(-mx + my - mz)
                    mx *= distortion
                    if depth > 4:
                        my = -math.sin(-mx + my + mz)
                        my *= distortion
                        if depth > 5:
                            my = -math.cos(-mx + my + mz)
                            my *= distortion
                            if depth > 6:
                                mx = math.cos(mx + my + mz)
                                mx *= distortion
                                if depth > 7:
                                    mz = math.sin(mx + my - mz)
                                    mz *= distortion
                                    if depth > 8:
                                        mx = -math.cos(-mx - my + mz)
                                        mx *= distortion
                                        if depth > 9:
                                            my = -math.sin(mx - my + mz)
                                            my *= distortion
    if distortion != 0.0:
        distortion *= 2.0
        mx /= distortion
        my /= distortion
        mz /= distortion
    return 0.5 - mx, 0.5 - my, 0.5 - mz


@jit
def white_noise(dims, x, y, z, w):
    """(Value, Color) of the White Noise node in 1-4 dimensions (1D reads W; Cycles'
    svm_node_tex_white_noise)."""
    if dims == 1:
        return hash_float_to_float(w), hash_float_to_float3(w)
    if dims == 2:
        return hash_float2_to_float(x, y), hash_float2_to_float3(x, y)
    if dims == 3:
        return hash_float3_to_float(x, y, z), hash_float3_to_float3(x, y, z)
    return hash_float4_to_float(x, y, z, w), hash_float4_to_float3(x, y, z, w)
