"""Scattering functions on arrays: Fresnel, reflection, refraction and their samplers.

Vectors are structure-of-arrays: shape (3, n), one row per coordinate, so every operation runs
on contiguous rows instead of strided (n, 3) columns (about five times faster in numpy).

Conventions follow Cycles (docs: shared/reference/cycles-conventions.md): directions are unit
vectors, `eta` is the relative index n_transmitted / n_incident, and a smooth dielectric weights
both reflection and refraction by its colour alone (no 1/eta^2 radiance scaling).
"""
from __future__ import annotations

import numpy as np

# Material kind codes, per triangle in the integrator (order matches scene.MATERIAL_KINDS).
DIFFUSE, MIRROR, GLASS, REFRACTION, EMISSION = range(5)


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot products of two (3, n) vector arrays."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def normalize(v: np.ndarray) -> np.ndarray:
    """Columns of a (3, n) array scaled to unit length."""
    return v * (1.0 / np.sqrt(dot(v, v)))


def fresnel_dielectric(cos_i, eta):
    """Exact unpolarised Fresnel reflectance and the cosine of the refracted ray.

    cos_i >= 0 is the cosine on the incident side, eta = n_t / n_i. Total internal reflection
    gives F = 1 and cos_t = 0 (tested before any square root, so it never makes a NaN).
    """
    cos_i = np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0)
    eta = np.asarray(eta, dtype=np.float64)
    g2 = eta * eta - 1.0 + cos_i * cos_i
    tir = g2 <= 0.0
    cos_t = np.sqrt(np.where(tir, 1.0, g2)) / eta
    r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    f = 0.5 * (r_s * r_s + r_p * r_p)
    return np.where(tir, 1.0, f), np.where(tir, 0.0, cos_t)


def fresnel_schlick(cos_i, eta):
    """Schlick's approximation (the seed's choice) and the refracted cosine.

    R0 = ((eta - 1) / (eta + 1))^2 and the cosine taken on the less dense side, as Schlick's
    approximation requires (for exits that is the refracted cosine). TIR gives F = 1.
    """
    cos_i = np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0)
    eta = np.asarray(eta, dtype=np.float64)
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.where(tir, 0.0, 1.0 - sin2_t))
    r0 = ((eta - 1.0) / (eta + 1.0)) ** 2
    c = np.where(eta >= 1.0, cos_i, cos_t)
    f = r0 + (1.0 - r0) * (1.0 - c) ** 5
    return np.where(tir, 1.0, f), np.where(tir, 0.0, cos_t)


FRESNEL = {"exact": fresnel_dielectric, "schlick": fresnel_schlick}


def reflect(d: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Mirror the incoming directions d about the normals n (both (3, n))."""
    return d - (2.0 * dot(d, n)) * n


def valid_reflection_normal(ng: np.ndarray, wi: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Cycles' ensure_valid_specular_reflection: bend shading normals n towards ng just enough
    that the mirror reflection of wi (pointing away from the surface, like ng) clears it.

    The reflection ends at height t = min(0.9 wi.ng, 0.01) above the surface: in the plane of ng
    and n, n' = (sqrt(1 - z^2), z) solves 4 a z^4 - 2 b z^2 + c = 0 with a = Ix^2 + Iz^2,
    b = 2 (a + Iz t), c = (Iz + t)^2; Cycles takes the larger root when wi.x < 0.
    """
    r_height = 2.0 * dot(n, wi) * dot(n, ng) - dot(wi, ng)
    iz = dot(wi, ng)
    t = np.minimum(0.9 * iz, 0.01)
    bad = r_height < t
    if not bad.any():
        return n
    x = n - dot(n, ng) * ng
    length = np.sqrt(dot(x, x))
    x = np.where(length > 0.0, x / np.where(length > 0.0, length, 1.0), n)
    ix = dot(wi, x)
    a = ix * ix + iz * iz
    b = 2.0 * (a + iz * t)
    c = (iz + t) ** 2
    root = np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        z2 = np.where(ix < 0.0, b + root, b - root) * 0.25 / a
    fixed = np.sqrt(np.maximum(1.0 - z2, 0.0)) * x + np.sqrt(np.maximum(z2, 0.0)) * ng
    return np.where(bad & (a > 0.0), fixed, n)


def refract(d: np.ndarray, n: np.ndarray, eta, cos_i, cos_t) -> np.ndarray:
    """Refract d through surfaces whose normals n face the incident side (eta = n_t / n_i)."""
    inv = 1.0 / np.asarray(eta, dtype=np.float64)
    return inv * d + (inv * cos_i - cos_t) * n


def orthonormal_basis(n: np.ndarray):
    """Two unit tangents completing the normals n (Duff et al. 2017, branchless)."""
    sign = np.where(n[2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    t = np.stack([1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]])
    s = np.stack([b, sign + n[1] * n[1] * a, -n[1]])
    return t, s


def sample_cosine_hemisphere(n: np.ndarray, u: np.ndarray):
    """Cosine-weighted directions around the normals n for u (2, n); returns (wi, pdf)."""
    r = np.sqrt(u[0])
    phi = 2.0 * np.pi * u[1]
    x, y = r * np.cos(phi), r * np.sin(phi)
    z = np.sqrt(np.maximum(0.0, 1.0 - u[0]))
    t, s = orthonormal_basis(n)
    return x * t + y * s + z * n, z * (1.0 / np.pi)


def sample_uniform_sphere(u: np.ndarray) -> np.ndarray:
    """Uniform directions on the unit sphere (pdf 1 / 4 pi) for u (2, n)."""
    z = 1.0 - 2.0 * u[0]
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = 2.0 * np.pi * u[1]
    return np.stack([r * np.cos(phi), r * np.sin(phi), z])


def sample_uniform_disk(u: np.ndarray) -> np.ndarray:
    """Uniform points (2, n) on the unit disk (concentric mapping, so strata stay compact)."""
    a = 2.0 * u[0] - 1.0
    b = 2.0 * u[1] - 1.0
    use_a = np.abs(a) > np.abs(b)
    r = np.where(use_a, a, b)
    safe_a = np.where(a == 0.0, 1.0, a)
    safe_b = np.where(b == 0.0, 1.0, b)
    theta = np.where(use_a, (np.pi / 4.0) * (b / safe_a), np.pi / 2.0 - (np.pi / 4.0) * (a / safe_b))
    theta = np.where((a == 0.0) & (b == 0.0), 0.0, theta)
    return np.stack([r * np.cos(theta), r * np.sin(theta)])


def sample_regular_polygon(u: np.ndarray, blades: int, rotation: float) -> np.ndarray:
    """Uniform points (2, n) in a regular polygon inscribed in the unit circle, as Cycles' aperture."""
    corner = np.floor(u[0] * blades)
    s = np.sqrt(u[0] * blades - corner)
    v = u[1] * s
    a = 1.0 - s
    half = np.pi / blades
    px, py = (a + v) * np.cos(half), (a - v) * np.sin(half)
    rot = rotation + corner * 2.0 * np.pi / blades
    c, sn = np.cos(rot), np.sin(rot)
    return np.stack([c * px - sn * py, sn * px + c * py])
