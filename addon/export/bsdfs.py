"""The BSDF nodes Snell evaluates, each as a scene-file material (CONVERTERS: one converter per
node, taking the material's name, the node, its Inputs and the issues to add to).
"""
from __future__ import annotations

import math

from ...tracer import microfacet
from ...tracer import scene as scene_mod

# The nodes' microfacet distributions as the scene file names them. Ashikhmin-Shirley (Glossy
# BSDF only) has none: it is rendered as GGX, its closest, with a warning.
BLENDER_DISTRIBUTIONS = {"GGX": "ggx", "MULTI_GGX": "multi_ggx", "BECKMANN": "beckmann"}


def _distribution(node, issues):
    """The node's microfacet distribution as the scene file names it."""
    if node.distribution not in BLENDER_DISTRIBUTIONS:
        issues.append(f"node {node.name!r}: distribution {node.distribution} is not supported, "
                      f"rendered as GGX")
        return "ggx"
    return BLENDER_DISTRIBUTIONS[node.distribution]


def _diffuse(name, node, inp, issues):
    inp.unsupported("Roughness", 0.0, "Oren-Nayar diffuse is rendered as Lambert")
    inp.ignored_links("Normal")
    return {"name": name, "kind": "diffuse", "color": inp.color("Color", "color")}


def _glossy(name, node, inp, issues):
    inp.unsupported("Anisotropy", 0.0, "rendered isotropic")
    inp.ignored_links("Normal", "Tangent")
    # Roughness 0 stays glossy: the tracer renders it as the exact mirror.
    return {"name": name, "kind": "glossy", "color": inp.color("Color", "color"),
            "roughness": inp.field("Roughness", "roughness"),
            "distribution": _distribution(node, issues)}


def _glass(name, node, inp, issues):
    color = inp.color("Color", "color")
    result = {"name": name, "kind": "glass", "color": color, "transmission_color": list(color),
              "ior": inp.field("IOR", "ior"), "roughness": inp.field("Roughness", "roughness"),
              "distribution": _distribution(node, issues)}
    inp.unsupported("Thin Film Thickness", 0.0, "thin film interference is ignored")
    inp.ignored_links("Normal")
    return result


def _refraction(name, node, inp, issues):
    inp.ignored_links("Normal")
    return {"name": name, "kind": "refraction", "color": inp.color("Color", "color"),
            "ior": inp.field("IOR", "ior"), "roughness": inp.field("Roughness", "roughness"),
            "distribution": _distribution(node, issues)}


def _emission(name, node, inp, issues):
    return {"name": name, "kind": "emission", "color": inp.color("Color"),
            "strength": max(inp.value("Strength"), 0.0)}


# The Principled BSDF's inputs by the scene file's fields (docs/scene-format.md).
PRINCIPLED_INPUTS = {
    "color": "Base Color", "metallic": "Metallic", "roughness": "Roughness", "ior": "IOR",
    "specular_ior_level": "Specular IOR Level", "specular_tint": "Specular Tint",
    "transmission": "Transmission Weight", "coat_weight": "Coat Weight",
    "coat_roughness": "Coat Roughness", "coat_ior": "Coat IOR", "coat_tint": "Coat Tint",
    "emission_color": "Emission Color", "emission_strength": "Emission Strength",
}
# Its inputs Snell does not render: (input, the value at which it has no effect, what Snell
# renders instead). An input the running Blender lacks (Diffuse Roughness is recent) is skipped.
PRINCIPLED_UNSUPPORTED = (
    ("Sheen Weight", 0.0, "sheen is ignored"),
    ("Subsurface Weight", 0.0, "subsurface scattering is rendered as the diffuse base"),
    ("Thin Film Thickness", 0.0, "thin film interference is ignored"),
    ("Anisotropic", 0.0, "rendered isotropic"),
    ("Alpha", 1.0, "rendered opaque"),
    ("Diffuse Roughness", 0.0, "Oren-Nayar diffuse is rendered as Lambert"),
)
WHITE = [1.0, 1.0, 1.0]


def _principled(name, node, inp, issues):
    mat = {"name": name, "kind": "principled"}
    for field, socket in PRINCIPLED_INPUTS.items():
        mat[field] = inp.field(socket, field)
    mat["distribution"] = _distribution(node, issues)
    for socket, neutral, rendered in PRINCIPLED_UNSUPPORTED:
        inp.unsupported(socket, neutral, rendered)
    inp.ignored_links("Normal", "Coat Normal", "Tangent")
    # A textured one stays a Principled BSDF: its inputs vary over the surface.
    return (not inp.textures and _as_smooth_glass(mat)) or mat


def _as_smooth_glass(mat):
    """The glass material a principled one renders exactly as, or None.

    Full transmission with nothing on top, smooth (a roughness Cycles treats as a perfect
    dielectric), an untinted specular layer and without emission is exactly Cycles' smooth glass
    with its reflection untinted and its transmission tinted by the square root of the base
    colour clamped to [0, 1] (Cycles 5.0's Principled BSDF: the light passes the surface twice).
    Specular IOR Level does not enter: Cycles applies it to the dielectric specular layer alone,
    which full transmission leaves no weight. As glass it is a caster for the light tracer and
    for manifold next-event estimation, which end light paths on a Principled surface.
    """
    exact = (mat["transmission"] == 1.0 and mat["metallic"] == 0.0 and mat["coat_weight"] == 0.0
             and microfacet.is_almost_specular(mat["roughness"] ** 2)
             and mat["specular_tint"] == WHITE and not scene_mod.emits(mat))
    if not exact:
        return None
    tint = [math.sqrt(min(max(c, 0.0), 1.0)) for c in mat["color"]]
    return {"name": mat["name"], "kind": "glass", "color": list(WHITE),
            "transmission_color": tint, "ior": mat["ior"]}


CONVERTERS = {
    "ShaderNodeBsdfDiffuse": _diffuse,
    "ShaderNodeBsdfGlossy": _glossy,
    "ShaderNodeBsdfAnisotropic": _glossy,    # the Glossy BSDF's identifier since Blender 4.0
    "ShaderNodeBsdfGlass": _glass,
    "ShaderNodeBsdfRefraction": _refraction,
    "ShaderNodeEmission": _emission,
    "ShaderNodeBsdfPrincipled": _principled,
}
