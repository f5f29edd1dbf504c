"""A surface's BSDF as Cycles builds it from its shader: a few lobes (Lambert, or microfacet
reflection and transmission with a Fresnel model), each with a colour weight and a sampling
weight, evaluated as their sum and sampled by picking one lobe.

Cycles' closures are the model (kernel/svm/closure.h, closure/bsdf_microfacet.h, Blender 5.0): the
setup functions below build the lobes of the Glossy, Glass and Refraction BSDFs and of the
Principled BSDF's layers for one hit, with the same energy compensation (Multiscatter GGX) and
the same layering weights, so the sum of the lobes is the BSDF Cycles renders.

A lobe is a row of a (MAX_LOBES, FIELDS) float64 array that the caller owns (compiled code does
not allocate); its columns are named below. Directions point away from the surface; wi is the
direction to the viewer and every lobe's normal faces it. eval returns f |cos(n, wo)|, as Cycles.
"""
from __future__ import annotations

import math

from . import microfacet
from .specular import refract
from .fresnel import (dielectric_fss, f0_from_ior, f82_fss, f82_tint_b, fresnel_dielectric,
                      fresnel_f82, fresnel_remapped, ior_from_f0, mix_to_one, mix_to_one3,
                      remap_factor)
from .jit import jit, jit_inline
from .microfacet import BECKMANN, GGX, is_almost_specular, ndf, smith_lambda
from .microfacet_tables import ggx_albedo, glass_albedo, remap_albedo
from .path_limits import drops
from .sampling import orthonormal_basis, sample_cosine_hemisphere
from .vec import add, dot, madd, mean3, mul, normalize, vmul

# Lobe kinds: Lambert reflection, microfacet reflection and refraction, Lambert transmission
# (the Translucent BSDF: Lambert about the reversed normal) and straight-through transparency (the
# Transparent BSDF and Principled Alpha: singular, the path goes on unbent).
LAMBERT, MICROFACET, TRANSLUCENT, TRANSPARENT = range(4)
# Fresnel models of a microfacet lobe: none (the colour alone), the dielectric, the dielectric
# remapped to [f0, 1] (Cycles' generalized Schlick with a negative exponent), F82-tint.
NO_FRESNEL, DIELECTRIC, REMAPPED, F82 = range(4)
# What a sample did (bit masks of them: 1 << event). A transparent sample is no scattering event:
# the path goes on as the ray it was (Cycles' LABEL_TRANSMIT_TRANSPARENT).
DIFFUSE_EVENT, REFLECT_EVENT, TRANSMIT_EVENT, TRANSPARENT_EVENT = range(4)
ALL_EVENTS = 7
# Columns of a lobe row.
KIND, DIST, ALPHA, ETA, REFLECTS, TRANSMITS, FRESNEL, ENERGY, SAMPLE_WEIGHT = range(9)
WEIGHT, F0, TINT_B, R_TINT, T_TINT, NORMAL = 9, 12, 15, 18, 21, 24   # three columns each
# The hit's smooth shading normal (facing the ray) where a lobe's NORMAL was bent away from it
# by a Normal Map (bump_shadowing); new_lobe makes it NORMAL itself.
SMOOTH_NORMAL = 27
FIELDS = 30
# The Principled BSDF alone has up to 6 (transparency, coat, metallic, transmission, specular,
# diffuse); a shader program's mix of closures may have more: those past MAX_LOBES are left out.
MAX_LOBES = 16
WEIGHT_CUTOFF = 1e-5   # Cycles' CLOSURE_WEIGHT_CUTOFF: lighter layers are left out
# Distributions of the scene file (scene.DISTRIBUTIONS order).
DIST_GGX, DIST_MULTI_GGX, DIST_BECKMANN = range(3)
# Principled BSDF parameters: columns of the materials' `principled` table.
(P_METALLIC, P_ROUGHNESS, P_IOR, P_SPECULAR_LEVEL, P_TRANSMISSION, P_COAT, P_COAT_ROUGHNESS,
 P_COAT_IOR) = range(8)
P_SPECULAR_TINT, P_COAT_TINT = 8, 11                                   # three columns each
P_FIELDS = 14


@jit
def vec_at(lobe, column):
    """Three columns of a lobe row as a vector."""
    return (lobe[column], lobe[column + 1], lobe[column + 2])


