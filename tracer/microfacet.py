"""Microfacet distributions, GGX and Beckmann: the normal distribution D, Smith's masking term
Lambda, and sampling of the visible normals.

Conventions follow Cycles' bsdf_microfacet.h (Blender 5.0): alpha = roughness^2 (isotropic),
vectors are in a frame whose z axis is the normal, and wi points away from the surface towards
the viewer. The BSDF built on these terms is in lobes.py.
"""
from __future__ import annotations

import math

from .jit import jit
from .sampling import sample_uniform_disk
from .vec import cross, normalize

# Distributions (Multiscatter GGX is GGX with Cycles' energy compensation, see lobes.py).
GGX, BECKMANN = range(2)
# Cycles renders a surface whose alpha_x * alpha_y is at most this as perfectly specular.
SPECULAR_ALPHA2 = 2e-10
# The largest double below 1.
ERF_MAX = 1.0 - 2.0 ** -53


@jit
def is_almost_specular(alpha):
    """Whether Cycles treats this roughness (alpha) as a perfect mirror or smooth dielectric."""
    return alpha * alpha <= SPECULAR_ALPHA2


@jit
def ndf(dist, alpha2, cos_nh):
    """The normal distribution D(h) (per steradian of microfacet normal; alpha2 = alpha^2)."""
    c2 = min(cos_nh * cos_nh, 1.0)
    s2 = 1.0 - c2
    if dist == BECKMANN:
        return 1.0 / (math.exp(s2 / (c2 * alpha2)) * math.pi * alpha2 * c2 * c2)
    return alpha2 / (math.pi * (s2 + alpha2 * c2) ** 2)


@jit
def smith_lambda(dist, alpha2, cos_n):
    """Smith's Lambda for a direction at cosine cos_n to the normal: G1 = 1 / (1 + Lambda).

    GGX is exact (Heitz 2014, eq. 72); Beckmann uses Walter et al.'s rational fit, as Cycles.
    """
    a2t2 = alpha2 * max(1.0 / (cos_n * cos_n) - 1.0, 0.0)     # alpha^2 tan^2
    if dist == BECKMANN:
        if a2t2 < 0.39:                  # a = 1 / (alpha tan) above 1.6: Lambda is 0
            return 0.0
        a = 1.0 / math.sqrt(a2t2)
        return ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a)
    return 0.5 * (math.sqrt(1.0 + a2t2) - 1.0)


@jit
def sample_visible_normal(dist, wi, alpha, u0, u1):
    """A microfacet normal (local frame) drawn from the distribution of normals visible from
    wi: density D(h) G1(wi) max(0, wi.h) / wi.z."""
    if dist == BECKMANN:
        return sample_beckmann_visible_normal(wi, alpha, u0, u1)
    return sample_ggx_visible_normal(wi, alpha, u0, u1)


@jit
def sample_ggx_visible_normal(wi, alpha, u0, u1):
    """GGX visible normals (Heitz, JCGT 7(4), 2018): a point on the projected hemisphere of the
    stretched configuration, lifted to it and unstretched."""
    v = normalize((alpha * wi[0], alpha * wi[1], wi[2]))
    lensq = v[0] * v[0] + v[1] * v[1]
    if lensq > 1e-7:
        inv = 1.0 / math.sqrt(lensq)
        t1 = (-v[1] * inv, v[0] * inv, 0.0)
        t2 = cross(v, t1)
    else:                                 # normal incidence: any basis
        t1, t2 = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)
    x, y = sample_uniform_disk(u0, u1)
    s = 0.5 * (1.0 + v[2])
    y = (1.0 - s) * math.sqrt(max(1.0 - x * x, 0.0)) + s * y
    z = math.sqrt(max(1.0 - x * x - y * y, 0.0))
    h = (x * t1[0] + y * t2[0] + z * v[0], x * t1[1] + y * t2[1] + z * v[1],
         x * t1[2] + y * t2[2] + z * v[2])
    return normalize((alpha * h[0], alpha * h[1], max(h[2], 0.0)))


