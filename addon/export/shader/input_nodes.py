"""The input nodes of a program, compiled one output at a time (NODE_OUTPUTS: node idname ->
function (compiler, node, output socket) -> register or None): Value, RGB, Light Path,
Geometry, Texture Coordinate, UV Map, Fresnel, Layer Weight and Image Texture (Cycles'
kernel/svm/value.h, light_path.h, geometry.h, tex_coord.h, fresnel.h, image.h)."""
from __future__ import annotations

from ....tracer.shader import inputs as tracer_inputs

LIGHT_PATH_OUTPUTS = {
    "Is Camera Ray": tracer_inputs.LP_CAMERA, "Is Shadow Ray": tracer_inputs.LP_SHADOW,
    "Is Diffuse Ray": tracer_inputs.LP_DIFFUSE, "Is Glossy Ray": tracer_inputs.LP_GLOSSY,
    "Is Singular Ray": tracer_inputs.LP_SINGULAR,
    "Is Reflection Ray": tracer_inputs.LP_REFLECTION,
    "Is Transmission Ray": tracer_inputs.LP_TRANSMISSION,
    "Ray Length": tracer_inputs.LP_RAY_LENGTH, "Ray Depth": tracer_inputs.LP_RAY_DEPTH,
}
# Light Path outputs that are exactly 0 in Snell's renders: it has no volumes.
ZERO_IN_SNELL = ("Is Volume Scatter Ray",)
GEOMETRY_OUTPUTS = {"Position": tracer_inputs.G_POSITION, "Normal": tracer_inputs.G_NORMAL,
                    "True Normal": tracer_inputs.G_TRUE_NORMAL,
                    "Incoming": tracer_inputs.G_INCOMING}
MISSING_IMAGE = "rendered magenta, as Cycles renders a missing image"
EXTENSIONS = ("REPEAT", "EXTEND", "CLIP", "MIRROR")     # tracer.textures.REPEAT ...


def _unsupported_output(c, node, socket, instead="using 0"):
    c.warn(node, f"output {socket.name!r} is not evaluated", instead)
    return c.constant(0.0 if socket.type == "VALUE" else (0.0, 0.0, 0.0))


def value(c, node, socket):
    """Value and RGB: their constant."""
    return c.constant(socket.default_value if socket.type == "VALUE"
                      else socket.default_value[:3])


def light_path(c, node, socket):
    """One Light Path output at the hit."""
    if socket.name in ZERO_IN_SNELL:
        return c.constant(0.0)
    which = LIGHT_PATH_OUTPUTS.get(socket.name)
    if which is None:
        return _unsupported_output(c, node, socket)
    reg = c.alloc("float")
    c.emit(tracer_inputs.LIGHT_PATH, reg, which)
    return reg


def geometry(c, node, socket):
    """One Geometry output at the hit."""
    if socket.name == "Backfacing":
        reg = c.alloc("float")
        c.emit(tracer_inputs.LIGHT_PATH, reg, tracer_inputs.LP_BACKFACING)
        return reg
    which = GEOMETRY_OUTPUTS.get(socket.name)
    if which is None:
        return _unsupported_output(c, node, socket)
    reg = c.alloc("vector")
    c.emit(tracer_inputs.GEOMETRY, reg, which)
    return reg


def texture_coordinate(c, node, socket):
    """One Texture Coordinate output at the hit."""
    name = socket.name
    if name == "Generated":
        return c.texcoord(node, "generated")
    if name == "UV":
        return c.texcoord(node, "uv", "")
    if name == "Object" and node.object is None:
        return c.texcoord(node, "object")
    if name == "Reflection":
        reg = c.alloc("vector")
        c.emit(tracer_inputs.REFLECTION, reg)
        return reg
    return _unsupported_output(c, node, socket, "using (0, 0, 0)")


def uv_map(c, node, socket):
    """The UV Map node's UV."""
    if getattr(node, "from_instancer", False):
        c.warn(node, "reads the instancer's UV map, which Snell does not", "using the object's")
    return c.texcoord(node, "uv", node.uv_map)


def fresnel(c, node, socket):
    """The Fresnel node."""
    reg = c.alloc("float")
    normal = c.input(node, "Normal", "vector") if c.is_linked(node, "Normal") else None
    c.emit(tracer_inputs.FRESNEL, reg, c.input(node, "IOR", "float"), normal)
    return reg


def layer_weight(c, node, socket):
    """Both Layer Weight outputs (one instruction); returns the one asked for."""
    fresnel_reg, facing = c.alloc("float"), c.alloc("float")
    normal = c.input(node, "Normal", "vector") if c.is_linked(node, "Normal") else None
    c.emit(tracer_inputs.LAYER_WEIGHT, fresnel_reg, facing, c.input(node, "Blend", "float"),
           normal)
    c.remember(node, "Fresnel", fresnel_reg)
    c.remember(node, "Facing", facing)
    return fresnel_reg if socket.identifier == "Fresnel" else facing


def image_texture(c, node, socket):
    """The Image Texture node's Color (Alpha: 1, warned; the pool keeps RGB only)."""
    index = c.resources.image_index(node, c.coverage, MISSING_IMAGE)
    if index is None:
        # Cycles renders a missing image as magenta, for materials as for the world.
        return c.constant((1.0, 0.0, 1.0)) if socket.name == "Color" else c.constant(1.0)
    if node.projection != "FLAT":
        c.warn(node, f"has {node.projection.lower()} projection, which Snell does not render",
               "using Flat")
    closest = node.interpolation == "Closest"
    if node.interpolation not in ("Linear", "Closest"):
        c.warn(node, f"has {node.interpolation} interpolation, which Snell does not render",
               "using Linear")
    vector = (c.input(node, "Vector", "vector") if c.is_linked(node, "Vector")
              else c.texcoord(node, "uv", ""))
    color, alpha = c.alloc("color"), c.alloc("float")
    c.emit(tracer_inputs.IMAGE, color, alpha, vector, index, int(closest),
           EXTENSIONS.index(node.extension))
    c.remember(node, "Color", color)
    c.remember(node, "Alpha", alpha)
    if socket.name == "Alpha":
        c.warn(node, "output 'Alpha' is read as 1: Snell keeps images' colour only",
               "opaque")
    return color if socket.name == "Color" else alpha


NODE_OUTPUTS = {
    "ShaderNodeValue": value, "ShaderNodeRGB": value,
    "ShaderNodeLightPath": light_path, "ShaderNodeNewGeometry": geometry,
    "ShaderNodeTexCoord": texture_coordinate, "ShaderNodeUVMap": uv_map,
    "ShaderNodeFresnel": fresnel, "ShaderNodeLayerWeight": layer_weight,
    "ShaderNodeTexImage": image_texture,
}
