"""Blender materials as the scene file's material dicts (convert_material), with their coverage.

The active Material Output decides what renders: its Surface's BSDF node is converted by its
entry in bsdfs.CONVERTERS, with Inputs (nodes.py) reading the node's input values; an Image
Texture on a texturable input is handed on in the dict's "_textures" (textures.py converts it).
A tree these fixed kinds cannot render (mixes of other factors, Transparent, Light Path, ...)
is compiled into a shader program instead (shader/: the scene file's "program" material).
Its Volume becomes the dict's "absorption" (volumes.py). Everything else the output reaches (a
displacement, a shader Snell lacks, a linked input it does not read) is recorded, with what
Snell renders instead, in the material's Coverage
(coverage.py): its replaced entries are the exporter's warnings, and `snell info` lists both.
"""
from __future__ import annotations

from ...tracer import scene as scene_mod
from ...tracer.shader import closures
from .bsdfs import BLENDER_DISTRIBUTIONS, CONVERTERS, PRINCIPLED_INPUTS  # noqa: F401
from .coverage import Coverage, node_text
from .mixes import NotFolded, fold, fold_fresnel, fresnel_ior, mix_factor
from .nodes import Inputs, active_output, follow, linked_socket, source_in  # noqa: F401
from .shader import compile_material
from .shader.compiler import CompileError
from .volumes import convert_volume

GREY = [0.8, 0.8, 0.8]
BLACK = [0.0, 0.0, 0.0]

# Cycles' default surface, which it renders on an object or slot without a material (and
# Blender's new material): a Principled BSDF of base colour 0.8, every other input at its node
# default. Cycles' images of the two are equal to the last digit.
DEFAULT_SURFACE = {"name": "(default surface)", "kind": "principled", "color": list(GREY),
                   **scene_mod.MATERIAL_DEFAULTS["principled"]}
# Notes on what Snell renders as Cycles does (depsgraph.SAME_IN_CYCLES: not "not comparable").
NO_MATERIAL = ("no material: rendered with Cycles' default surface (a Principled BSDF of base "
               "colour 0.8), as Cycles renders it")
NO_SURFACE = "rendered black, as Cycles renders it"
# A material with a Volume and no Surface: Cycles' boundary lets every ray through.
VOLUME_ONLY = ("rendered as a clear boundary (a Refraction BSDF of IOR 1) around the volume; "
               "direct light from lamps does not pass it")
CLEAR = {"kind": "refraction", "color": [1.0, 1.0, 1.0], "ior": 1.0}
HOLDOUT_NAME = "(object holdout)"


def holdout_material() -> dict:
    """The material of an object held out (Object > Visibility > Mask > Holdout): a program of
    one Holdout closure of weight 1, as Cycles' surface_shader_apply_holdout makes it."""
    row = [closures.HOLDOUT, -1] + [0] * 6
    return {"name": HOLDOUT_NAME, "kind": "program",
            "program": {"registers": 1, "constants": [], "code": [row], "data": [],
                        "emission_varies": False, "refracts": False}}

# What Snell renders instead of what a Material Output's other inputs carry.
OUTPUT_INPUTS = {
    "Displacement": "rendered without displacement or bump (the mesh's normals)",
}
# The Thickness input is EEVEE's alone: Cycles ignores it too.


def convert_material(mat, resources=None):
    """(material dict, Coverage) for a Blender material (None: no material); the coverage's
    issues name the node and input at fault and what is rendered instead.

    A material that is one of the scene file's fixed kinds (a BSDF of constant or image-
    textured inputs, a foldable mix) stays that kind: the tracer's exact code paths render it.
    Any other is compiled to a shader program (shader/), when that leaves fewer nodes
    unevaluated; `resources` (depsgraph's ImageTextures) gives a program the scene's images
    and texture coordinates (None: no programs)."""
    try:
        converted, coverage = _convert_fixed(mat)
    except scene_mod.SceneError as exc:   # a node's NaN input (nodes.Inputs): name the material
        raise scene_mod.SceneError(f"material {mat.name!r}: {exc}") from None
    whole_replaced = converted.pop("_replaced", False)
    if resources is None or mat is None or not coverage.issues or mat.node_tree is None:
        return converted, coverage
    out = active_output(mat.node_tree, "ShaderNodeOutputMaterial")
    if out is None or source_in(out.inputs["Surface"]).node is None:
        return converted, coverage          # no surface: black, as Cycles renders it
    program_coverage = Coverage()
    method = getattr(mat, "displacement_method", "BUMP")
    absorption = _output_inputs(out, program_coverage, method)
    try:
        program = compile_material(mat.name, out.inputs["Surface"], resources, program_coverage,
                                   method)
    except CompileError as exc:
        coverage.append(f"its shader program: {exc}")
        return converted, coverage
    # A program wins where it leaves fewer nodes out, or renders part of a surface the fixed
    # kinds replace whole, or the bump displacement they leave out.
    bumped = program["program"].get("bump_displacement", False)
    if len(program_coverage.issues) > len(coverage.issues) or (
            len(program_coverage.issues) == len(coverage.issues) and not whole_replaced
            and not bumped):
        return converted, coverage
    if absorption is not None:
        program["absorption"] = absorption
    return program, program_coverage


