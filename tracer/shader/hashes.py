"""Cycles' hash functions for procedural textures: Bob Jenkins' lookup3 hashes of 1-4 unsigned
ints, their float forms (a float hashed by its float32 bit pattern), and the PCG 2D-4D integer
hashes Voronoi reads its cell points from.

Follows Blender 5.0's intern/cycles/util/hash.h (hash_uint*, hash_*_to_float*, hash_pcg*d_i,
hash_int*_to_float*). Cycles computes in 32-bit integers that wrap; here every operation works on
int64 and keeps the low 32 bits (`_u32`), or the signed 32-bit value (`_i32`) for PCG, which
Cycles writes with signed ints so that OSL can run it too.
"""
from __future__ import annotations

import numpy as np

from ..jit import jit

_MASK = 0xFFFFFFFF
# lookup3's seed, 0xdeadbeef + (n << 2) + 13 for n keys
_SEED = 0xDEADBEEF + 13
# uint_to_float_incl: n / 0xFFFFFFFF, in float32 as Cycles computes it
_INV_UINT_MAX = float(np.float32(1.0) / np.float32(4294967295.0))
# hash_int*_to_float*: h / 0x7FFFFFFF (the float32 constant 1 / 2147483648 after rounding)
_INV_INT_MAX = float(np.float32(1.0) / np.float32(2147483647.0))


@jit
def _u32(x):
    return x & _MASK


@jit
def _i32(x):
    x = x & _MASK
    return x - 0x100000000 if x >= 0x80000000 else x


@jit
def _rot(x, k):
    return ((x << k) | (x >> (32 - k))) & _MASK


@jit
def _final(a, b, c):
    # lookup3's final(a, b, c)
    c = _u32((c ^ b) - _rot(b, 14))
    a = _u32((a ^ c) - _rot(c, 11))
    b = _u32((b ^ a) - _rot(a, 25))
    c = _u32((c ^ b) - _rot(b, 16))
    a = _u32((a ^ c) - _rot(c, 4))
    b = _u32((b ^ a) - _rot(a, 14))
    c = _u32((c ^ b) - _rot(b, 24))
    return a, b, c


@jit
def _mix(a, b, c):
    # lookup3's mix(a, b, c)
    a = _u32(a - c) ^ _rot(c, 4)
    c = _u32(c + b)
    b = _u32(b - a) ^ _rot(a, 6)
    a = _u32(a + c)
    c = _u32(c - b) ^ _rot(b, 8)
    b = _u32(b + a)
    a = _u32(a - c) ^ _rot(c, 16)
    c = _u32(c + b)
    b = _u32(b - a) ^ _rot(a, 19)
    a = _u32(a + c)
    c = _u32(c - b) ^ _rot(b, 4)
    b = _u32(b + a)
    return a, b, c


@jit
def hash_uint(kx):
    """lookup3 hash of one 32-bit key (Cycles' hash_uint)."""
    a = b = c = _u32(_SEED + (1 << 2))
    a = _u32(a + _u32(kx))
    a, b, c = _final(a, b, c)
    return c


@jit
def hash_uint2(kx, ky):
    """lookup3 hash of two 32-bit keys (Cycles' hash_uint2)."""
    a = b = c = _u32(_SEED + (2 << 2))
    b = _u32(b + _u32(ky))
    a = _u32(a + _u32(kx))
    a, b, c = _final(a, b, c)
    return c


@jit
def hash_uint3(kx, ky, kz):
    """lookup3 hash of three 32-bit keys (Cycles' hash_uint3)."""
    a = b = c = _u32(_SEED + (3 << 2))
    c = _u32(c + _u32(kz))
    b = _u32(b + _u32(ky))
    a = _u32(a + _u32(kx))
    a, b, c = _final(a, b, c)
    return c


@jit
def hash_uint4(kx, ky, kz, kw):
    """lookup3 hash of four 32-bit keys (Cycles' hash_uint4)."""
    a = b = c = _u32(_SEED + (4 << 2))
    a = _u32(a + _u32(kx))
    b = _u32(b + _u32(ky))
    c = _u32(c + _u32(kz))
    a, b, c = _mix(a, b, c)
    a = _u32(a + _u32(kw))
    a, b, c = _final(a, b, c)
    return c


@jit
def float_bits(x):
    """The bit pattern of x rounded to float32 (Cycles' __float_as_uint)."""
    return np.int64(np.float32(x).view(np.uint32))


@jit
def uint_to_float_incl(n):
    """[0, 2^32 - 1] -> [0, 1], as Cycles' uint_to_float_incl (in float32)."""
    return float(np.float32(np.float32(n) * np.float32(_INV_UINT_MAX)))


@jit
def hash_float_to_float(k):
    """A float in [0, 1] from one float (Cycles' hash_float_to_float)."""
    return uint_to_float_incl(hash_uint(float_bits(k)))


@jit
def hash_float2_to_float(kx, ky):
    """A float in [0, 1] from two floats (Cycles' hash_float2_to_float)."""
    return uint_to_float_incl(hash_uint2(float_bits(kx), float_bits(ky)))


@jit
def hash_float3_to_float(kx, ky, kz):
    """A float in [0, 1] from three floats (Cycles' hash_float3_to_float)."""
    return uint_to_float_incl(hash_uint3(float_bits(kx), float_bits(ky), float_bits(kz)))