@jit
def set_vec(lobe, column, v):
    """Write a vector into three columns of a lobe row."""
    lobe[column], lobe[column + 1], lobe[column + 2] = v[0], v[1], v[2]


@jit
def new_lobe(lobe, kind, n, weight):
    """Start a lobe: kind, normal, colour weight; a neutral microfacet otherwise."""
    lobe[:] = 0.0
    lobe[KIND] = kind
    lobe[ENERGY] = 1.0
    lobe[SAMPLE_WEIGHT] = abs(mean3(weight))
    lobe[REFLECTS] = 1.0
    set_vec(lobe, NORMAL, n)
    set_vec(lobe, SMOOTH_NORMAL, n)
    set_vec(lobe, WEIGHT, weight)
    set_vec(lobe, R_TINT, (1.0, 1.0, 1.0))


@jit
def bump_shadowing(lobe, wo, is_eval):
    """The factor Cycles 5.0 puts on a lobe whose normal a normal map bent away from the smooth
    normal ns (kernel/closure/bsdf.h, bump_shadowing_term): 0 for light wo on the other side of
    ns than the bent normal (always in evaluation; in sampling for diffuse lobes), and on
    diffuse lobes a GGX shadowing G1(alpha^2 = tan^2(ns, n) / 8, |cos(ns, wo)|) that fades light
    at grazing angles to ns (Bump Map Correction, on by default in Blender)."""
    n, ns = vec_at(lobe, NORMAL), vec_at(lobe, SMOOTH_NORMAL)
    if n[0] == ns[0] and n[1] == ns[1] and n[2] == ns[2]:
        return 1.0
    cos_ns_i, cos_ns_n, cos_n_i = dot(ns, wo), dot(ns, n), dot(n, wo)
    diffuse = lobe[KIND] == LAMBERT or lobe[KIND] == TRANSLUCENT
    if cos_ns_i * cos_ns_n * cos_n_i < 0.0 and (is_eval or diffuse):
        return 0.0
    if not diffuse:
        return 1.0
    cos_i, cos_d = abs(cos_ns_i), abs(cos_ns_n)
    if cos_d >= 1.0 or cos_i >= 1.0:
        return 1.0
    if cos_i < 1e-6:
        return 0.0
    alpha2 = min(max(0.125 * (1.0 / (cos_d * cos_d) - 1.0), 0.0), 1.0)
    return 1.0 / (1.0 + smith_lambda(GGX, alpha2, cos_i))


@jit
def new_microfacet(lobe, n, weight, dist, alpha, eta, reflects, transmits, fresnel_model):
    """Start a microfacet lobe (alpha = roughness^2, eta = n_t / n_i on wi's side)."""
    new_lobe(lobe, MICROFACET, n, weight)
    lobe[DIST] = BECKMANN if dist == DIST_BECKMANN else GGX
    lobe[ALPHA] = min(max(alpha, 0.0), 1.0)
    lobe[ETA] = eta
    lobe[REFLECTS] = 1.0 if reflects else 0.0
    lobe[TRANSMITS] = 1.0 if transmits else 0.0
    lobe[FRESNEL] = fresnel_model


# ---------------------------------------------------------------------------------------------
# One lobe


@jit
def lobe_fresnel(lobe, cos_hi):
    """Reflectance and transmittance (RGB) of a microfacet lobe at a microfacet seen at cosine
    cos_hi, and the refracted cosine (Cycles' microfacet_fresnel)."""
    model, eta = lobe[FRESNEL], lobe[ETA]
    c = abs(cos_hi)
    f_real, cos_t = fresnel_dielectric(c, eta)
    if model == DIELECTRIC:
        r, t = (f_real, f_real, f_real), (1.0 - f_real, 1.0 - f_real, 1.0 - f_real)
    elif model == REMAPPED:
        f, cos_t = fresnel_remapped(c, eta, vec_at(lobe, F0))
        r = vmul(f, vec_at(lobe, R_TINT))
        t = vmul((1.0 - f[0], 1.0 - f[1], 1.0 - f[2]), vec_at(lobe, T_TINT))
    elif model == F82:
        r, t = fresnel_f82(c, vec_at(lobe, F0), vec_at(lobe, TINT_B)), (0.0, 0.0, 0.0)
    else:
        # No Fresnel: the colour alone, but a refraction-only lobe has nothing under total
        # internal reflection.
        r = (1.0, 1.0, 1.0)
        t = (0.0, 0.0, 0.0) if f_real >= 1.0 else (1.0, 1.0, 1.0)
    return mul(r, lobe[REFLECTS]), mul(t, lobe[TRANSMITS]), cos_t


