"""The light passes as Cycles 5.0 defines them: Emission, Environment, Diffuse, Glossy and
Transmission Direct, Indirect and Color.

Cycles (kernel/film/light_passes.h, film_write_emission_or_background_pass and
film_write_direct_light; kernel/integrator/shade_surface.h; scene/pass.cpp) splits each piece of
light a camera path adds to the image by where the path was:

- light found before the path's first bounce (seen directly, or through transparent surfaces,
  which are no bounce) goes to Emission, or to Environment for the world;
- after it, the light goes to Diffuse, Glossy and Transmission by the path's pass weights, set at
  its first bounce: the diffuse and the glossy share of the BSDF evaluation (per colour channel,
  safe_divide(eval.diffuse, eval.sum) of kernel/closure/bsdf.h's bsdf_eval_pass_*_weight) of
  the direction the path took, transmission what is left (1 - diffuse - glossy). A closure is
  diffuse (Lambert, Translucent), glossy (microfacet reflection) or, for glass, glossy on the
  side of its normal and transmission on the other; refraction is transmission;
- it is Direct when found by the ray of the first bounce (bounce 1) or by a light sample of the
  first hit (a shadow ray of bounce 0, weighted by the BSDF at the light's direction), else
  Indirect.

The Color passes (kernel/film/data_passes.h) add, at every hit before the first bounce, the
throughput times the albedo of the hit's diffuse, glossy and transmitting closures
(surface_shader_diffuse/glossy/transmission: lobes.lobe_albedo_parts). When the image is read,
each Direct and Indirect pass is divided by its Color pass (scene/pass.cpp's divide_type, with
util/color.h's safe_divide_even_color), so that Combined = (Direct + Indirect) x Color summed
over the three kinds, plus Emission and Environment.

A path's pass sums are a row of COLUMNS numbers (three per pass, in PASSES' order); the stages add
to them only when a render asks for the passes (their array has rows).

Snell's own strategies go where Cycles would put the same light: a connection to a light vertex
(light_vertices.py) lights the camera vertex through at least one more bounce (Indirect), and the
light tracer's splats (light_tracer.py: lamp, mirrors or glass, a diffuse surface the camera
sees) are Diffuse Indirect light of that Lambert surface (RenderResult.light_passes adds them).
"""
from __future__ import annotations

import numpy as np

from .jit import jit
from .lobes import (KIND, LAMBERT, MICROFACET, NORMAL, REFLECTS, TRANSLUCENT, TRANSMITS, WEIGHT,
                    lobe_albedo_parts, lobe_eval, vec_at)
from .vec import add, dot, vmul

# Blender's names of the passes (View Layer > Passes > Light), in the order of a path's row.
PASSES = ("Emission", "Environment", "Diffuse Direct", "Diffuse Indirect", "Glossy Direct",
          "Glossy Indirect", "Transmission Direct", "Transmission Indirect", "Diffuse Color",
          "Glossy Color", "Transmission Color")
(EMISSION, ENVIRONMENT, DIFFUSE_DIRECT, DIFFUSE_INDIRECT, GLOSSY_DIRECT, GLOSSY_INDIRECT,
 TRANSMISSION_DIRECT, TRANSMISSION_INDIRECT, DIFFUSE_COLOR, GLOSSY_COLOR,
 TRANSMISSION_COLOR) = range(len(PASSES))
COLUMNS = 3 * len(PASSES)
# Each Direct and Indirect pass and the Color pass it is divided by when read (pass.cpp).
DIVIDED_BY = {"Diffuse Direct": "Diffuse Color", "Diffuse Indirect": "Diffuse Color",
              "Glossy Direct": "Glossy Color", "Glossy Indirect": "Glossy Color",
              "Transmission Direct": "Transmission Color",
              "Transmission Indirect": "Transmission Color"}
# Closure classes of Cycles' pass weights and colours (svm/types.h, CLOSURE_IS_BSDF_*).
DIFFUSE_CLOSURE, GLOSSY_CLOSURE, REFRACTION_CLOSURE, GLASS_CLOSURE, OTHER_CLOSURE = range(5)
ONE = (1.0, 1.0, 1.0)
ZERO = (0.0, 0.0, 0.0)