@jit
def hash_float4_to_float(kx, ky, kz, kw):
    """A float in [0, 1] from four floats (Cycles' hash_float4_to_float)."""
    return uint_to_float_incl(hash_uint4(float_bits(kx), float_bits(ky), float_bits(kz),
                                         float_bits(kw)))


@jit
def hash_float_to_float3(k):
    """Three floats in [0, 1] from one float (Cycles' hash_float_to_float3)."""
    return (hash_float_to_float(k), hash_float2_to_float(k, 1.0), hash_float2_to_float(k, 2.0))


@jit
def hash_float2_to_float3(kx, ky):
    """Three floats in [0, 1] from two floats (Cycles' hash_float2_to_float3)."""
    return (hash_float2_to_float(kx, ky), hash_float3_to_float(kx, ky, 1.0),
            hash_float3_to_float(kx, ky, 2.0))


@jit
def hash_float3_to_float3(kx, ky, kz):
    """Three floats in [0, 1] from three floats (Cycles' hash_float3_to_float3)."""
    return (hash_float3_to_float(kx, ky, kz), hash_float4_to_float(kx, ky, kz, 1.0),
            hash_float4_to_float(kx, ky, kz, 2.0))


@jit
def hash_float4_to_float3(kx, ky, kz, kw):
    """Three floats in [0, 1] from four floats (Cycles' hash_float4_to_float3)."""
    return (hash_float4_to_float(kx, ky, kz, kw), hash_float4_to_float(kz, kx, kw, ky),
            hash_float4_to_float(kw, kz, ky, kx))


@jit
def hash_pcg2d_i(x, y):
    """PCG 2D hash on signed 32-bit ints, non-negative results (Cycles' hash_pcg2d_i)."""
    x = _i32(x * 1664525 + 1013904223)
    y = _i32(y * 1664525 + 1013904223)
    x = _i32(x + y * 1664525)
    y = _i32(y + x * 1664525)
    x = x ^ (x >> 16)
    y = y ^ (y >> 16)
    x = _i32(x + y * 1664525)
    y = _i32(y + x * 1664525)
    return x & 0x7FFFFFFF, y & 0x7FFFFFFF


@jit
def hash_pcg3d_i(x, y, z):
    """PCG 3D hash on signed 32-bit ints, non-negative results (Cycles' hash_pcg3d_i)."""
    x = _i32(x * 1664525 + 1013904223)
    y = _i32(y * 1664525 + 1013904223)
    z = _i32(z * 1664525 + 1013904223)
    x = _i32(x + y * z)
    y = _i32(y + z * x)
    z = _i32(z + x * y)
    x = x ^ (x >> 16)
    y = y ^ (y >> 16)
    z = z ^ (z >> 16)
    x = _i32(x + y * z)
    y = _i32(y + z * x)
    z = _i32(z + x * y)
    return x & 0x7FFFFFFF, y & 0x7FFFFFFF, z & 0x7FFFFFFF


@jit
def hash_pcg4d_i(x, y, z, w):
    """PCG 4D hash on signed 32-bit ints, non-negative results (Cycles' hash_pcg4d_i)."""
    x = _i32(x * 1664525 + 1013904223)
    y = _i32(y * 1664525 + 1013904223)
    z = _i32(z * 1664525 + 1013904223)
    w = _i32(w * 1664525 + 1013904223)
    x = _i32(x + y * w)
    y = _i32(y + z * x)
    z = _i32(z + x * y)
    w = _i32(w + y * z)
    x = x ^ (x >> 16)
    y = y ^ (y >> 16)
    z = z ^ (z >> 16)
    w = w ^ (w >> 16)
    x = _i32(x + y * w)
    y = _i32(y + z * x)
    z = _i32(z + x * y)
    w = _i32(w + y * z)
    return x & 0x7FFFFFFF, y & 0x7FFFFFFF, z & 0x7FFFFFFF, w & 0x7FFFFFFF


@jit
def _int_to_unit(h):
    # (float)h * (1.0f / (float)0x7FFFFFFF), both in float32
    return float(np.float32(np.float32(h) * np.float32(_INV_INT_MAX)))


@jit
def hash_int2_to_float2(x, y):
    """Two floats in [0, 1] from a 2D integer cell (Cycles' hash_int2_to_float2)."""
    hx, hy = hash_pcg2d_i(x, y)
    return _int_to_unit(hx), _int_to_unit(hy)


@jit
def hash_int3_to_float3(x, y, z):
    """Three floats in [0, 1] from a 3D integer cell (Cycles' hash_int3_to_float3)."""
    hx, hy, hz = hash_pcg3d_i(x, y, z)
    return _int_to_unit(hx), _int_to_unit(hy), _int_to_unit(hz)


@jit
def hash_int4_to_float4(x, y, z, w):
    """Four floats in [0, 1] from a 4D integer cell (Cycles' hash_int4_to_float4)."""
    hx, hy, hz, hw = hash_pcg4d_i(x, y, z, w)
    return _int_to_unit(hx), _int_to_unit(hy), _int_to_unit(hz), _int_to_unit(hw)


@jit
def hash_float3_to_float2(kx, ky, kz):
    """Two floats in [0, 1] from three floats (Cycles' hash_float3_to_float2)."""
    return hash_float3_to_float(kx, ky, kz), hash_float3_to_float(kz, kx, ky)


@jit
def hash_float4_to_float2(kx, ky, kz, kw):
    """Two floats in [0, 1] from four floats (Cycles' hash_float4_to_float2)."""
    return hash_float4_to_float(kx, ky, kz, kw), hash_float4_to_float(kz, kx, kw, ky)
