"""The shader nodes of a program: the BSDFs, Emission, Transparent, Translucent, Holdout, and
the Mix and Add Shaders that weigh them (Cycles' kernel/svm/closure.h; compile_surface walks
them from the Material Output's Surface), and the bump displacement that comes before them
(compile_displacement)."""
from __future__ import annotations

from ....tracer.shader import bump as tracer_bump, closures, inputs as tracer_inputs
from ..bsdfs import BLENDER_DISTRIBUTIONS, PRINCIPLED_INPUTS, PRINCIPLED_UNSUPPORTED
from ..coverage import node_text
from ..nodes import source_in
from .normal_nodes import three_heights

DISTRIBUTIONS = ("ggx", "multi_ggx", "beckmann")     # tracer.scene.DISTRIBUTIONS
GREY = (0.8, 0.8, 0.8)
# A Principled BSDF's scene fields in the order of its block (closures.P_*): lobes.py's
# P_FIELDS order after the base colour.
PRINCIPLED_BLOCK_FIELDS = (
    ("color", 3), ("metallic", 1), ("roughness", 1), ("ior", 1), ("specular_ior_level", 1),
    ("transmission", 1), ("coat_weight", 1), ("coat_roughness", 1), ("coat_ior", 1),
    ("specular_tint", 3), ("coat_tint", 3), ("alpha", 1), ("emission_color", 3),
    ("emission_strength", 1))
SOCKETS = {**PRINCIPLED_INPUTS, "alpha": "Alpha"}


def _distribution(c, node, choices=DISTRIBUTIONS):
    """A node's distribution as a DISTRIBUTIONS index (Ashikhmin-Shirley: GGX, warned)."""
    name = BLENDER_DISTRIBUTIONS.get(node.distribution)
    if name is None or name not in choices:
        c.warn(node, f"has distribution {node.distribution}, which Snell does not render",
               "using GGX")
        name = "ggx"
    return DISTRIBUTIONS.index(name)


def _normal(c, node, name="Normal"):
    """The register of a closure's Normal input, or None (the hit's normal) when unlinked."""
    if node.inputs.get(name) is None or not c.is_linked(node, name):
        return None
    return c.input(node, name, "vector")


def _unsupported(c, node, name, neutral, rendered):
    """Warn for an input Snell does not render unless it is unlinked at its neutral value."""
    if node.inputs.get(name) is None:
        return
    if c.is_linked(node, name):
        c.warn(node, "is linked, which Snell does not render", rendered, input=name)
    elif c.value(node, name) != neutral:
        c.warn(node, f"is {c.value(node, name):g}, which Snell does not render", rendered,
               input=name)


def _ignored(c, node, *names):
    for name in names:
        if node.inputs.get(name) is not None and c.is_linked(node, name):
            c.warn(node, "is linked, which Snell does not render", "ignored", input=name)


def _principled(c, node, weight):
    values = []
    for field, width in PRINCIPLED_BLOCK_FIELDS:
        value = c.value(node, SOCKETS[field])
        values.extend(value if width == 3 else [value])
    block = c.constant_block(values)
    at = 0
    for field, width in PRINCIPLED_BLOCK_FIELDS:
        socket = SOCKETS[field]
        if c.is_linked(node, socket):
            reg = c.input(node, socket, "color" if width == 3 else "float")
            c.emit(tracer_inputs.COPY_VECTOR if width == 3 else tracer_inputs.COPY_FLOAT,
                   block[at], reg)
        at += width
    for socket, neutral, rendered in PRINCIPLED_UNSUPPORTED:
        if socket != "Alpha":
            _unsupported(c, node, socket, neutral, rendered)
    _ignored(c, node, "Coat Normal", "Tangent")
    c.emit(closures.PRINCIPLED, weight, block[0],
           _distribution(c, node, ("ggx", "multi_ggx")), _normal(c, node))
    if c.is_linked(node, "Transmission Weight") or c.value(node, "Transmission Weight") > 0:
        c.refracts = True
    # Cycles scales the emission by Alpha too (principled_bsdf_emission).
    alpha = min(max(c.value(node, "Alpha"), 0.0), 1.0)
    emission = [c.value(node, "Emission Color")[k] * c.value(node, "Emission Strength") * alpha
                for k in range(3)]
    return emission, (c.is_linked(node, "Emission Color")
                      or c.is_linked(node, "Emission Strength")
                      or (c.is_linked(node, "Alpha") and any(emission)))