@jit
def lobe_eval(lobe, wi, wo):
    """(f |cos(n, wo)| as RGB, without the lobe's weight; solid-angle density of sampling wo)."""
    shadowing = bump_shadowing(lobe, wo, True)
    if shadowing == 0.0:
        return (0.0, 0.0, 0.0), 0.0
    n = vec_at(lobe, NORMAL)
    cos_no = dot(n, wo)
    if lobe[KIND] == LAMBERT or lobe[KIND] == TRANSLUCENT:
        if lobe[KIND] == TRANSLUCENT:
            cos_no = -cos_no
        if cos_no <= 0.0:
            return (0.0, 0.0, 0.0), 0.0
        f = cos_no / math.pi
        return (f * shadowing, f * shadowing, f * shadowing), f
    if lobe[KIND] == TRANSPARENT:
        return (0.0, 0.0, 0.0), 0.0
    cos_ni = dot(n, wi)
    alpha, eta = lobe[ALPHA], lobe[ETA]
    transmission = cos_no < 0.0
    if (cos_ni <= 0.0 or is_almost_specular(alpha)
            or (transmission and lobe[TRANSMITS] == 0.0)
            or (not transmission and lobe[REFLECTS] == 0.0)):
        return (0.0, 0.0, 0.0), 0.0
    h = mul(add(mul(wo, eta), wi), -1.0) if transmission else add(wi, wo)
    length = math.sqrt(dot(h, h))
    if not length > 0.0:
        return (0.0, 0.0, 0.0), 0.0
    h = mul(h, 1.0 / length)
    if transmission:
        # Only microfacets that face both directions refract wi into wo. Cycles 5.0 evaluates
        # the other pairs too (its "TODO: check if the refraction configuration is valid"),
        # light that its own sampling never produces; Snell keeps eval and sampling consistent.
        if dot(h, n) < 0.0:
            h = mul(h, -1.0)
        if dot(h, wi) <= 0.0 or dot(h, wo) >= 0.0:
            return (0.0, 0.0, 0.0), 0.0
    cos_hi = dot(h, wi)
    r, t, _ = lobe_fresnel(lobe, cos_hi)
    if max(r[0], r[1], r[2], t[0], t[1], t[2]) <= 0.0:
        return (0.0, 0.0, 0.0), 0.0
    alpha2 = alpha * alpha
    dist = int(lobe[DIST])
    d = ndf(dist, alpha2, dot(n, h))
    lambda_i = smith_lambda(dist, alpha2, cos_ni)
    lambda_o = smith_lambda(dist, alpha2, cos_no)
    if transmission:
        common = d / cos_ni * (eta / length) ** 2 * abs(cos_hi * dot(h, wo))
    else:
        common = d / cos_ni * 0.25
    p_reflect = mean3(r) / mean3(add(r, t))
    pdf = common * (1.0 - p_reflect if transmission else p_reflect) / (1.0 + lambda_i)
    value = mul(t if transmission else r,
                common / (1.0 + lambda_i + lambda_o) * lobe[ENERGY] * shadowing)
    return value, pdf


