"""A Material Output's Volume as the scene file's `absorption` (sigma_a per metre, RGB), with what
Snell does not render of it recorded in the material's Coverage.

Cycles sums the extinction of every volume closure (intern/cycles/kernel/svm/closure.h,
volume_extinction_setup); Snell renders its absorbing part (tracer/media.py):
- Volume Absorption: sigma_a = (1 - Color) x max(Density, 0) (svm_node_closure_volume,
  CLOSURE_VOLUME_ABSORPTION_ID: the closure weight is the colour, 1 - weight its absorption);
- Principled Volume: sigma_a = max(1 - Color, 0) x max(1 - sqrt(Absorption Color), 0)
  x max(Density, 0) (svm_node_principled_volume); its scattering Color x Density is not
  rendered (warned), nor its emission;
- Volume Scatter: all its extinction (Color x Density) is scattering: not rendered, warned;
- Volume Coefficients: sigma_a = its Absorption Coefficients (svm_node_volume_coefficients);
  its scatter and emission coefficients are warned;
- Add Shader adds, Mix Shader of a constant factor weights its sides by 1 - Fac and Fac (the
  mix weight multiplies each closure's density).
Inputs are read as constants: a linked input is warned and its unlinked value used (nodes.Inputs).
"""
from __future__ import annotations

import math

from .coverage import NODE_FAMILIES
from .mixes import mix_factor
from .nodes import Inputs, source_in

SCATTERING = "rendered without its scattering (homogeneous scattering is not rendered yet)"
EMISSION = "rendered without its emission (volume emission is not rendered)"


def convert_volume(out, coverage):
    """The absorption coefficient [r, g, b] of what the Material Output `out`'s Volume input
    carries (None: no volume, or one that absorbs nothing Snell renders); what is not rendered
    goes into coverage."""
    if "Volume" not in out.inputs:
        return None
    found = source_in(out.inputs["Volume"])
    if found.node is None:
        return None
    sigma = _sigma(found.node, found.groups, 1.0, coverage)
    if sigma is None:
        return None
    return [max(float(s), 0.0) for s in sigma]


def _sigma(node, groups, weight, coverage):
    """sigma_a of a volume node (weight: the product of the mix weights above it), or None."""
    kind = node.bl_idname
    if kind == "ShaderNodeAddShader":
        sides = [source_in(node.inputs[k], groups) for k in (0, 1)]
        return _add(*(_sigma(s.node, s.groups, weight, coverage) if s.node is not None else None
                      for s in sides))
    if kind == "ShaderNodeMixShader":
        fac = mix_factor(node, Inputs(node, coverage, groups))
        fac = min(max(fac, 0.0), 1.0)
        sides = [source_in(node.inputs[k], groups) for k in (1, 2)]
        return _add(*(_sigma(s.node, s.groups, weight * w, coverage)
                      if s.node is not None and w > 0.0 else None
                      for s, w in zip(sides, (1.0 - fac, fac))))
    inputs = Inputs(node, coverage, groups)
    if kind == "ShaderNodeVolumeAbsorption":
        color, density = inputs.color("Color"), max(inputs.value("Density"), 0.0)
        inputs.unread_links()
        coverage.evaluate(node, "absorption (1 - Color) x Density", input="Volume")
        return [weight * (1.0 - c) * density for c in color]
    if kind == "ShaderNodeVolumePrincipled":
        return _principled(node, inputs, weight, coverage)
    if kind == "ShaderNodeVolumeScatter":
        color, density = inputs.color("Color"), max(inputs.value("Density"), 0.0)
        if density > 0.0 and any(c > 0.0 for c in color):
            coverage.replace(node, "scatters light", SCATTERING)
        return None
    if kind == "ShaderNodeVolumeCoefficients":
        absorption = inputs.vector("Absorption Coefficients")
        scatter = inputs.vector("Scatter Coefficients")
        emission = inputs.vector("Emission Coefficients")
        inputs.unread_links()
        if any(c > 0.0 for c in scatter):
            coverage.replace(node, "scatters light", SCATTERING)
        if any(c > 0.0 for c in emission):
            coverage.replace(node, "emits light", EMISSION)
        coverage.evaluate(node, "absorption coefficients", input="Volume")
        return [weight * a for a in absorption]
    coverage.replace(node, f"({NODE_FAMILIES.get(kind, kind)}) on the Volume output is not a "
                           f"volume Snell renders", "rendered without it (the object's inside "
                           f"is clear)")
    return None


def _principled(node, inputs, weight, coverage):
    """sigma_a of a Principled Volume (svm_node_principled_volume's extinction minus its
    scattering)."""
    color = [max(c, 0.0) for c in inputs.color("Color")]
    density = max(inputs.value("Density"), 0.0)
    absorption_color = inputs.color("Absorption Color")
    emission = inputs.value("Emission Strength")
    blackbody = inputs.value("Blackbody Intensity")
    inputs.read.update(("Emission Color", "Blackbody Tint", "Temperature", "Anisotropy"))
    inputs.unread_links()
    if density > 0.0 and any(c > 0.0 for c in color):
        coverage.replace(node, f"scatters light (Color x Density "
                               f"{', '.join(f'{c * density:g}' for c in color)})", SCATTERING)
    if emission > 0.0 or blackbody > 0.0:
        coverage.replace(node, "emits light", EMISSION)
    coverage.evaluate(node, "absorption (1 - Color) x (1 - sqrt(Absorption Color)) x Density",
                      input="Volume")
    return [weight * max(1.0 - c, 0.0) * max(1.0 - math.sqrt(max(a, 0.0)), 0.0) * density
            for c, a in zip(color, absorption_color)]


def _add(a, b):
    """The sum of two coefficients, either None (nothing)."""
    if a is None:
        return b
    if b is None:
        return a
    return [x + y for x, y in zip(a, b)]
