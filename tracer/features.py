"""The Denoising Albedo and Denoising Normal passes as Cycles defines them
(kernel/film/denoising_passes.h, film_write_denoising_features_surface).

A camera path carries a feature weight, 1 at the camera. At each surface it hits, the BSDF's
lobes (lobes.py; a Lambert lobe for a diffuse surface, one microfacet lobe of roughness 0 for a
smooth mirror, glass or refraction surface) are split into rough ones (alpha = roughness^2 above
ROUGH_ALPHA: Cycles' alpha_x alpha_y > 0.075^2; Lambert always) and specular ones. If more than a
quarter of the lobes' sample weight is rough, or there is no lobe, the path writes its features
and stops carrying them: albedo = weight x the rough lobes' albedos (lobes.lobe_albedo), normal =
the lobes' normals averaged by sample weight (world space here; Cycles writes camera space, which
RenderResult.denoising_normal applies). Otherwise the weight is multiplied by the specular lobes'
albedos and the path looks again at its next surface: through a mirror or clear glass the passes
show what is seen in it. A path that ends first (escapes, hits an emitter, is absorbed, the
depth limit, Russian roulette) writes no albedo or normal of a surface, as in Cycles.

Cycles also adds to the Denoising Albedo the light such a path finds on its way (a lamp, the
world or an emitter seen directly or through the mirror or glass): the features' weight x the
light as the image counts it (throughput x emission x its MIS weight; film/write.h,
film_write_emission_or_background_pass). Snell adds it the same way, with the MIS weight of
Cycles' strategies (light vertices left out): add_feature_light.
"""
from __future__ import annotations

from .jit import jit_inline
from .lobes import (ALPHA, DIST_GGX, KIND, LAMBERT, NORMAL, SAMPLE_WEIGHT, TRANSLUCENT,
                    lobe_albedo, new_lobe, setup_glass, setup_glossy, setup_refraction, vec_at)
from .material_kinds import DIFFUSE, GLASS, MIRROR
from .vec import add, madd, mul, vmul

ROUGH_ALPHA = 0.075       # Cycles: a closure is rough when alpha_x alpha_y > 0.075^2
ROUGH_SHARE = 0.25        # ... and a surface writes when its rough closures' share exceeds this


@jit_inline
def smooth_lobes(kind, lobes, tables, wi, n, entering, color, trans_color, ior):
    """The lobe Cycles sees at a diffuse or smooth (mirror, glass, refraction) hit, in `lobes`;
    returns 1 (their count)."""
    if kind == DIFFUSE:
        new_lobe(lobes[0], LAMBERT, n, color)
    elif kind == MIRROR:
        setup_glossy(lobes, tables, n, wi, color, 0.0, DIST_GGX)
    elif kind == GLASS:
        setup_glass(lobes, tables, n, wi, entering, color, trans_color, 0.0, DIST_GGX, ior)
    else:
        setup_refraction(lobes, n, entering, trans_color, 0.0, DIST_GGX, ior)
    return 1


@jit_inline
def surface_features(lobes, count, tables, wi):
    """(writes, rough lobes' albedo, normal averaged by sample weight, specular lobes' albedo)
    of a hit's lobes seen from wi: Cycles' rule (module docstring)."""
    normal = (0.0, 0.0, 0.0)
    rough_albedo = (0.0, 0.0, 0.0)
    specular_albedo = (0.0, 0.0, 0.0)
    total, rough = 0.0, 0.0
    for k in range(count):
        lobe = lobes[k]
        weight = lobe[SAMPLE_WEIGHT]
        normal = madd(normal, weight, vec_at(lobe, NORMAL))
        total += weight
        albedo = lobe_albedo(lobe, tables, wi)
        if lobe[KIND] == LAMBERT or lobe[KIND] == TRANSLUCENT or lobe[ALPHA] > ROUGH_ALPHA:
            rough_albedo = add(rough_albedo, albedo)
            rough += weight
        else:
            specular_albedo = add(specular_albedo, albedo)
    if total == 0.0 or rough > ROUGH_SHARE * total:
        if total != 0.0:
            normal = mul(normal, 1.0 / total)
        return True, rough_albedo, normal, specular_albedo
    return False, rough_albedo, normal, specular_albedo


@jit_inline
def add_feature_light(albedo, paths, i, beta, light, w):
    """Add light found by path i (throughput beta, emission `light`, MIS weight w) times its
    features' weight to row paths.path[i] of the albedo."""
    row = paths.path[i]
    for k in range(3):
        albedo[row, k] += paths.feature[i, k] * beta[k] * light[k] * w


@jit_inline
def record_features(lobes, count, tables, wi, paths, i, albedo, normal):
    """Apply a hit's lobes to path i's features: add them to row paths.path[i] of `albedo`
    (which may hold light it found on the way) and `normal` and stop, or carry the weight on
    through the specular lobes."""
    writes, rough_albedo, n, specular_albedo = surface_features(lobes, count, tables, wi)
    weight = (paths.feature[i, 0], paths.feature[i, 1], paths.feature[i, 2])
    if writes:
        row = paths.path[i]
        a = vmul(weight, rough_albedo)
        for k in range(3):
            albedo[row, k] += a[k]
            normal[row, k] = n[k]
        paths.feature_on[i] = 0
    else:
        w = vmul(weight, specular_albedo)
        for k in range(3):
            paths.feature[i, k] = w[k]