@jit
def lobe_sample(lobe, ng, wi, u0, u1, u2):
    """Sample a direction from one lobe: (wo, f |cos| RGB without the weight, density, event,
    singular, valid). For a singular (perfectly specular) lobe f is the Fresnel factor and the
    density the probability of the event. valid is False where Cycles rejects the sample (wo on
    the wrong side of either normal for its event)."""
    n = vec_at(lobe, NORMAL)
    if lobe[KIND] == LAMBERT:
        wo, pdf = sample_cosine_hemisphere(n, u0, u1)
        if dot(ng, wo) <= 0.0:
            return wo, (0.0, 0.0, 0.0), 0.0, DIFFUSE_EVENT, False, False
        # Cycles scales a sampled reflection's value, not its density, by the bump shadowing
        # (a microfacet lobe's sample it leaves alone: its factor is 1 when sampling).
        f = pdf * bump_shadowing(lobe, wo, False)
        return wo, (f, f, f), pdf, DIFFUSE_EVENT, False, True
    if lobe[KIND] == TRANSLUCENT:
        wo, pdf = sample_cosine_hemisphere(mul(n, -1.0), u0, u1)
        if dot(ng, wo) >= 0.0:
            return wo, (0.0, 0.0, 0.0), 0.0, DIFFUSE_EVENT, False, False
        return wo, (pdf, pdf, pdf), pdf, DIFFUSE_EVENT, False, True
    if lobe[KIND] == TRANSPARENT:
        return mul(wi, -1.0), (1.0, 1.0, 1.0), 1.0, TRANSPARENT_EVENT, True, True
    cos_ni = dot(n, wi)
    zero = (0.0, 0.0, 0.0)
    if cos_ni <= 0.0:
        return wi, zero, 0.0, REFLECT_EVENT, False, False
    alpha, eta = lobe[ALPHA], lobe[ETA]
    dist = int(lobe[DIST])
    singular = is_almost_specular(alpha)
    if singular:
        h, cos_nh = n, 1.0
    else:
        tx, ty = orthonormal_basis(n)
        local_i = (dot(wi, tx), dot(wi, ty), cos_ni)
        local_h = microfacet.sample_visible_normal(dist, local_i, alpha, u0, u1)
        h = normalize(madd(madd(mul(tx, local_h[0]), local_h[1], ty), local_h[2], n))
        cos_nh = local_h[2]
    cos_hi = dot(h, wi)
    r, t, cos_t = lobe_fresnel(lobe, cos_hi)
    total = mean3(add(r, t))
    if not total > 0.0:
        return wi, zero, 0.0, REFLECT_EVENT, singular, False
    p_reflect = mean3(r) / total
    transmission = u2 >= p_reflect
    if transmission:
        wo = refract(mul(wi, -1.0), h, eta, cos_hi, cos_t)
    else:
        wo = madd(mul(wi, -1.0), 2.0 * cos_hi, h)
    event = TRANSMIT_EVENT if transmission else REFLECT_EVENT
    cos_no = dot(n, wo)
    if (dot(ng, wo) < 0.0) != transmission or (cos_no < 0.0) != transmission:
        return wo, zero, 0.0, event, singular, False
    f = t if transmission else r
    pdf = 1.0 - p_reflect if transmission else p_reflect
    if singular or (transmission and abs(eta - 1.0) < 1e-4):
        return wo, f, pdf, event, True, True
    alpha2 = alpha * alpha
    d = ndf(dist, alpha2, cos_nh)
    lambda_i = smith_lambda(dist, alpha2, cos_ni)
    lambda_o = smith_lambda(dist, alpha2, cos_no)
    if transmission:
        cos_ho = dot(h, wo)
        common = d / cos_ni * abs(cos_hi * cos_ho) / (cos_ho + cos_hi / eta) ** 2
    else:
        common = d / cos_ni * 0.25
    return (wo, mul(f, common / (1.0 + lambda_i + lambda_o) * lobe[ENERGY]),
            pdf * common / (1.0 + lambda_i), event, False, True)


# ---------------------------------------------------------------------------------------------
# The sum of a hit's lobes


@jit
def lobe_event(lobe, wo):
    """What scattering into wo is for this lobe: DIFFUSE_EVENT, REFLECT_EVENT, TRANSMIT_EVENT
    (or TRANSPARENT_EVENT, which bsdf_eval never meets: a transparent lobe evaluates to 0)."""
    if lobe[KIND] == LAMBERT or lobe[KIND] == TRANSLUCENT:
        return DIFFUSE_EVENT
    if lobe[KIND] == TRANSPARENT:
        return TRANSPARENT_EVENT
    return TRANSMIT_EVENT if dot(vec_at(lobe, NORMAL), wo) < 0.0 else REFLECT_EVENT