def _output_inputs(out, coverage, program_method=None):
    """The absorption of a Material Output's Volume (volumes.py; None: none), recording what
    its Volume and Displacement carry that Snell does not render. program_method: the
    material's displacement method, for a shader program (which renders bump displacement,
    shader/closure_nodes.py), or None."""
    for socket, instead in OUTPUT_INPUTS.items():
        node = follow(out.inputs[socket]) if socket in out.inputs else None
        if node is not None and socket == "Displacement" and program_method is not None:
            if program_method == "BOTH":
                coverage.replace(out, "is displaced as well as bumped (displacement method "
                                      "Displacement and Bump), and Snell does not displace "
                                      "meshes", "rendered with bump only", input=socket)
            elif program_method not in ("BUMP", "BOTH"):
                coverage.replace(out, "is true displacement (displacement method Displacement "
                                      "Only), which Snell does not render",
                                 "rendered without displacement", input=socket)
        elif node is not None:
            coverage.replace(out, f"is linked to {node_text(node)}, which Snell does not "
                                  f"render", instead, input=socket)
    return convert_volume(out, coverage)


def _convert_fixed(mat):
    """convert_material's material dict of a fixed kind, and its Coverage; the dict's
    "_replaced" is True where grey diffuse replaces the whole surface."""
    coverage = Coverage()
    if mat is None:
        coverage.evaluated.append("Cycles' default surface: a Principled BSDF of base colour 0.8")
        coverage.append(NO_MATERIAL)
        return dict(DEFAULT_SURFACE, specular_tint=list(DEFAULT_SURFACE["specular_tint"]),
                    coat_tint=list(DEFAULT_SURFACE["coat_tint"]),
                    emission_color=list(DEFAULT_SURFACE["emission_color"])), coverage
    name = mat.name
    black = {"name": name, "kind": "diffuse", "color": list(BLACK)}
    tree = mat.node_tree
    if tree is None:
        # Blender 5 always has a tree; files from older versions may not.
        coverage.append("no shader node tree: using grey 0.8 diffuse")
        return {"name": name, "kind": "diffuse", "color": list(GREY)}, coverage
    out = active_output(tree, "ShaderNodeOutputMaterial")
    if out is None:
        coverage.append(f"no Material Output node: {NO_SURFACE}")
        return black, coverage
    absorption = _output_inputs(out, coverage)
    surface = source_in(out.inputs["Surface"])
    if surface.node is None and absorption is not None:
        coverage.replace(out, "is not connected (a volume alone)", VOLUME_ONLY, input="Surface")
        return {"name": name, **CLEAR, "color": list(CLEAR["color"]),
                "absorption": absorption}, coverage
    if surface.node is None:
        coverage.replace(out, "is not connected", NO_SURFACE, input="Surface")
        return black, coverage
    try:
        converted = convert_surface(name, surface, coverage)
    except NotFolded as exc:
        coverage.replace(out, f"is linked to {exc}, which Snell cannot evaluate",
                         "using grey 0.8 diffuse", input="Surface")
        converted = {"name": name, "kind": "diffuse", "color": list(GREY), "_replaced": True}
    if absorption is not None:
        converted["absorption"] = absorption
    return converted, coverage


def convert_surface(name, surface, coverage):
    """The material dict of the shader node on a Surface (a nodes.Source; no node: no closure,
    black), its entries recorded in coverage; NotFolded if Snell cannot evaluate it."""
    node, groups = surface.node, surface.groups
    if node is None:
        return {"name": name, "kind": "diffuse", "color": list(BLACK)}
    if groups:
        coverage.evaluated.append(f"node {node.name!r} inside group "
                                  + " > ".join(repr(g.name) for g in groups) + ": flattened")
    if node.bl_idname == "ShaderNodeMixShader":
        # Its factor's and sides' entries count only if the mix folds: else the mix is the one
        # warning.
        sides = Coverage()
        ior = fresnel_ior(node, groups, sides)
        if ior is None:         # the factor is read (and may fail) before the sides
            fac = mix_factor(node, Inputs(node, sides, groups))
            how = f"constant factor {fac:g}"

            def combine(first, second):
                return fold(node, fac, first, second)
        else:
            how = f"factor a Fresnel node of IOR {ior:g}"

            def combine(first, second):
                return fold_fresnel(node, ior, first, second)
        try:
            first = convert_surface(name, source_in(node.inputs[1], groups), sides)
            second = convert_surface(name, source_in(node.inputs[2], groups), sides)
        except NotFolded as exc:
            raise NotFolded(f"{node_text(node)} of {exc}") from None
        mixed = combine(first, second)
        coverage.evaluate(node, f"{how}, folded into one {mixed['kind']} surface")
        coverage.evaluated += sides.evaluated
        for issue in sides.issues:
            coverage.append(issue)
        return mixed
    convert = CONVERTERS.get(node.bl_idname)
    if convert is None:
        raise NotFolded(node_text(node))
    inputs = Inputs(node, coverage, groups)
    converted = convert(name, node, inputs, coverage)
    inputs.unread_links()
    kind = converted["kind"]
    coverage.evaluate(node, f"{kind} surface")
    allowed = scene_mod.TEXTURABLE.get(kind, ())
    for field, (texture, texture_groups) in inputs.textures.items():
        if field in allowed:
            converted.setdefault("_textures", {})[field] = (texture, texture_groups)
        else:
            coverage.replace(node, f"is linked to {node_text(texture)}, which a {kind} surface "
                                   f"does not read", "using its unlinked value", input=field)
    return converted
