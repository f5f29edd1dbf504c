"""Cycles' Perlin noise in 1-4 dimensions, its fractal sums (fBm, multifractal, hybrid and ridged
multifractal, heterogeneous terrain) and the Noise Texture node built on them.

Follows Blender 5.0's intern/cycles/kernel/svm/noise.h (perlin_*d, snoise_*d, the noise_scale*
factors), fractal_noise.h (noise_fbm and the others) and noisetex.h (random_float*_offset,
noise_texture_*d). Cycles writes each function four times, once per dimension, with the same
body; here each is written once for a point of `dims` components (x, y, z, w; the unused ones are
ignored), which is what the four copies compute.
"""
from __future__ import annotations

import math

import numpy as np

from ..jit import jit
from .hashes import hash_float2_to_float, hash_float_to_float, hash_uint, hash_uint2, \
    hash_uint3, hash_uint4

# NodeNoiseType (kernel/svm/types.h), in Cycles' order
MULTIFRACTAL, FBM, HYBRID_MULTIFRACTAL, RIDGED_MULTIFRACTAL, HETERO_TERRAIN = range(5)


@jit
def fade(t):
    """Perlin's quintic fade curve 6t^5 - 15t^4 + 10t^3."""
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@jit
def _negate_if(val, condition):
    return -val if condition else val


@jit
def grad1(h, x):
    """Cycles' grad1: one of 16 gradients (slopes 1-8, either sign) picked by the hash."""
    h = h & 15
    g = 1.0 + (h & 7)
    return _negate_if(g, h & 8) * x


@jit
def grad2(h, x, y):
    """Cycles' grad2."""
    h = h & 7
    u = x if h < 4 else y
    v = 2.0 * (y if h < 4 else x)
    return _negate_if(u, h & 1) + _negate_if(v, h & 2)


@jit
def grad3(h, x, y, z):
    """Cycles' grad3."""
    h = h & 15
    u = x if h < 8 else y
    vt = x if (h == 12 or h == 14) else z
    v = y if h < 4 else vt
    return _negate_if(u, h & 1) + _negate_if(v, h & 2)


@jit
def grad4(h, x, y, z, w):
    """Cycles' grad4."""
    h = h & 31
    u = x if h < 24 else y
    v = y if h < 16 else z
    s = z if h < 8 else w
    return _negate_if(u, h & 1) + _negate_if(v, h & 2) + _negate_if(s, h & 4)


@jit
def _mix(a, b, t):
    return a + t * (b - a)


@jit
def _bi_mix(v0, v1, v2, v3, x, y):
    x1 = 1.0 - x
    return (1.0 - y) * (v0 * x1 + v1 * x) + y * (v2 * x1 + v3 * x)


@jit
def _tri_mix(v0, v1, v2, v3, v4, v5, v6, v7, x, y, z):
    x1 = 1.0 - x
    y1 = 1.0 - y
    z1 = 1.0 - z
    return (z1 * (y1 * (v0 * x1 + v1 * x) + y * (v2 * x1 + v3 * x))
            + z * (y1 * (v4 * x1 + v5 * x) + y * (v6 * x1 + v7 * x)))


@jit
def perlin_1d(x):
    """Signed Perlin noise of a number (Cycles' perlin_1d, before noise_scale1)."""
    fl = math.floor(x)
    X = int(fl)
    fx = x - fl
    return _mix(grad1(hash_uint(X), fx), grad1(hash_uint(X + 1), fx - 1.0), fade(fx))


@jit
def perlin_2d(x, y):
    """Signed Perlin noise of a 2D point (Cycles' perlin_2d, before noise_scale2)."""
    X = int(math.floor(x))
    Y = int(math.floor(y))
    fx = x - math.floor(x)
    fy = y - math.floor(y)
    return _bi_mix(grad2(hash_uint2(X, Y), fx, fy),
                   grad2(hash_uint2(X + 1, Y), fx - 1.0, fy),
                   grad2(hash_uint2(X, Y + 1), fx, fy - 1.0),
                   grad2(hash_uint2(X + 1, Y + 1), fx - 1.0, fy - 1.0),
                   fade(fx), fade(fy))