@jit
def closure_class(lobe):
    """Which of Cycles' closure classes a lobe is: Lambert and Translucent are diffuse, microfacet
    reflection glossy, microfacet refraction alone refraction, both glass; transparency none."""
    kind = lobe[KIND]
    if kind == LAMBERT or kind == TRANSLUCENT:
        return DIFFUSE_CLOSURE
    if kind != MICROFACET:
        return OTHER_CLOSURE
    if lobe[REFLECTS] > 0.0 and lobe[TRANSMITS] > 0.0:
        return GLASS_CLOSURE
    return GLOSSY_CLOSURE if lobe[REFLECTS] > 0.0 else REFRACTION_CLOSURE


@jit
def safe_divide3(a, b):
    """a / b per channel, 0 where b is 0 (Cycles' safe_divide)."""
    return (a[0] / b[0] if b[0] != 0.0 else 0.0, a[1] / b[1] if b[1] != 0.0 else 0.0,
            a[2] / b[2] if b[2] != 0.0 else 0.0)


@jit
def pass_weights(lobes, count, wi, wo):
    """(diffuse, glossy) pass weights of a hit's lobes seen from wi for light along wo: each
    class's share of the BSDF evaluation, as Cycles' bsdf_eval_init / bsdf_eval_accum split it
    (a glass lobe is glossy on its normal's side) and bsdf_eval_pass_*_weight divide it."""
    diffuse, glossy, total = ZERO, ZERO, ZERO
    for i in range(count):
        lobe = lobes[i]
        value, p = lobe_eval(lobe, wi, wo)
        if not p > 0.0:
            continue
        f = vmul(value, vec_at(lobe, WEIGHT))
        total = add(total, f)
        kind = closure_class(lobe)
        if kind == DIFFUSE_CLOSURE:
            diffuse = add(diffuse, f)
        elif kind == GLOSSY_CLOSURE or (kind == GLASS_CLOSURE
                                        and dot(vec_at(lobe, NORMAL), wo) > 0.0):
            glossy = add(glossy, f)
    return safe_divide3(diffuse, total), safe_divide3(glossy, total)


@jit
def add3(light, row, slot, value):
    """light[row, slot's three columns] += value."""
    for k in range(3):
        light[row, 3 * slot + k] += value[k]


@jit
def add_scattered(light, row, direct, diffuse_w, glossy_w, contribution):
    """Light that reached the camera through the path's first bounce: split by the pass weights
    into the Diffuse, Glossy and Transmission passes (Direct or Indirect)."""
    offset = 0 if direct else 1
    add3(light, row, DIFFUSE_DIRECT + offset, vmul(diffuse_w, contribution))
    add3(light, row, GLOSSY_DIRECT + offset, vmul(glossy_w, contribution))
    rest = (1.0 - diffuse_w[0] - glossy_w[0], 1.0 - diffuse_w[1] - glossy_w[1],
            1.0 - diffuse_w[2] - glossy_w[2])
    add3(light, row, TRANSMISSION_DIRECT + offset, vmul(rest, contribution))


@jit
def add_found(light, paths, i, beta, emission, w, background):
    """Light path i finds (throughput beta, emission, MIS weight w), as Cycles'
    film_write_emission_or_background_pass: before the first bounce into Emission (Environment
    for the world: `background`), then by the path's pass weights, Direct at bounce 1."""
    contribution = (beta[0] * emission[0] * w, beta[1] * emission[1] * w,
                    beta[2] * emission[2] * w)
    row, bounce = paths.path[i], paths.bounce[i]
    if bounce == 0:
        add3(light, row, ENVIRONMENT if background else EMISSION, contribution)
        return
    add_scattered(light, row, bounce == 1, vec_at(paths.pass_diffuse[i], 0),
                  vec_at(paths.pass_glossy[i], 0), contribution)


@jit
def add_colors(light, row, lobes, count, tables, wi, beta):
    """A hit before the first bounce adds its closures' albedos (lobe_albedo_parts) times the
    throughput beta to the Color passes (Cycles' surface_shader_diffuse, _glossy and
    _transmission: a glass lobe's reflection is glossy, its transmission transmission)."""
    for i in range(count):
        lobe = lobes[i]
        kind = closure_class(lobe)
        if kind == OTHER_CLOSURE:
            continue
        reflected, transmitted = lobe_albedo_parts(lobe, tables, wi)
        if kind == DIFFUSE_CLOSURE:
            add3(light, row, DIFFUSE_COLOR, vmul(beta, reflected))
            continue
        if kind != REFRACTION_CLOSURE:
            add3(light, row, GLOSSY_COLOR, vmul(beta, reflected))
        if kind != GLOSSY_CLOSURE:
            add3(light, row, TRANSMISSION_COLOR, vmul(beta, transmitted))