@jit
def bsdf_eval(lobes, count, wi, wo, events):
    """The hit's BSDF for light arriving from wo: (f |cos| RGB, density of bsdf_sample). Only
    lobes whose event is in the bit mask `events` (1 << event) add to f, as Cycles leaves out
    the closures a lamp is invisible to; all of them add to the density."""
    f = (0.0, 0.0, 0.0)
    pdf = 0.0
    total_weight = 0.0
    for i in range(count):
        lobe = lobes[i]
        value, p = lobe_eval(lobe, wi, wo)
        if p > 0.0:
            if events & (1 << lobe_event(lobe, wo)):
                f = add(f, vmul(value, vec_at(lobe, WEIGHT)))
            pdf += p * lobe[SAMPLE_WEIGHT]
        total_weight += lobe[SAMPLE_WEIGHT]
    return f, (pdf / total_weight if total_weight > 0.0 else 0.0)


@jit
def bsdf_sample(lobes, count, ng, wi, u_pick, u0, u1):
    """Sample the hit's BSDF: one lobe picked by sampling weight (u_pick; what is left of it
    picks reflection or refraction), then a direction from it. Returns (wo, throughput factor
    f |cos| / pdf RGB, density for MIS (0 after a singular lobe), event, valid)."""
    total_weight = 0.0
    for i in range(count):
        total_weight += lobes[i, SAMPLE_WEIGHT]
    if not total_weight > 0.0:
        return wi, (0.0, 0.0, 0.0), 0.0, REFLECT_EVENT, False
    pick = u_pick * total_weight
    chosen = count - 1
    for i in range(count):
        if pick < lobes[i, SAMPLE_WEIGHT] or i == count - 1:
            chosen = i
            break
        pick -= lobes[i, SAMPLE_WEIGHT]
    lobe = lobes[chosen]
    share = lobe[SAMPLE_WEIGHT] / total_weight
    u2 = min(pick / lobe[SAMPLE_WEIGHT], 1.0) if lobe[SAMPLE_WEIGHT] > 0.0 else 0.0
    wo, f, pdf, event, singular, valid = lobe_sample(lobe, ng, wi, u0, u1, u2)
    if not valid or not pdf > 0.0:
        return wo, (0.0, 0.0, 0.0), 0.0, event, False
    if singular:
        return wo, mul(vmul(f, vec_at(lobe, WEIGHT)), 1.0 / (pdf * share)), 0.0, event, True
    f = vmul(f, vec_at(lobe, WEIGHT))
    pdf *= lobe[SAMPLE_WEIGHT]
    for i in range(count):
        if i != chosen:
            value, p = lobe_eval(lobes[i], wi, wo)
            if p > 0.0:
                f = add(f, vmul(value, vec_at(lobes[i], WEIGHT)))
                pdf += p * lobes[i, SAMPLE_WEIGHT]
    pdf /= total_weight
    return wo, mul(f, 1.0 / pdf), pdf, event, True



@jit_inline
def lobe_albedo(lobe, tables, wi):
    """A lobe's albedo seen from wi, weight included, as Cycles estimates it for the Denoising
    Albedo pass (bsdf_albedo with reflection and transmission): lobe_albedo_parts' sum."""
    reflected, transmitted = lobe_albedo_parts(lobe, tables, wi)
    return add(reflected, transmitted)


@jit_inline
def lobe_albedo_parts(lobe, tables, wi):
    """A lobe's albedo seen from wi, weight included, split into (reflected, transmitted), as
    Cycles 5.0's bsdf_albedo (kernel/closure/bsdf.h, bsdf_microfacet_estimate_albedo) estimates
    it for the Denoising Albedo and the Color passes: a Lambert or Translucent lobe's weight (all
    reflected: Cycles counts it as diffuse); a microfacet lobe's weight x (reflectance,
    transmittance) of its Fresnel at the lobe's normal, the reflectance of a remapped or
    dielectric (index above 1) Fresnel read from the albedo table for its roughness instead.
    The transmittance stays the Fresnel's at the normal: 1 - F of the table (Cycles' reading of
    its code) made the Denoising Albedo inconsistent with Cycles' on the glass sphere's rim
    (tests/validation/test_denoising_passes_compare.py). F82 keeps the smooth reflectance:
    Snell has no table of Cycles' exponent-5 Schlick albedo."""
    weight = vec_at(lobe, WEIGHT)
    zero = (0.0, 0.0, 0.0)
    if lobe[KIND] == LAMBERT or lobe[KIND] == TRANSLUCENT:
        return weight, zero
    if lobe[KIND] == TRANSPARENT:
        return zero, zero
    cos_i = dot(wi, vec_at(lobe, NORMAL))
    r, t, _ = lobe_fresnel(lobe, cos_i)
    model, eta = lobe[FRESNEL], lobe[ETA]
    if max(r[0], r[1], r[2]) > 0.0:
        rough = math.sqrt(lobe[ALPHA])
        if model == REMAPPED:
            s = remap_albedo(tables, rough, cos_i, eta)
            r = vmul(mix_to_one3(vec_at(lobe, F0), s), vec_at(lobe, R_TINT))
        elif model == DIELECTRIC and eta > 1.0:
            f = mix_to_one(f0_from_ior(eta), remap_albedo(tables, rough, cos_i, eta))
            r = (f, f, f)
    return vmul(weight, r), vmul(weight, t)