@jit
def perlin_3d(x, y, z):
    """Signed Perlin noise of a 3D point (Cycles' perlin_3d, before noise_scale3)."""
    X = int(math.floor(x))
    Y = int(math.floor(y))
    Z = int(math.floor(z))
    fx = x - math.floor(x)
    fy = y - math.floor(y)
    fz = z - math.floor(z)
    return _tri_mix(grad3(hash_uint3(X, Y, Z), fx, fy, fz),
                    grad3(hash_uint3(X + 1, Y, Z), fx - 1.0, fy, fz),
                    grad3(hash_uint3(X, Y + 1, Z), fx, fy - 1.0, fz),
                    grad3(hash_uint3(X + 1, Y + 1, Z), fx - 1.0, fy - 1.0, fz),
                    grad3(hash_uint3(X, Y, Z + 1), fx, fy, fz - 1.0),
                    grad3(hash_uint3(X + 1, Y, Z + 1), fx - 1.0, fy, fz - 1.0),
                    grad3(hash_uint3(X, Y + 1, Z + 1), fx, fy - 1.0, fz - 1.0),
                    grad3(hash_uint3(X + 1, Y + 1, Z + 1), fx - 1.0, fy - 1.0, fz - 1.0),
                    fade(fx), fade(fy), fade(fz))


@jit
def _perlin_4d_slice(X, Y, Z, W, fx, fy, fz, fw, u, v, t):
    # the trilinear mix of the eight corners at one W (Cycles' quad_mix halves)
    return _tri_mix(grad4(hash_uint4(X, Y, Z, W), fx, fy, fz, fw),
                    grad4(hash_uint4(X + 1, Y, Z, W), fx - 1.0, fy, fz, fw),
                    grad4(hash_uint4(X, Y + 1, Z, W), fx, fy - 1.0, fz, fw),
                    grad4(hash_uint4(X + 1, Y + 1, Z, W), fx - 1.0, fy - 1.0, fz, fw),
                    grad4(hash_uint4(X, Y, Z + 1, W), fx, fy, fz - 1.0, fw),
                    grad4(hash_uint4(X + 1, Y, Z + 1, W), fx - 1.0, fy, fz - 1.0, fw),
                    grad4(hash_uint4(X, Y + 1, Z + 1, W), fx, fy - 1.0, fz - 1.0, fw),
                    grad4(hash_uint4(X + 1, Y + 1, Z + 1, W), fx - 1.0, fy - 1.0, fz - 1.0, fw),
                    u, v, t)


@jit
def perlin_4d(x, y, z, w):
    """Signed Perlin noise of a 4D point (Cycles' perlin_4d, before noise_scale4)."""
    X = int(math.floor(x))
    Y = int(math.floor(y))
    Z = int(math.floor(z))
    W = int(math.floor(w))
    fx = x - math.floor(x)
    fy = y - math.floor(y)
    fz = z - math.floor(z)
    fw = w - math.floor(w)
    u, v, t, s = fade(fx), fade(fy), fade(fz), fade(fw)
    return _mix(_perlin_4d_slice(X, Y, Z, W, fx, fy, fz, fw, u, v, t),
                _perlin_4d_slice(X, Y, Z, W + 1, fx, fy, fz, fw - 1.0, u, v, t), s)


@jit
def _wrap(p):
    # Cycles repeats the noise every 100000 on each axis and shifts coordinates beyond 1e6 by
    # half a cell (snoise_*d's precision_correction)
    correction = 0.5 if abs(p) >= 1000000.0 else 0.0
    return np.fmod(p, 100000.0) + correction


@jit
def snoise(dims, x, y, z, w):
    """Signed Perlin noise of the first `dims` components, scaled as Cycles' snoise_*d."""
    if dims == 1:
        return 0.25 * perlin_1d(_wrap(x))
    if dims == 2:
        return 0.6616 * perlin_2d(_wrap(x), _wrap(y))
    if dims == 3:
        return 0.9820 * perlin_3d(_wrap(x), _wrap(y), _wrap(z))
    return 0.8344 * perlin_4d(_wrap(x), _wrap(y), _wrap(z), _wrap(w))


