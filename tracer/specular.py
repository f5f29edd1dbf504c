"""Smooth scattering, one vertex at a time: mirror reflection, refraction, specular sampling.

Conventions follow Cycles (docs: shared/reference/cycles-conventions.md): directions are unit
vectors (tuples, see vec.py), `eta` is the relative index n_transmitted / n_incident, and a
smooth dielectric weights both reflection and refraction by its colour alone (no 1/eta^2
radiance scaling).
"""
from __future__ import annotations

import math

from .fresnel import fresnel
from .jit import jit, jit_inline
from .material_kinds import GLASS, MIRROR, REFRACTION
from .vec import add, dot, madd, mul, neg, sub

# What a specular vertex did (for the integrator's counters).
REFLECTED, TRANSMITTED, TIR, TIR_ABSORBED = range(4)


@jit
def reflect(d, n):
    """Mirror the incoming direction d about the normal n."""
    return madd(d, -2.0 * dot(d, n), n)


@jit
def refract(d, n, eta, cos_i, cos_t):
    """Refract d through a surface whose normal n faces the incident side (eta = n_t / n_i)."""
    inv = 1.0 / eta
    return madd(mul(d, inv), inv * cos_i - cos_t, n)


@jit
def valid_reflection_normal(ng, wi, n):
    """Cycles' ensure_valid_specular_reflection: bend the shading normal n towards ng just enough
    that the mirror reflection of wi (pointing away from the surface, like ng) clears it.

    The reflection ends at height t = min(0.9 wi.ng, 0.01) above the surface: in the plane of ng
    and n, n' = (sqrt(1 - z^2), z) solves 4 a z^4 - 2 b z^2 + c = 0 with a = Ix^2 + Iz^2,
    b = 2 (a + Iz t), c = (Iz + t)^2; Cycles takes the larger root when wi.x < 0.
    """
    iz = dot(wi, ng)
    t = min(0.9 * iz, 0.01)
    if 2.0 * dot(n, wi) * dot(n, ng) - iz >= t:
        return n
    x = sub(n, mul(ng, dot(n, ng)))
    x_len = math.sqrt(dot(x, x))
    x = mul(x, 1.0 / x_len) if x_len > 0.0 else n
    ix = dot(wi, x)
    a = ix * ix + iz * iz
    if not a > 0.0:
        return n
    b = 2.0 * (a + iz * t)
    c = (iz + t) ** 2
    root = math.sqrt(max(b * b - 4.0 * a * c, 0.0))
    z2 = ((b + root) if ix < 0.0 else (b - root)) * 0.25 / a
    return add(mul(x, math.sqrt(max(1.0 - z2, 0.0))), mul(ng, math.sqrt(max(z2, 0.0))))


@jit
def sample_specular(kind, d, ng, n, entering, color, trans_color, ior, fresnel_model, u):
    """Sample a mirror, smooth glass or refraction-only surface for the incoming direction d.

    ng and n face the incoming ray (n already bent by valid_reflection_normal where Cycles bends
    it); u in [0, 1) chooses reflection with probability F on glass. Returns (new direction,
    weight, event, valid, F): the weight is colour for reflections and transmission colour for
    refractions. valid is False where Cycles rejects the sample: the shading normal faces away
    from the viewer, or the new direction is not on the side its event implies for both normals.
    A refraction-only surface has nothing to give under total internal reflection (event
    TIR_ABSORBED, weight 0). Last, the Fresnel reflectance F it chose by (1 for a mirror).
    """
    cos_i = -dot(d, n)
    f = 1.0
    if kind == MIRROR:
        out, event, weight = reflect(d, n), REFLECTED, color
    else:
        eta = ior if entering else 1.0 / ior
        f, cos_t = fresnel(fresnel_model, cos_i, eta)
        if f >= 1.0:
            if kind == REFRACTION:
                return d, (0.0, 0.0, 0.0), TIR_ABSORBED, True, f
            out, event, weight = reflect(d, n), TIR, color
        elif kind == GLASS and u < f:
            out, event, weight = reflect(d, n), REFLECTED, color
        else:
            out, event, weight = refract(d, n, eta, cos_i, cos_t), TRANSMITTED, trans_color
    refracts = event == TRANSMITTED
    valid = cos_i > 0.0 and (dot(ng, out) < 0.0) == refracts and (dot(n, out) < 0.0) == refracts
    return out, weight, event, valid, f


@jit_inline
def sample_at_hit(kind, d, ng_f, ns_f, entering, has_normals, color, trans_color, ior,
                  fresnel_model, u):
    """sample_specular at a hit whose normals face the ray (geometry.facing), the shading
    normal bent as Cycles bends it for a reflection where the mesh has shading normals (a
    refraction-only surface's is not)."""
    n = ns_f
    if has_normals and kind != REFRACTION:
        n = valid_reflection_normal(ng_f, neg(d), ns_f)
    return sample_specular(kind, d, ng_f, n, entering, color, trans_color, ior, fresnel_model,
                           u)


@jit
def light_refraction_scale(ior, entering):
    """The factor a light path's weight takes at a refraction beyond sample_specular's weight:
    (n_i / n_t)^2 for the light's direction of travel (entering: the light arrives on the
    front side, n_i = 1, n_t = ior).

    Cycles carries radiance across a smooth refraction unchanged: its singular sample's eval
    and pdf are 1e6 (1 - F) tint and 1e6 (1 - F) (kernel/closure/bsdf_microfacet.h,
    bsdf_microfacet_sample), with no (n_t / n_i)^2 of physical radiance. A light path carries
    flux, which the delta of that BSDF, turned from the camera's side to the light's, spreads
    over the projected solid angle |cos_t| dw_t = (n_i / n_t)^2 |cos_i| dw_i (Snell's law, n^2
    cos dw invariant): the adjoint of Cycles' refraction weighs (n_i / n_t)^2 more than the
    camera path's. Entering and leaving a closed object cancel; an open pane, or light that
    ends on a diffuse surface inside glass, is one refraction left over.
    """
    eta = ior if entering else 1.0 / ior
    return 1.0 / (eta * eta)
