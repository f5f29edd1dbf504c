"""Fresnel reflectance: the exact dielectric, Schlick's, and the models Cycles' microfacet
closures use (the Principled BSDF's real-Fresnel remap between F0 and 1, and the F82-tint
conductor), with their hemispherical averages for energy compensation.

Conventions follow Cycles (bsdf_util.h and bsdf_microfacet.h, Blender 5.0): `eta` is the relative
index n_transmitted / n_incident; colours are RGB tuples.
"""
from __future__ import annotations

import math

from .jit import jit

# Fresnel models of the smooth dielectrics (order matches settings.FRESNEL_MODELS).
EXACT, SCHLICK = range(2)


@jit
def fresnel_dielectric(cos_i, eta):
    """Exact unpolarised Fresnel reflectance and the cosine of the refracted ray.

    cos_i is clamped to [0, 1], eta = n_t / n_i. Total internal reflection gives F = 1 and
    cos_t = 0 (tested before any square root, so it never makes a NaN).
    """
    cos_i = min(max(cos_i, 0.0), 1.0)
    g2 = eta * eta - 1.0 + cos_i * cos_i
    if g2 <= 0.0:
        return 1.0, 0.0
    cos_t = math.sqrt(g2) / eta
    r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (r_s * r_s + r_p * r_p), cos_t


@jit
def fresnel_schlick(cos_i, eta):
    """Schlick's approximation (the seed's choice) and the refracted cosine.

    R0 = ((eta - 1) / (eta + 1))^2 and the cosine taken on the less dense side, as Schlick's
    approximation requires (for exits that is the refracted cosine). TIR gives F = 1.
    """
    cos_i = min(max(cos_i, 0.0), 1.0)
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    if sin2_t >= 1.0:
        return 1.0, 0.0
    cos_t = math.sqrt(1.0 - sin2_t)
    r0 = f0_from_ior(eta)
    c = cos_i if eta >= 1.0 else cos_t
    return mix_to_one(r0, (1.0 - c) ** 5), cos_t


@jit
def fresnel(model, cos_i, eta):
    """Reflectance and refracted cosine by the scene's Fresnel model (EXACT or SCHLICK)."""
    if model == SCHLICK:
        return fresnel_schlick(cos_i, eta)
    return fresnel_dielectric(cos_i, eta)


@jit
def f0_from_ior(ior):
    """Reflectance at normal incidence of a dielectric of relative index ior."""
    return ((ior - 1.0) / (ior + 1.0)) ** 2


@jit
def ior_from_f0(f0):
    """The relative index (above 1) whose normal reflectance is f0 (clamped to [0, 0.99])."""
    s = math.sqrt(min(max(f0, 0.0), 0.99))
    return (1.0 + s) / (1.0 - s)


@jit
def mix_to_one(f0, s):
    """f0 + (1 - f0) s: the Schlick-style blend from a normal reflectance towards 1."""
    return f0 + (1.0 - f0) * s


@jit
def mix_to_one3(f0, s):
    """mix_to_one per component of an RGB f0."""
    return (mix_to_one(f0[0], s), mix_to_one(f0[1], s), mix_to_one(f0[2], s))


@jit
def remap_factor(f, f0):
    """The s with f = mix_to_one(f0, s), clamped to [0, 1] (1 when f0 is 1)."""
    return min(max((f - f0) / (1.0 - f0), 0.0), 1.0) if f0 < 1.0 else 1.0


@jit
def fresnel_remapped(cos_i, eta, f0):
    """Cycles' generalized Schlick with a negative exponent (the Principled BSDF and the Glass
    BSDF): the real dielectric curve, remapped from [F0(eta), 1] onto [f0, 1] per channel.
    Returns (F rgb, refracted cosine); total internal reflection gives F = 1."""
    f_real, cos_t = fresnel_dielectric(cos_i, eta)
    return mix_to_one3(f0, remap_factor(f_real, f0_from_ior(eta))), cos_t


@jit
def f82_channel(cos_i, f0, b):
    """The F82-tint conductor (Kutz et al., Adobe Standard Material) for one channel: Schlick
    from f0, less b cos (1 - cos)^6, clamped to [0, 1]."""
    s = min(max(1.0 - cos_i, 0.0), 1.0)
    s5 = s * s * s * s * s
    return min(max(mix_to_one(f0, s5) - b * cos_i * s5 * s, 0.0), 1.0)


@jit
def fresnel_f82(cos_i, f0, b):
    """F82-tint reflectance (RGB) for the normal reflectance f0 and the tint terms b."""
    return (f82_channel(cos_i, f0[0], b[0]), f82_channel(cos_i, f0[1], b[1]),
            f82_channel(cos_i, f0[2], b[2]))


@jit
def f82_b_channel(f0, tint):
    """One channel of the F82-tint term b that scales Schlick's value at cos = 1/7 by `tint`."""
    f = 6.0 / 7.0
    f5 = f ** 5
    return mix_to_one(f0, f5) * (7.0 / (f5 * f)) * (1.0 - tint)


@jit
def f82_tint_b(f0, tint):
    """The F82-tint terms b (RGB) for the normal reflectance f0 and the edge tint."""
    return (f82_b_channel(f0[0], tint[0]), f82_b_channel(f0[1], tint[1]),
            f82_b_channel(f0[2], tint[2]))


@jit
def dielectric_fss(eta):
    """Average reflectance 2 int_0^1 F(mu, eta) mu dmu of a dielectric: Kulla and Conty's fit, as
    Cycles uses it for energy compensation."""
    if eta < 1.0:
        return 0.997118 + eta * (0.1014 - eta * (0.965241 + eta * 0.130607))
    return (eta - 1.0) / (4.08567 + 1.00071 * eta)


@jit
def f82_fss(f0, b):
    """Average reflectance of F82-tint (RGB), analytic."""
    return ((f0[0] + (1.0 - f0[0]) / 21.0) - b[0] / 126.0,
            (f0[1] + (1.0 - f0[1]) / 21.0) - b[1] / 126.0,
            (f0[2] + (1.0 - f0[2]) / 21.0) - b[2] / 126.0)