@jit
def noise_fbm(dims, x, y, z, w, detail, roughness, lacunarity, normalize):
    """Fractal Brownian motion: octaves of snoise (Cycles' noise_fbm)."""
    fscale = 1.0
    amp = 1.0
    maxamp = 0.0
    total = 0.0
    for _ in range(int(detail) + 1):
        t = snoise(dims, fscale * x, fscale * y, fscale * z, fscale * w)
        total += t * amp
        maxamp += amp
        amp *= roughness
        fscale *= lacunarity
    rmd = detail - math.floor(detail)
    if rmd != 0.0:
        t = snoise(dims, fscale * x, fscale * y, fscale * z, fscale * w)
        total2 = total + t * amp
        if normalize:
            return _mix(0.5 * total / maxamp + 0.5, 0.5 * total2 / (maxamp + amp) + 0.5, rmd)
        return _mix(total, total2, rmd)
    if normalize:
        return 0.5 * total / maxamp + 0.5
    return total


@jit
def noise_multi_fractal(dims, x, y, z, w, detail, roughness, lacunarity):
    """Multifractal noise: a product of octaves (Cycles' noise_multi_fractal)."""
    value = 1.0
    pwr = 1.0
    for _ in range(int(detail) + 1):
        value *= pwr * snoise(dims, x, y, z, w) + 1.0
        pwr *= roughness
        x, y, z, w = x * lacunarity, y * lacunarity, z * lacunarity, w * lacunarity
    rmd = detail - math.floor(detail)
    if rmd != 0.0:
        value *= rmd * pwr * snoise(dims, x, y, z, w) + 1.0
    return value


@jit
def noise_hetero_terrain(dims, x, y, z, w, detail, roughness, lacunarity, offset):
    """Heterogeneous terrain (Cycles' noise_hetero_terrain)."""
    pwr = roughness
    value = offset + snoise(dims, x, y, z, w)
    x, y, z, w = x * lacunarity, y * lacunarity, z * lacunarity, w * lacunarity
    for _ in range(1, int(detail) + 1):
        increment = (snoise(dims, x, y, z, w) + offset) * pwr * value
        value += increment
        pwr *= roughness
        x, y, z, w = x * lacunarity, y * lacunarity, z * lacunarity, w * lacunarity
    rmd = detail - math.floor(detail)
    if rmd != 0.0:
        increment = (snoise(dims, x, y, z, w) + offset) * pwr * value
        value += rmd * increment
    return value


@jit
def noise_hybrid_multi_fractal(dims, x, y, z, w, detail, roughness, lacunarity, offset, gain):
    """Hybrid additive/multiplicative multifractal (Cycles' noise_hybrid_multi_fractal)."""
    pwr = 1.0
    value = 0.0
    weight = 1.0
    i = 0
    while weight > 0.001 and i <= int(detail):
        weight = min(weight, 1.0)
        signal = (snoise(dims, x, y, z, w) + offset) * pwr
        pwr *= roughness
        value += weight * signal
        weight *= gain * signal
        x, y, z, w = x * lacunarity, y * lacunarity, z * lacunarity, w * lacunarity
        i += 1
    rmd = detail - math.floor(detail)
    if rmd != 0.0 and weight > 0.001:
        weight = min(weight, 1.0)
        signal = (snoise(dims, x, y, z, w) + offset) * pwr
        value += rmd * weight * signal
    return value


@jit
def noise_ridged_multi_fractal(dims, x, y, z, w, detail, roughness, lacunarity, offset, gain):
    """Ridged multifractal (Cycles' noise_ridged_multi_fractal)."""
    pwr = roughness
    signal = offset - abs(snoise(dims, x, y, z, w))
    signal *= signal
    value = signal
    for _ in range(1, int(detail) + 1):
        x, y, z, w = x * lacunarity, y * lacunarity, z * lacunarity, w * lacunarity
        weight = min(max(signal * gain, 0.0), 1.0)
        signal = offset - abs(snoise(dims, x, y, z, w))
        signal *= signal
        signal *= weight
        value += signal * pwr
        pwr *= roughness
    return value