# ---------------------------------------------------------------------------------------------
# Shaders: the lobes of one hit


@jit
def preserve_energy(lobe, tables, wi, fss):
    """Multiscatter GGX: scale a GGX lobe by 1 / E (its single-scattering albedo) and darken it
    by the multiple-bounce Fresnel of average fss (Kulla and Conty 2017, as Cycles applies it)."""
    rough = math.sqrt(lobe[ALPHA])
    mu = dot(wi, vec_at(lobe, NORMAL))
    if lobe[TRANSMITS] > 0.0:
        e, e_avg = glass_albedo(tables, rough, mu, lobe[ETA])
    else:
        e, e_avg = ggx_albedo(tables, rough, mu)
    missing = (1.0 - e) / e
    lobe[ENERGY] = 1.0 + missing
    if fss[0] != 1.0 or fss[1] != 1.0 or fss[2] != 1.0:
        darkening = 0.0
        for k in range(3):
            fms = fss[k] * e_avg / (1.0 - fss[k] * (1.0 - e_avg))
            factor = (1.0 + fms * missing) / lobe[ENERGY]
            lobe[WEIGHT + k] *= factor
            darkening += factor / 3.0
        lobe[SAMPLE_WEIGHT] *= darkening


@jit
def setup_glossy(lobes, tables, n, wi, color, roughness, dist, drop=0):
    """The Glossy BSDF: microfacet reflection weighted by its colour (no Fresnel); none where
    the hit drops reflective caustics (drop: path_limits.dropped_at)."""
    if drops(drop, False):
        return 0
    lobe = lobes[0]
    new_microfacet(lobe, n, color, dist, roughness * roughness, 1.0, True, False, NO_FRESNEL)
    if dist == DIST_MULTI_GGX:
        preserve_energy(lobe, tables, wi, color)
    return 1


@jit
def setup_glass(lobes, tables, n, wi, entering, color, trans_color, roughness, dist, ior,
                drop=0):
    """The Glass BSDF: microfacet reflection and refraction with the dielectric Fresnel, tinted
    by colour (and trans_color for the refraction); a kind of caustics the hit drops (drop:
    path_limits.dropped_at) has tint 0, and with both dropped there is no lobe."""
    reflects, refracts = not drops(drop, False), not drops(drop, True)
    if not (reflects or refracts):
        return 0
    lobe = lobes[0]
    eta = ior if entering else 1.0 / ior
    new_microfacet(lobe, n, (1.0, 1.0, 1.0), dist, roughness * roughness, eta, True, True,
                   REMAPPED)
    f0 = f0_from_ior(ior)
    set_vec(lobe, F0, (f0, f0, f0))
    set_vec(lobe, R_TINT, color if reflects else (0.0, 0.0, 0.0))
    set_vec(lobe, T_TINT, trans_color if refracts else (0.0, 0.0, 0.0))
    if dist == DIST_MULTI_GGX:
        preserve_energy(lobe, tables, wi, glass_fss(lobe, refracts))
    return 1


@jit
def glass_fss(lobe, refracts):
    """The multiple-bounce Fresnel a glass lobe's energy preservation assumes (Cycles'
    bsdf_microfacet_setup_fresnel_generalized_schlick): its transmission tint, or with none
    (refractive caustics dropped) its reflection tint x the remapped Fresnel's average."""
    if refracts:
        return vec_at(lobe, T_TINT)
    eta = lobe[ETA]
    s = remap_factor(dielectric_fss(eta), f0_from_ior(eta))
    return vmul(vec_at(lobe, R_TINT), mix_to_one3(vec_at(lobe, F0), s))