@jit
def erfinv(x):
    """The inverse error function on [-1, 1], +-1 giving +-5.86 (erfinv of the doubles nearest
    +-1) rather than infinities: Giles' (2010) approximation, refined."""
    # The Beckmann sampler passes 2 u - 1 with u = 0 possible: an infinite slope made its
    # microfacet normal NaN.
    x = min(max(x, -ERF_MAX), ERF_MAX)
    w = -math.log((1.0 - x) * (1.0 + x))
    if w < 5.0:
        w -= 2.5
        p = 2.81022636e-08
        p = 3.43273939e-07 + p * w
        p = -3.5233877e-06 + p * w
        p = -4.39150654e-06 + p * w
        p = 0.00021858087 + p * w
        p = -0.00125372503 + p * w
        p = -0.00417768164 + p * w
        p = 0.246640727 + p * w
        p = 1.50140941 + p * w
    else:
        w = math.sqrt(w) - 3.0
        p = -0.000200214257
        p = 0.000100950558 + p * w
        p = 0.00134934322 + p * w
        p = -0.00367342844 + p * w
        p = 0.00573950773 + p * w
        p = -0.0076224613 + p * w
        p = 0.00943887047 + p * w
        p = 1.00167406 + p * w
        p = 2.83297682 + p * w
    y = p * x
    # Newton steps take the approximation to double precision: on erf(y) = x, and past |x| = 0.9
    # on log erfc(|y|) = log(1 - |x|), nearly quadratic in y, with a right side exact there.
    # (erf(y) - x keeps no digits where erf(y) is within 1e-12 of 1: two steps on it had left
    # erfinv 3e-5 off at x = 1 - 1e-12.)
    for _ in range(8):
        if abs(x) > 0.9:
            sign = 1.0 if x > 0.0 else -1.0
            tail = math.erfc(sign * y)
            step = -sign * math.log(tail / (1.0 - sign * x)) * tail
        else:
            step = math.erf(y) - x
        step /= 1.1283791670955126 * math.exp(-y * y)
        y -= step
        if abs(step) <= 1e-8 * abs(y):      # converging quadratically: now within 1e-16
            break
    return y


@jit
def sample_beckmann_visible_normal(wi, alpha, u0, u1):
    """Beckmann visible normals (Heitz and d'Eon 2014, with Jakob's sampling of the slope): the
    slope's x is found by Newton steps with bisection on its monotone CDF, y is Gaussian."""
    v = normalize((alpha * wi[0], alpha * wi[1], wi[2]))
    cos_phi, sin_phi = 1.0, 0.0
    if v[2] >= 0.99999:                   # normal incidence: the slope is a plain Gaussian
        r = math.sqrt(-math.log(max(u0, 1e-300)))
        phi = 2.0 * math.pi * u1
        sx, sy = r * math.cos(phi), r * math.sin(phi)
    else:
        sin_t = math.sqrt(max(1.0 - v[2] * v[2], 0.0))
        tan_t = sin_t / v[2]
        cot_t = 1.0 / tan_t
        cos_phi, sin_phi = v[0] / sin_t, v[1] / sin_t
        erf_a = math.erf(cot_t)
        k = tan_t / math.sqrt(math.pi)
        target = u0 * (1.0 + erf_a + k * math.exp(-cot_t * cot_t))
        # Find b in (-1, erf_a) with 1 + b + k exp(-erfinv(b)^2) = target (the CDF is monotone).
        lo, hi = -1.0, erf_a
        b = min(max(u0 * (1.0 + erf_a) - 1.0, lo), hi)
        for _ in range(40):
            x = erfinv(b)
            value = 1.0 + b + k * math.exp(-x * x) - target
            if abs(value) < 1e-12:
                break
            if value > 0.0:
                hi = b
            else:
                lo = b
            step = b - value / (1.0 - x * tan_t)
            b = step if lo < step < hi else 0.5 * (lo + hi)
        sx = erfinv(b)
        sy = erfinv(2.0 * u1 - 1.0)
    sx, sy = cos_phi * sx - sin_phi * sy, sin_phi * sx + cos_phi * sy
    return normalize((-sx * alpha, -sy * alpha, 1.0))