@jit
def shadow_weights(shadows, first, end, bounce, diffuse_w, glossy_w, lobes, count, wi,
                   diffuse):
    """The pass weights of shadow rays first .. end of a hit: at the first hit (bounce 0) the
    BSDF's at each ray's direction (a Lambert surface's, `diffuse`, all diffuse), else the
    path's (diffuse_w, glossy_w); a light sample of the first hit is Direct, a connection to a
    light vertex (pass_direct 0 as queued) never is."""
    for j in range(first, end):
        if bounce == 0:
            if diffuse:
                dw, gw = ONE, ZERO
            else:
                wo = (np.float64(shadows.d32[j, 0]), np.float64(shadows.d32[j, 1]),
                      np.float64(shadows.d32[j, 2]))
                dw, gw = pass_weights(lobes, count, wi, wo)
        else:
            dw, gw = diffuse_w, glossy_w
            shadows.pass_direct[j] = 0
        for k in range(3):
            shadows.pass_diffuse[j, k] = dw[k]
            shadows.pass_glossy[j, k] = gw[k]


@jit
def add_shadow(light, shadows, j):
    """Shadow ray j arrived: its light into the Diffuse, Glossy and Transmission passes."""
    add_scattered(light, shadows.path[j], shadows.pass_direct[j] != 0,
                  vec_at(shadows.pass_diffuse[j], 0), vec_at(shadows.pass_glossy[j], 0),
                  vec_at(shadows.contrib[j], 0))


@jit
def film_rows(rows, first, n, start, in_pass, pixels, total):
    """Add columns first.. of the chunk's n paths' rows to their pixels' sums (total's column c -
    first); a path whose row holds a NaN or Inf in any column adds nothing, as film leaves out a
    path whose Combined does. Returns how many did."""
    bad = 0
    for i in range(n):
        finite = True
        for c in range(rows.shape[1]):
            if not np.isfinite(rows[i, c]):
                finite = False
                break
        if not finite:
            bad += 1
            continue
        pixel = (start + i) // in_pass
        if pixels.shape[0] > 0:
            pixel = pixels[pixel]
        for c in range(first, rows.shape[1]):
            total[pixel, c - first] += rows[i, c]
    return bad


@jit
def film_light_passes(light, n, start, in_pass, pixels, total):
    """Add the chunk's n paths' pass rows to their pixels' sums (rows of (pixels, COLUMNS)); a
    path whose row holds a NaN or Inf adds nothing. Returns how many did."""
    return film_rows(light, 0, n, start, in_pass, pixels, total)


def safe_divide_even_color(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a / b per channel of (..., 3) arrays as Cycles reads a divided pass (util/color.h's
    safe_divide_even_color): where a channel of b is 0, the mean of the other channels'
    quotients (or the one other's), 0 where all of b is 0."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    zero = b == 0.0
    q = np.where(zero, 0.0, a / np.where(zero, 1.0, b))
    good = (~zero).sum(-1, keepdims=True)
    mean_good = np.where(good > 0, (q * ~zero).sum(-1, keepdims=True) / np.maximum(good, 1), 0.0)
    return np.where(zero, mean_good, q)


def read_passes(mean: np.ndarray, light_image: np.ndarray | None, exposure: float) -> dict:
    """{Blender's pass name: float64 (H, W, 3)} from the pixels' means of the pass rows (H, W,
    COLUMNS), the light tracer's image (its Diffuse Indirect share; None without it) and the
    film's exposure, as Cycles reads them: Direct and Indirect divided by their Color; exposure
    on all but the Color passes."""
    raw = {name: mean[..., 3 * k:3 * k + 3] for k, name in enumerate(PASSES)}
    if light_image is not None:
        raw["Diffuse Indirect"] = raw["Diffuse Indirect"] + light_image
    out = {}
    for name, values in raw.items():
        if name in DIVIDED_BY:
            values = safe_divide_even_color(values, raw[DIVIDED_BY[name]])
        out[name] = values if name.endswith("Color") else values * exposure
    return out