@jit
def noise_select(dims, x, y, z, w, detail, roughness, lacunarity, offset, gain, kind, normalize):
    """The fractal of type `kind` (NodeNoiseType) at a point (Cycles' noise_select)."""
    if kind == MULTIFRACTAL:
        return noise_multi_fractal(dims, x, y, z, w, detail, roughness, lacunarity)
    if kind == FBM:
        return noise_fbm(dims, x, y, z, w, detail, roughness, lacunarity, normalize)
    if kind == HYBRID_MULTIFRACTAL:
        return noise_hybrid_multi_fractal(dims, x, y, z, w, detail, roughness, lacunarity,
                                          offset, gain)
    if kind == RIDGED_MULTIFRACTAL:
        return noise_ridged_multi_fractal(dims, x, y, z, w, detail, roughness, lacunarity,
                                          offset, gain)
    return noise_hetero_terrain(dims, x, y, z, w, detail, roughness, lacunarity, offset)


@jit
def random_offset(dims, seed, axis):
    """Component `axis` of Cycles' random_float*_offset(seed): 100 + 100 hash."""
    if dims == 1:
        return 100.0 + hash_float_to_float(seed) * 100.0
    return 100.0 + hash_float2_to_float(seed, float(axis)) * 100.0


@jit
def _offset_point(dims, x, y, z, w, seed):
    # p + random_float*_offset(seed), for the components in use
    return (x + random_offset(dims, seed, 0), y + random_offset(dims, seed, 1),
            z + random_offset(dims, seed, 2), w + random_offset(dims, seed, 3))


@jit
def _distortion(dims, x, y, z, w, seed):
    ox, oy, oz, ow = _offset_point(dims, x, y, z, w, seed)
    return snoise(dims, ox, oy, oz, ow)


@jit
def noise_texture(dims, x, y, z, w, scale, detail, roughness, lacunarity, offset, gain,
                  distortion, kind, normalize, color_needed):
    """The Noise Texture node: (Fac, Color) at vector (x, y, z) and W (Cycles'
    svm_node_tex_noise and noise_texture_*d). Color is (Fac, Fac, Fac) unless color_needed."""
    detail = min(max(detail, 0.0), 15.0)
    roughness = max(roughness, 0.0)
    x, y, z, w = x * scale, y * scale, z * scale, w * scale
    if dims == 1:
        # the 1D node reads W only
        x, y, z, w = w, 0.0, 0.0, 0.0
    if distortion != 0.0:
        # one noise per component in use, each at the point shifted by its own seed's offset
        dx = _distortion(dims, x, y, z, w, 0.0) * distortion
        dy = _distortion(dims, x, y, z, w, 1.0) * distortion if dims >= 2 else 0.0
        dz = _distortion(dims, x, y, z, w, 2.0) * distortion if dims >= 3 else 0.0
        dw = _distortion(dims, x, y, z, w, 3.0) * distortion if dims >= 4 else 0.0
        x, y, z, w = x + dx, y + dy, z + dz, w + dw
    value = noise_select(dims, x, y, z, w, detail, roughness, lacunarity, offset, gain, kind,
                         normalize)
    if not color_needed:
        return value, (value, value, value)
    # the colour's second and third channels use the seeds after the distortion's
    gx, gy, gz, gw = _offset_point(dims, x, y, z, w, float(dims))
    bx, by, bz, bw = _offset_point(dims, x, y, z, w, float(dims + 1))
    return value, (value,
                   noise_select(dims, gx, gy, gz, gw, detail, roughness, lacunarity, offset, gain,
                                kind, normalize),
                   noise_select(dims, bx, by, bz, bw, detail, roughness, lacunarity, offset, gain,
                                kind, normalize))
