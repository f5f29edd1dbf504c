"""Where light paths end: the surfaces with a Lambert lobe, and what of their BSDF the light
tracer carries there.

The hybrid splits path space between the path tracer and the light tracer (light_tracer.py) by
the lobe the camera path samples at its first vertex: a camera path whose first vertex is on a
receiving surface (Materials.receives: plain diffuse, a Principled BSDF, a shader program with a
Diffuse or Principled closure) and whose sample there came from a Lambert lobe is the light
tracer's if every vertex after it is specular (scatter.py sets FIRST_DIFFUSE by lambert_sampled);
the path tracer renders the paths whose sample came from any other lobe. A direction w is
sampled by bsdf_sample with density sum_k q_k p_k(w) / Q (q_k the lobes' sampling weights), so
the path tracer leaves the light tracer, on average, the share

    sum over Lambert lobes l of q_l p_l(w) / sum_k q_k p_k(w)

of its estimate f(w) |cos|: the light tracer's connection at such a vertex carries f |cos| times
that share (surface_response), and the two add up to the whole BSDF exactly. A plain diffuse
surface has one Lambert lobe: share 1, its albedo / pi, as before. Light from a delta lamp
through glass no camera path finds at all: there the light tracer carries the whole BSDF.
"""
from __future__ import annotations

from . import specular
from .jit import jit, jit_inline
from .lobes import (DIFFUSE_EVENT, KIND, LAMBERT, P_METALLIC, P_ROUGHNESS, SAMPLE_WEIGHT,
                    SHADER_PRINCIPLED, WEIGHT, lobe_eval, setup_shader, vec_at)
from .material_kinds import LAYERED
from .shader.inputs import DROP_SHIFT, LP_CAMERA
from .shader.program import run
from .textures import METALLIC_SLOT, ROUGHNESS_SLOT, material_number
from .vec import add, dot, mul, vmul

ALL_LOBE_EVENTS = 7       # lobes' DIFFUSE, REFLECT and TRANSMIT events: bsdf_eval's mask


@jit
def textured_params(mats, mat, tri, b1, b2, params):
    """(roughness, Principled parameters) of a textured layered material at a hit: its
    roughness texture's value, and for a Principled BSDF its parameters copied into the scratch
    row `params` with the roughness and metallic textures' values."""
    roughness = material_number(mats, mat, ROUGHNESS_SLOT, tri, b1, b2, mats.roughness[mat])
    if mats.shader[mat] != SHADER_PRINCIPLED:
        return roughness, mats.principled[mat]
    for k in range(params.shape[0]):
        params[k] = mats.principled[mat, k]
    params[P_ROUGHNESS] = material_number(mats, mat, ROUGHNESS_SLOT, tri, b1, b2,
                                          mats.principled[mat, P_ROUGHNESS])
    params[P_METALLIC] = material_number(mats, mat, METALLIC_SLOT, tri, b1, b2,
                                         mats.principled[mat, P_METALLIC])
    return roughness, params


@jit_inline
def layered_lobes(mats, tables, has_normals, surface, color, trans_color, ng_f, ns_f, view,
                  entering, params, lobes, drop):
    """The lobes of a hit on a LAYERED material (surface: material, triangle, barycentrics;
    normals facing view; drop: the caustics it drops, path_limits.dropped_at); returns their
    number."""
    mat, tri, b1, b2 = surface
    n = specular.valid_reflection_normal(ng_f, view, ns_f) if has_normals else ns_f
    roughness, shader_params = mats.roughness[mat], mats.principled[mat]
    if mats.textured[mat]:
        roughness, shader_params = textured_params(mats, mat, tri, b1, b2, params)
    return setup_shader(lobes, tables, mats.shader[mat], color, trans_color, mats.ior[mat],
                        roughness, mats.distribution[mat], shader_params, n, ns_f, view,
                        entering, drop)


@jit_inline
def lambert_sampled(event, wo, ng_f):
    """Whether bsdf_sample's direction wo (its event) came from a Lambert lobe: a diffuse event
    above the surface (a Translucent lobe's valid samples are all below it)."""
    return event == DIFFUSE_EVENT and dot(wo, ng_f) > 0.0


@jit
def lambert_share(lobes, count, view, w):
    """The hit's BSDF towards w (f |cos| RGB, all lobes) and the share of it that bsdf_sample
    draws from Lambert lobes (0 when no lobe draws w)."""
    f = (0.0, 0.0, 0.0)
    lambert, pdf = 0.0, 0.0
    for i in range(count):
        value, p = lobe_eval(lobes[i], view, w)
        if p > 0.0:
            f = add(f, vmul(value, vec_at(lobes[i], WEIGHT)))
            pdf += p * lobes[i, SAMPLE_WEIGHT]
            if lobes[i, KIND] == LAMBERT:
                lambert += p * lobes[i, SAMPLE_WEIGHT]
    return f, (lambert / pdf if pdf > 0.0 else 0.0)


@jit_inline
def hit_lobes(mats, tables, has_normals, kind, surface, colors, hit, view, ray, scratch):
    """The lobes of a hit on a LAYERED or PROGRAM surface, in scratch's lobes; returns their
    number. surface: (material, triangle, barycentrics); colors: its colour and transmission
    colour there; hit: (point, geometric and shading normals facing view, entering); ray: the
    ray that met it (its Light Path flags, shader.inputs.ray_flags; the caustics it drops,
    path_limits.dropped_at; its bounce; its length); scratch: (lobes, program registers,
    Principled parameters)."""
    p, ng_f, ns_f, entering = hit
    flags, drop, bounce, length = ray
    lobes, regs, params = scratch
    mat, tri, b1, b2 = surface
    if kind == LAYERED:
        return layered_lobes(mats, tables, has_normals, surface, colors[0], colors[1], ng_f,
                             ns_f, view, entering, params, lobes, drop)
    return run(mats, mat, regs, (p, ng_f, ns_f, view, entering, tri, b1, b2,
                                 flags | drop << DROP_SHIFT, bounce, length),
               lobes, tables, has_normals)


@jit_inline
def surface_response(mats, tables, has_normals, kind, surface, colors, hit, view, w, whole,
                     scratch):
    """f |cos(ns, w)| (RGB) of a LAYERED or PROGRAM surface that receives light paths, seen
    from view for light arriving from w, times the share the light tracer carries (the whole
    BSDF if `whole`: a delta lamp's). surface, colors and scratch as hit_lobes'; hit: (point,
    geometric and shading normals facing view, entering, distance to the viewer). The hit is
    met as a camera ray meets it, at bounce 0 (the Light Path node's inputs)."""
    p, ng_f, ns_f, entering, length = hit
    count = hit_lobes(mats, tables, has_normals, kind, surface, colors,
                      (p, ng_f, ns_f, entering), view, (1 << LP_CAMERA, 0, 0, length), scratch)
    f, share = lambert_share(scratch[0], count, view, w)
    return f if whole else mul(f, share)
