"""Blender materials as the scene file's material dicts: the shader nodes' conversion.

A material's Surface node is converted by its entry in _CONVERTERS (one function per BSDF node);
Inputs reads a node's unlinked input values and notes what Snell ignores. An Image Texture on a
texturable input is handed on in the dict's "_textures" (textures.py converts it). follow,
active_output and Inputs are the node-tree readers the lamp and world conversions use too.
"""
from __future__ import annotations

from ...tracer import scene as scene_mod

GREY = [0.8, 0.8, 0.8]
DEFAULT_MATERIAL = {"name": "(default grey)", "kind": "diffuse", "color": GREY}


def follow(socket):
    """The node feeding an input socket (through reroutes and enabled links), or None."""
    while socket is not None and socket.is_linked:
        link = socket.links[0]
        if link.is_muted or not link.is_valid:
            return None
        node = link.from_node
        if node.bl_idname == "NodeReroute":
            socket = node.inputs[0]
            continue
        return node
    return None


def active_output(tree, idname):
    """The tree's output node of type idname that Cycles renders (the active one), or None."""
    outputs = [n for n in tree.nodes if n.bl_idname == idname]
    for n in outputs:
        if n.is_active_output and n.target in ("ALL", "CYCLES"):
            return n
    return next((n for n in outputs if n.target in ("ALL", "CYCLES")), None)


def linked_socket(socket):
    """The output socket feeding an input (through reroutes)."""
    while socket.is_linked:
        link = socket.links[0]
        if link.from_node.bl_idname != "NodeReroute":
            return link.from_socket
        socket = link.from_node.inputs[0]
    return None


def _value_text(sock):
    """A socket's unlinked value as a message shows it."""
    value = sock.default_value
    if sock.type in ("RGBA", "VECTOR", "ROTATION"):
        return "(" + ", ".join(f"{float(c):g}" for c in value[:3]) + ")"
    return f"{float(value):g}"


class Inputs:
    """Reads the unlinked values of one node's inputs and notes, as issues, what Snell ignores."""

    def __init__(self, node, issues):
        self.node, self.issues = node, issues
        self.textures = {}     # scene field -> the Image Texture node that drives it

    def _note(self, name, text):
        self.issues.append(f"node {self.node.name!r}: input {name!r} {text}")

    def _socket(self, name, field=None):
        sock = self.node.inputs[name]
        source = follow(sock)
        if source is not None:
            if (field in scene_mod.TEXTURE_SLOTS and source.bl_idname == "ShaderNodeTexImage"
                    and linked_socket(sock).name == "Color"):
                self.textures[field] = source
                return sock
            what = ("an Image Texture's Alpha" if source.bl_idname == "ShaderNodeTexImage"
                    else repr(source.name))
            self._note(name, f"is linked to {what}, which Snell cannot evaluate: using "
                             f"its unlinked value {_value_text(sock)}")
        return sock

    def color(self, name, field=None):
        """The input's RGB colour (an Image Texture on it is noted in self.textures when field
        names a texturable one)."""
        return [float(c) for c in self._socket(name, field).default_value[:3]]

    def value(self, name):
        """The input's number."""
        return float(self._socket(name).default_value)

    def vector(self, name):
        """The input's three numbers (a vector, an Euler rotation)."""
        return [float(c) for c in self._socket(name).default_value[:3]]

    def field(self, name, field):
        """The input as the scene file's `field`: a colour, or a number clamped as Cycles does."""
        if self.node.inputs[name].type == "RGBA":
            return self.color(name, field)
        return _clamp(float(self._socket(name, field).default_value), field)

    def unsupported(self, name, neutral, rendered):
        """Note an input Snell does not render, unless it has its neutral value or is missing."""
        if self.node.inputs.get(name) is None:    # an input older Blender versions lack
            return
        value = self.value(name)
        if value != neutral:
            self._note(name, f"is {value:g}: {rendered}")

    def ignored_links(self, *names):
        """Note the linked ones of these inputs (normals, tangents), which Snell ignores."""
        for name in names:
            sock = self.node.inputs.get(name)
            source = follow(sock) if sock is not None else None
            if source is not None:
                self._note(name, f"is linked to {source.name!r}, which Snell ignores: "
                                 f"{IGNORED_LINKS[name]}")


# What Snell renders instead of a linked normal or tangent.
IGNORED_LINKS = {"Normal": "shaded with the mesh's normals",
                 "Coat Normal": "shaded with the mesh's normals", "Tangent": "rendered isotropic"}


def _clamp(value, field):
    """A number within the scene file's range of `field`, where Cycles clamps the input too."""
    least, greatest, open_below = scene_mod.MATERIAL_RANGES[field]
    if open_below:
        least = 1e-5    # the one such range is an IOR's, > 0; Cycles takes at least 1e-5
    value = max(value, least)
    return value if greatest is None else min(value, greatest)


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


def convert_material(mat):
    """(material dict, issues) for a Blender material; issues name the node at fault."""
    issues = []
    if mat is None:
        return dict(DEFAULT_MATERIAL), ["no material, using grey 0.8 diffuse"]
    name = mat.name
    fallback = {"name": name, "kind": "diffuse", "color": GREY}
    tree = mat.node_tree
    if tree is None:
        # Blender 5 always has a tree; files from older versions may not.
        return fallback, ["no shader node tree, using grey 0.8 diffuse"]
    out = active_output(tree, "ShaderNodeOutputMaterial")
    if out is None:
        return fallback, ["no Material Output node, using grey 0.8 diffuse"]
    node = follow(out.inputs["Surface"])
    if node is None:
        return fallback, [f"node {out.name!r}: nothing connected to Surface, using grey 0.8 diffuse"]
    convert = _CONVERTERS.get(node.bl_idname)
    if convert is None:
        issues.append(f"node {node.name!r} ({node.bl_idname}) is not supported, using grey 0.8 diffuse")
        return fallback, issues
    inputs = Inputs(node, issues)
    converted = convert(name, node, inputs, issues)
    kind = converted["kind"]
    allowed = scene_mod.TEXTURABLE.get(kind, ())
    for field, texture in inputs.textures.items():
        if field in allowed:
            converted.setdefault("_textures", {})[field] = texture
    return converted, issues


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

    Full transmission with nothing on top, smooth, untinted and without emission is exactly
    Cycles' smooth glass: it keeps the kind it had before rough surfaces, so that a scene's
    glass renders as the validator has always held it.
    """
    exact = (mat["transmission"] == 1.0 and mat["metallic"] == 0.0 and mat["coat_weight"] == 0.0
             and mat["roughness"] == 0.0 and mat["color"] == WHITE
             and mat["specular_tint"] == WHITE and mat["specular_ior_level"] == 0.5
             and not scene_mod.emits(mat))
    if not exact:
        return None
    return {"name": mat["name"], "kind": "glass", "color": list(WHITE),
            "transmission_color": list(WHITE), "ior": mat["ior"]}


_CONVERTERS = {
    "ShaderNodeBsdfDiffuse": _diffuse,
    "ShaderNodeBsdfGlossy": _glossy,
    "ShaderNodeBsdfAnisotropic": _glossy,    # the Glossy BSDF's identifier since Blender 4.0
    "ShaderNodeBsdfGlass": _glass,
    "ShaderNodeBsdfRefraction": _refraction,
    "ShaderNodeEmission": _emission,
    "ShaderNodeBsdfPrincipled": _principled,
}