@jit
def setup_refraction(lobes, n, entering, color, roughness, dist, ior, drop=0):
    """The Refraction BSDF: microfacet refraction weighted by its colour, nothing under total
    internal reflection; none where the hit drops refractive caustics."""
    if drops(drop, True):
        return 0
    eta = ior if entering else 1.0 / ior
    new_microfacet(lobes[0], n, color, dist, roughness * roughness, eta, False, True, NO_FRESNEL)
    return 1


@jit
def layering_weight(weight, lobe_weight, albedo):
    """What a layer leaves to the layers below it (Cycles' closure_layering_weight): weight x
    (1 - the largest ratio of the layer's albedo to the weight), clamped to [0, 1]."""
    ratio = 0.0
    for k in range(3):
        if weight[k] != 0.0:
            ratio = max(ratio, lobe_weight[k] * albedo[k] / weight[k])
    return mul(weight, min(max(1.0 - ratio, 0.0), 1.0))


@jit
def setup_principled(lobes, tables, n, n_diffuse, wi, entering, base, params, dist, drop=0):
    """The Principled BSDF's layers as Cycles 5.0 stacks them: coat, metallic, transmission,
    dielectric specular over a Lambert base. Returns the number of lobes. Where the hit drops
    a kind of caustics (drop: path_limits.dropped_at), Cycles leaves out the coat, metallic
    and specular layers (reflective) and the transmission's tint of that kind, and a dropped
    coat or specular layer no longer dims the layers below it."""
    reflects, refracts = not drops(drop, False), not drops(drop, True)
    count = 0
    weight = (1.0, 1.0, 1.0)
    clamped = (min(base[0], 1.0), min(base[1], 1.0), min(base[2], 1.0))
    roughness = min(max(params[P_ROUGHNESS], 0.0), 1.0)
    alpha = roughness * roughness
    ior = max(params[P_IOR], 1e-5)
    tint = (max(params[P_SPECULAR_TINT], 0.0), max(params[P_SPECULAR_TINT + 1], 0.0),
            max(params[P_SPECULAR_TINT + 2], 0.0))
    coat = max(params[P_COAT], 0.0)
    if coat > WEIGHT_CUTOFF:
        coat_ior = max(params[P_COAT_IOR], 1.0)
        if reflects:
            weight = setup_coat(lobes[count], tables, n, wi, weight, coat, coat_ior,
                                min(max(params[P_COAT_ROUGHNESS], 0.0), 1.0))
            count += 1
        coat_tint = (params[P_COAT_TINT], params[P_COAT_TINT + 1], params[P_COAT_TINT + 2])
        if coat_tint[0] != 1.0 or coat_tint[1] != 1.0 or coat_tint[2] != 1.0:
            # Beer's law through a coat of unit thickness along the refracted view ray.
            cos_i = dot(wi, n)
            cos_t = math.sqrt(1.0 - (1.0 - cos_i * cos_i) / (coat_ior * coat_ior))
            weight = vmul(weight, tuple_mix(coat, coat_tint, 1.0 / cos_t))
    metallic = min(max(params[P_METALLIC], 0.0), 1.0)
    if metallic > WEIGHT_CUTOFF and reflects:
        lobe = lobes[count]
        new_microfacet(lobe, n, mul(weight, metallic), DIST_GGX, alpha, 1.0, True, False, F82)
        set_vec(lobe, F0, clamped)
        edge = (min(tint[0], 1.0), min(tint[1], 1.0), min(tint[2], 1.0))
        b = (0.0, 0.0, 0.0) if edge == (1.0, 1.0, 1.0) else f82_tint_b(clamped, edge)
        set_vec(lobe, TINT_B, b)
        if dist == DIST_MULTI_GGX:
            preserve_energy(lobe, tables, wi, f82_fss(clamped, b))
        count += 1
    if metallic > WEIGHT_CUTOFF:
        weight = mul(weight, 1.0 - metallic)
    transmission = min(max(params[P_TRANSMISSION], 0.0), 1.0)
    if transmission > WEIGHT_CUTOFF and (reflects or refracts):
        lobe = lobes[count]
        new_microfacet(lobe, n, mul(weight, transmission), DIST_GGX, alpha,
                       ior if entering else 1.0 / ior, True, True, REMAPPED)
        f0 = f0_from_ior(ior)
        set_vec(lobe, F0, mul(tint, f0))
        if refracts:
            set_vec(lobe, T_TINT, (math.sqrt(clamped[0]), math.sqrt(clamped[1]),
                                   math.sqrt(clamped[2])))
        if not reflects:
            set_vec(lobe, R_TINT, (0.0, 0.0, 0.0))
        if dist == DIST_MULTI_GGX:
            preserve_energy(lobe, tables, wi, glass_fss(lobe, refracts))
        count += 1
    if transmission > WEIGHT_CUTOFF:
        weight = mul(weight, 1.0 - transmission)
    level = max(params[P_SPECULAR_LEVEL], 0.0)
    eta = ior
    f0 = f0_from_ior(eta)
    if level != 0.5:
        f0 *= 2.0 * level
        eta = ior_from_f0(f0)
        if ior < 1.0:
            eta = 1.0 / eta
    if eta != 1.0 and reflects:
        lobe = lobes[count]
        new_microfacet(lobe, n, weight, DIST_GGX, alpha, eta, True, False, REMAPPED)
        f0_rgb = mul(tint, f0)
        set_vec(lobe, F0, f0_rgb)
        if dist == DIST_MULTI_GGX:
            s = remap_factor(dielectric_fss(eta), f0_from_ior(eta))
            preserve_energy(lobe, tables, wi, mix_to_one3(f0_rgb, s))
        albedo = (0.0, 0.0, 0.0)
        r, _, _ = lobe_fresnel(lobe, dot(wi, n))
        if max(r[0], r[1], r[2]) > 0.0:
            albedo = mix_to_one3(f0_rgb, remap_albedo(tables, roughness, dot(wi, n), eta))
        lobe[SAMPLE_WEIGHT] *= mean3(albedo)
        weight = layering_weight(weight, vec_at(lobe, WEIGHT), albedo)
        count += 1
    new_lobe(lobes[count], LAMBERT, n_diffuse, vmul((max(base[0], 0.0), max(base[1], 0.0),
                                                     max(base[2], 0.0)), weight))
    return count + 1


