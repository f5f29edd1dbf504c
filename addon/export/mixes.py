"""The Mix Shader folded into one material where that is exact: of a constant factor, or glass
built from nodes.

Cycles weights the two closures by 1 - Fac and Fac (Fac clamped to [0, 1]). Snell has no mixed
closures yet, so a mix renders only when it is one material already: Fac 0 or 1 picks one side,
two equal surfaces are that one, and two surfaces of one kind whose BSDF is linear in its colour
(everything but the colour equal, no textures) are that kind with the colours mixed. One mix of
a factor that varies is exact too: glass built from nodes, a smooth Refraction BSDF and a smooth
Glossy BSDF weighted by a Fresnel node of the refraction's IOR (fresnel_ior, fold_fresnel). Any
other mix is reported by the caller.
"""
from __future__ import annotations

from ...tracer import microfacet
from .coverage import node_text
from .nodes import Inputs, is_constant, source_in

# Kinds whose BSDF is its colour times a BSDF of the other fields, so that a mix of two with the
# same other fields is one with the colours mixed. Multiscatter GGX is left out: its energy
# compensation depends on the colour. An unconnected shader input is no closure: black diffuse.
LINEAR_IN_COLOR = ("diffuse", "glossy", "refraction", "glass")
COLOR_FIELDS = ("name", "color", "transmission_color")


class NotFolded(Exception):
    """A mix Snell cannot render as one material: the text says why."""


def mix_factor(node, inputs):
    """The Mix Shader's factor as Cycles uses it: clamped to [0, 1]."""
    return min(max(inputs.value("Fac"), 0.0), 1.0)


def fresnel_ior(node, groups, coverage):
    """The IOR of the Fresnel node that the Mix Shader's Fac is (a constant IOR, no Normal), or
    None."""
    found = source_in(node.inputs["Fac"], groups)
    fresnel = found.node
    if fresnel is None or fresnel.bl_idname != "ShaderNodeFresnel":
        return None
    if (not is_constant(fresnel.inputs["IOR"], found.groups)
            or source_in(fresnel.inputs["Normal"], found.groups).node is not None):
        return None
    ior = max(Inputs(fresnel, coverage, found.groups).value("IOR"), 1e-5)
    coverage.evaluate(fresnel, f"Fresnel factor of IOR {ior:g}")
    return ior


def fold_fresnel(node, ior, first, second):
    """The glass a mix weighted by a Fresnel node of index `ior` is, or NotFolded.

    Cycles' smooth Refraction and Glossy BSDFs transmit and reflect everything (no Fresnel of
    their own), so weighting them by 1 - F and F, F the Fresnel node's dielectric reflectance of
    the refraction's own IOR (inverted on back faces, as the glass inverts it), is the Glass
    BSDF with its reflection tinted by the Glossy colour and its transmission by the
    Refraction's: the exact glass, which the light tracer and manifold next-event estimation
    follow (light paths end on a shader program).
    """
    smooth = all(microfacet.is_almost_specular(side.get("roughness", 0.0) ** 2)
                 for side in (first, second))
    exact = (first["kind"] == "refraction" and second["kind"] == "glossy" and smooth
             and first["ior"] == ior and "_textures" not in first and "_textures" not in second)
    if not exact:
        raise NotFolded(f"{node_text(node)} of {first['kind']} and {second['kind']} weighted by "
                        f"a Fresnel node, not a smooth Refraction and Glossy BSDF of its IOR")
    return {"name": first["name"], "kind": "glass", "color": list(second["color"]),
            "transmission_color": list(first["color"]), "ior": ior}


def fold(node, fac, first, second):
    """The one material the mix of two converted materials is, or NotFolded."""
    if fac == 0.0:
        return first
    if fac == 1.0:
        return second
    if first["kind"] != second["kind"]:
        raise NotFolded(f"{node_text(node)} of {first['kind']} and {second['kind']}")
    kind = first["kind"]
    if "_textures" in first or "_textures" in second:
        raise NotFolded(f"{node_text(node)} of textured surfaces")
    if kind == "emission":
        return {**first, "strength": 1.0,
                "color": _lerp([c * first["strength"] for c in first["color"]],
                               [c * second["strength"] for c in second["color"]], fac)}
    if first == second:
        return first
    if kind not in LINEAR_IN_COLOR or first.get("distribution") == "multi_ggx":
        raise NotFolded(f"{node_text(node)} of two different {kind} surfaces, not linear in "
                        f"their colour")
    rest = {k: v for k, v in first.items() if k not in COLOR_FIELDS}
    if rest != {k: v for k, v in second.items() if k not in COLOR_FIELDS}:
        raise NotFolded(f"{node_text(node)} of two {kind} surfaces that differ beyond their "
                        f"colour")
    mixed = {**first, "color": _lerp(first["color"], second["color"], fac)}
    if "transmission_color" in first:
        mixed["transmission_color"] = _lerp(first["transmission_color"],
                                            second["transmission_color"], fac)
    return mixed


def _lerp(a, b, t):
    return [(1.0 - t) * x + t * y for x, y in zip(a, b)]
