"""Cycles' Gabor noise texture in 2D and 3D: a sum of windowed Gabor kernels, eight random
impulses per cell over the 3x3 (or 3x3x3) cells around the point.

Follows Blender 5.0's intern/cycles/kernel/svm/gabor.h (compute_*d_gabor_kernel,
compute_*d_gabor_noise_cell, compute_*d_gabor_noise, svm_node_tex_gabor).
"""
from __future__ import annotations

import math

from ..jit import jit
from .hashes import hash_float3_to_float, hash_float3_to_float2, hash_float4_to_float, \
    hash_float4_to_float2, hash_float4_to_float3

# NodeGaborType (kernel/svm/types.h)
TYPE_2D, TYPE_3D = range(2)
IMPULSES = 8


@jit
def _kernel(d2, phase_dot, frequency):
    # the windowed Gaussian envelope (a Hann window cuts it at unit distance) times the
    # complex sinusoid of angle 2 pi frequency <position, orientation>
    hann = 0.5 + 0.5 * math.cos(math.pi * d2)
    envelope = math.exp(-math.pi * d2) * hann
    angle = 2.0 * math.pi * frequency * phase_dot
    return envelope * math.cos(angle), envelope * math.sin(angle)


@jit
def gabor_2d(x, y, frequency, isotropy, base_orientation):
    """The Gabor noise phasor (real, imaginary) at a 2D point (Cycles' compute_2d_gabor_noise)."""
    fx, fy = math.floor(x), math.floor(y)
    lx, ly = x - fx, y - fy
    re, im = 0.0, 0.0
    for j in range(-1, 2):
        for i in range(-1, 2):
            cx, cy = fx + i, fy + j
            px, py = lx - i, ly - j
            for k in range(IMPULSES):
                orientation = base_orientation + (
                    hash_float3_to_float(cx, cy, k * 3.0) - 0.5) * math.pi * isotropy
                kx, ky = hash_float3_to_float2(cx, cy, k * 3.0 + 1.0)
                qx, qy = px - kx, py - ky
                d2 = qx * qx + qy * qy
                if d2 >= 1.0:
                    continue
                weight = -1.0 if hash_float3_to_float(cx, cy, k * 3.0 + 2.0) < 0.5 else 1.0
                a, b = _kernel(d2, qx * math.cos(orientation) + qy * math.sin(orientation),
                               frequency)
                re += weight * a
                im += weight * b
    return re, im


@jit
def _orientation_3d(ox, oy, oz, isotropy, cx, cy, cz, seed):
    # Cycles' compute_3d_orientation: the base orientation turned by random spherical angles
    if isotropy == 0.0:
        return ox, oy, oz
    inclination = math.acos(oz)
    azimuth = (-1.0 if oy < 0.0 else 1.0) * math.acos(ox / math.sqrt(ox * ox + oy * oy))
    ra, rb = hash_float4_to_float2(cx, cy, cz, seed)
    inclination += ra * math.pi * isotropy
    azimuth += rb * math.pi * isotropy
    return (math.sin(inclination) * math.cos(azimuth), math.sin(inclination) * math.sin(azimuth),
            math.cos(inclination))


@jit
def gabor_3d(x, y, z, frequency, isotropy, ox, oy, oz):
    """The Gabor noise phasor (real, imaginary) at a 3D point, (ox, oy, oz) the unit base
    orientation (Cycles' compute_3d_gabor_noise)."""
    fx, fy, fz = math.floor(x), math.floor(y), math.floor(z)
    lx, ly, lz = x - fx, y - fy, z - fz
    re, im = 0.0, 0.0
    for m in range(-1, 2):
        for j in range(-1, 2):
            for i in range(-1, 2):
                cx, cy, cz = fx + i, fy + j, fz + m
                px, py, pz = lx - i, ly - j, lz - m
                for k in range(IMPULSES):
                    dx, dy, dz = _orientation_3d(ox, oy, oz, isotropy, cx, cy, cz, k * 3.0)
                    kx, ky, kz = hash_float4_to_float3(cx, cy, cz, k * 3.0 + 1.0)
                    qx, qy, qz = px - kx, py - ky, pz - kz
                    d2 = qx * qx + qy * qy + qz * qz
                    if d2 >= 1.0:
                        continue
                    weight = -1.0 if hash_float4_to_float(cx, cy, cz, k * 3.0 + 2.0) < 0.5 \
                        else 1.0
                    a, b = _kernel(d2, qx * dx + qy * dy + qz * dz, frequency)
                    re += weight * a
                    im += weight * b
    return re, im


@jit
def gabor_texture(kind, x, y, z, scale, frequency, anisotropy, orientation_2d, ox, oy, oz):
    """The Gabor Texture node: (Value, Phase, Intensity) (Cycles' svm_node_tex_gabor)."""
    x, y, z = x * scale, y * scale, z * scale
    isotropy = 1.0 - min(max(anisotropy, 0.0), 1.0)
    frequency = max(0.001, frequency)
    if kind == TYPE_3D:
        n = math.sqrt(ox * ox + oy * oy + oz * oz)
        # Cycles divides by the length unguarded (NaN for a zero orientation); here a zero
        # orientation stays zero
        if n > 0.0:
            ox, oy, oz = ox / n, oy / n, oz / n
        re, im = gabor_3d(x, y, z, frequency, isotropy, ox, oy, oz)
        # sqrt(impulses * second moment 1/2 * the integral of the squared kernel 1 / (4 sqrt 2))
        deviation = math.sqrt(IMPULSES * 0.5 * (1.0 / (4.0 * math.sqrt(2.0))))
    else:
        re, im = gabor_2d(x, y, frequency, isotropy, orientation_2d)
        # the same with the 2D kernel's integral 1/4
        deviation = math.sqrt(IMPULSES * 0.5 * 0.25)
    # Cycles divides by six standard deviations, found empirically
    norm = 6.0 * deviation
    value = (im / norm) * 0.5 + 0.5
    phase = (math.atan2(im, re) + math.pi) / (2.0 * math.pi)
    intensity = math.sqrt(re * re + im * im) / norm
    return value, phase, intensity