@jit
def setup_coat(lobe, tables, n, wi, weight, coat, coat_ior, coat_rough):
    """The Principled BSDF's coat lobe over layers of weight `weight`; returns what it leaves
    to them."""
    new_microfacet(lobe, n, mul(weight, coat), DIST_GGX, coat_rough * coat_rough, coat_ior,
                   True, False, DIELECTRIC)
    fss = dielectric_fss(coat_ior)
    preserve_energy(lobe, tables, wi, (fss, fss, fss))
    f = 0.0                 # Cycles' albedo estimate of a dielectric of index 1 is 0
    if coat_ior > 1.0:
        f = mix_to_one(f0_from_ior(coat_ior),
                       remap_albedo(tables, coat_rough, dot(wi, n), coat_ior))
    lobe[SAMPLE_WEIGHT] *= f
    return layering_weight(weight, vec_at(lobe, WEIGHT), (f, f, f))


@jit
def tuple_mix(t, color, exponent):
    """1 + t (color^exponent - 1) per component."""
    return (1.0 + t * (color[0] ** exponent - 1.0), 1.0 + t * (color[1] ** exponent - 1.0),
            1.0 + t * (color[2] ** exponent - 1.0))


# Shaders of layered materials (Materials.shader in the integrator).
SHADER_GLOSSY, SHADER_GLASS, SHADER_REFRACTION, SHADER_PRINCIPLED = range(4)


@jit
def setup_shader(lobes, tables, shader, color, trans_color, ior, roughness, dist, params, n,
                 n_diffuse, wi, entering, drop):
    """The lobes of one hit on a layered material (n: the normal bent for specular reflection,
    n_diffuse: the shading normal; drop: the caustics it drops, path_limits.dropped_at);
    returns their number."""
    if shader == SHADER_GLOSSY:
        return setup_glossy(lobes, tables, n, wi, color, roughness, dist, drop)
    if shader == SHADER_GLASS:
        return setup_glass(lobes, tables, n, wi, entering, color, trans_color, roughness, dist,
                           ior, drop)
    if shader == SHADER_REFRACTION:
        return setup_refraction(lobes, n, entering, color, roughness, dist, ior, drop)
    return setup_principled(lobes, tables, n, n_diffuse, wi, entering, color, params, dist,
                            drop)