def _bsdf(c, node, weight):
    """Compile one closure node; returns (its constant emission x 1, whether it varies)."""
    kind = node.bl_idname
    if kind == "ShaderNodeBsdfDiffuse":
        _unsupported(c, node, "Roughness", 0.0, "Oren-Nayar diffuse is rendered as Lambert")
        c.emit(closures.DIFFUSE, weight, c.input(node, "Color", "color"), _normal(c, node))
    elif kind in ("ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic"):
        _unsupported(c, node, "Anisotropy", 0.0, "rendered isotropic")
        _ignored(c, node, "Tangent")
        c.emit(closures.GLOSSY, weight, c.input(node, "Color", "color"),
               c.input(node, "Roughness", "float"), _distribution(c, node), _normal(c, node))
    elif kind in ("ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction"):
        if kind == "ShaderNodeBsdfGlass":
            _unsupported(c, node, "Thin Film Thickness", 0.0, "thin film interference is "
                                                               "ignored")
        choices = DISTRIBUTIONS if kind == "ShaderNodeBsdfGlass" else ("ggx", "beckmann")
        c.emit(closures.GLASS if kind == "ShaderNodeBsdfGlass" else closures.REFRACTION, weight,
               c.input(node, "Color", "color"), c.input(node, "Roughness", "float"),
               c.input(node, "IOR", "float"), _distribution(c, node, choices), _normal(c, node))
        c.refracts = True
    elif kind == "ShaderNodeBsdfPrincipled":
        return _principled(c, node, weight)
    elif kind == "ShaderNodeEmission":
        color, strength = c.input(node, "Color", "color"), c.input(node, "Strength", "float")
        c.emit(closures.EMISSION, weight, color, strength)
        if color.constant is None or strength.constant is None:
            return (0.0, 0.0, 0.0), True
        return [x * strength.constant[0] for x in color.constant], False
    elif kind == "ShaderNodeBsdfTransparent":
        c.emit(closures.TRANSPARENT_BSDF, weight, c.input(node, "Color", "color"))
    elif kind == "ShaderNodeBsdfTranslucent":
        c.emit(closures.TRANSLUCENT_BSDF, weight, c.input(node, "Color", "color"),
               _normal(c, node))
    elif kind == "ShaderNodeHoldout":
        c.emit(closures.HOLDOUT, weight)
    else:
        c.warn(node, f"is {node_text(node)}, which Snell does not render",
               "rendered as grey 0.8 diffuse")
        c.emit(closures.DIFFUSE, weight, c.constant(GREY), None)
    return (0.0, 0.0, 0.0), False


def compile_surface(c, socket, weight=None, groups=()):
    """Compile the closures feeding a shader socket with mix weight `weight` (a Reg, or None:
    1), adding constant emission to c.emission."""
    found = source_in(socket, groups)
    node = found.node
    if node is None:
        return                      # no closure: nothing (black), as in Cycles
    if node.bl_idname == "ShaderNodeGroup":
        # source_in stops at a group node only when its tree has no Group Output.
        c.warn(node, "is a node group with no Group Output", "no closure (black), as in Cycles")
        return
    saved, c.groups = c.groups, found.groups
    try:
        if node.bl_idname == "ShaderNodeAddShader":
            compile_surface(c, node.inputs[0], weight, found.groups)
            compile_surface(c, node.inputs[1], weight, found.groups)
        elif node.bl_idname == "ShaderNodeMixShader":
            fac = c.input(node, "Fac", "float")
            w = 1.0 if weight is None else weight.constant[0] if weight.constant else None
            if fac.constant is not None and w is not None:
                f = min(max(fac.constant[0], 0.0), 1.0)
                sides = (w * (1.0 - f), w * f)
                for k, side in enumerate(sides, start=1):
                    if side != 0.0:
                        compile_surface(c, node.inputs[k], c.constant(side), found.groups)
            else:
                first, second = c.alloc("float"), c.alloc("float")
                c.emit(closures.MIX_CLOSURE, first, second, weight, fac)
                compile_surface(c, node.inputs[1], first, found.groups)
                compile_surface(c, node.inputs[2], second, found.groups)
        else:
            emission, varies = _bsdf(c, node, weight)
            c.unread_links(node)
            if varies or (any(emission) and weight is not None and weight.constant is None):
                c.emission_varies = True
            elif any(emission):
                w = 1.0 if weight is None else weight.constant[0]
                c.emission = [e + w * x for e, x in zip(c.emission, emission)]
            c.coverage.evaluate(node, "compiled into the material's shader program")
    finally:
        c.groups = saved


# Cycles' displacement methods that bump (shader.cpp: all but DISPLACE_TRUE).
BUMP_METHODS = ("BUMP", "BOTH")
# The Filter Width of the Bump node bump_from_displacement makes (BumpNode's default).
DISPLACEMENT_FILTER_WIDTH = 0.1


def compile_displacement(c, output, method):
    """A Material Output's Displacement as Cycles' bump_from_displacement (scene/
    shader_graph.cpp) makes it for displacement method BUMP or BOTH: the displacement's
    height along the shading normal at the hit and at the hit moved by each differential,
    through a Bump node of Distance 1, made the hit's shading normal before the surface's
    closures compile (SET_NORMAL): every closure, Geometry Normal and Bump after it reads it.
    Its nodes compile in memo scopes of their own, as Cycles compiles its bump shader apart
    from the surface."""
    if method not in BUMP_METHODS or "Displacement" not in output.inputs \
            or not c.is_linked(output, "Displacement"):
        return

    def height():
        reg = c.alloc("float")
        c.emit(tracer_bump.HEIGHT, reg, c.input(output, "Displacement", "vector"))
        return reg

    width = c.constant(DISPLACEMENT_FILTER_WIDTH)
    with c.scope("displacement"):
        heights = three_heights(c, width, "displacement", height)
    normal = c.alloc("vector")
    c.emit(tracer_bump.BUMP, normal, None, heights, c.constant(1.0), c.constant(1.0), 0, width)
    c.emit(tracer_bump.SET_NORMAL, normal)
    c.bump_displacement = True
