"""The input nodes of a program, compiled one output at a time (NODE_OUTPUTS: node idname ->
function (compiler, node, output socket) -> register or None): Value, RGB, Light Path,
Geometry, Texture Coordinate, UV Map, Fresnel, Layer Weight, Image Texture, Object Info,
Attribute, Color Attribute and Camera Data (Cycles' kernel/svm/value.h, light_path.h,
geometry.h, tex_coord.h, fresnel.h, image.h, attribute.h, vertex_color.h, camera.h)."""
from __future__ import annotations

import numpy as np

from ....tracer.shader import inputs as tracer_inputs
from ....tracer.shader import object_inputs as tracer_objects

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


TEXCO_OPCODES = {"Normal": tracer_objects.TEXCO_NORMAL, "Camera": tracer_objects.TEXCO_CAMERA,
                 "Window": tracer_objects.TEXCO_WINDOW,
                 "Reflection": tracer_inputs.REFLECTION}


def texture_coordinate(c, node, socket):
    """One Texture Coordinate output at the hit."""
    name = socket.name
    if name in ("Generated", "UV") and getattr(node, "from_instancer", False):
        # Cycles' NODE_TEXCO_DUPLI_GENERATED and _UV: the instancer's coordinates.
        c.warn(node, "reads the instancer's coordinates (From Instancer), which Snell does "
                     "not", "using the object's")
    if name == "Generated":
        return c.texcoord(node, "generated")
    if name == "UV":
        return c.texcoord(node, "uv", "")
    if name == "Object" and node.object is None:
        return c.texcoord(node, "object")
    reg = c.alloc("vector")
    if name == "Object":
        # Cycles' NODE_TEXCO_OBJECT_WITH_TRANSFORM: the point in that object's space.
        to_object = np.linalg.inv(np.array(node.object.matrix_world, np.float64))
        c.emit(tracer_objects.TEXCO_OBJECT_OF, reg, c.data(to_object[:3].ravel()), 12)
        return reg
    if name not in TEXCO_OPCODES:
        return _unsupported_output(c, node, socket, "using (0, 0, 0)")
    c.emit(TEXCO_OPCODES[name], reg)
    return reg


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


OBJECT_VECTORS = {"Location": tracer_objects.OI_LOCATION, "Color": tracer_objects.OI_COLOR}
OBJECT_VALUES = {"Alpha": tracer_objects.OI_ALPHA, "Object Index": tracer_objects.OI_INDEX,
                 "Random": tracer_objects.OI_RANDOM}


def object_info(c, node, socket):
    """One Object Info output at the hit (Material Index: the material's pass index, a
    constant of the program, as Cycles' shader_pass_id)."""
    name = socket.name
    if name == "Material Index":
        import bpy
        material = bpy.data.materials.get(c.name)
        return c.constant(float(material.pass_index) if material is not None else 0.0)
    if name in OBJECT_VECTORS:
        reg = c.alloc("vector" if name == "Location" else "color")
        c.emit(tracer_objects.OBJECT_VECTOR, reg, OBJECT_VECTORS[name])
        return reg
    if name in OBJECT_VALUES:
        reg = c.alloc("float")
        c.emit(tracer_objects.OBJECT_VALUE, reg, OBJECT_VALUES[name])
        return reg
    return _unsupported_output(c, node, socket)


def _attribute_outputs(c, name, missing_alpha, kind="attribute"):
    """(colour, Fac, Alpha) registers of one ATTRIBUTE instruction reading the texture
    coordinates `kind` and `kind`_extra of `name` (missing_alpha: the Alpha where a mesh
    lacks the attribute)."""
    color, fac, alpha = c.alloc("color"), c.alloc("float"), c.alloc("float")
    c.emit(tracer_objects.ATTRIBUTE, color, fac, alpha,
           c.resources.texcoord_index(kind, name),
           c.resources.texcoord_index(f"{kind}_extra", name), missing_alpha)
    return color, fac, alpha


# Names an Attribute node gives Cycles' standard attributes (scene/attribute.cpp
# standard_name) rather than the mesh's, beside "uv", "generated" and "vertex_color", which
# meshes.py reads: not read, warned.
UNREAD_STANDARD = ("P", "radius", "N", "generated_transform", "tangent", "tangent_sign",
                   "undisplaced_tangent", "undisplaced_tangent_sign", "undeformed",
                   "undisplaced", "undisplaced_N", "particle", "curve_intercept",
                   "curve_length", "curve_random", "point_random", "ptex_face_id", "ptex_uv",
                   "density", "color", "flame", "heat", "temperature", "velocity",
                   "velocity_x", "velocity_y", "velocity_z", "pointiness", "random_per_island",
                   "shadow_transparency")


def object_attribute_key(attribute_type, name):
    """The texture coordinate name of an Attribute node of type Object, Instancer or View
    Layer."""
    return f"{attribute_type.lower()}:{name}"


def attribute(c, node, socket):
    """One Attribute node output: a mesh attribute by name (type Geometry), read per corner
    as Cycles reads it, or the object's, instancer's or view layer's property (types Object,
    Instancer and View Layer, RGBA per object: custom_properties.py)."""
    kind = node.attribute_type
    if kind == "GEOMETRY" and node.attribute_name in UNREAD_STANDARD:
        c.warn(node, f"reads Cycles' standard attribute {node.attribute_name!r}, which Snell "
                     "does not", "using 0")
        return c.constant(0.0 if socket.type == "VALUE" else (0.0, 0.0, 0.0))
    if kind == "GEOMETRY" and not node.attribute_name:
        # No name: no attribute (Cycles finds none); "" is the default colour for meshes.py.
        regs = {"Color": c.constant((0.0, 0.0, 0.0)), "Vector": c.constant((0.0, 0.0, 0.0)),
                "Fac": c.constant(0.0), "Alpha": c.constant(1.0)}
        return regs[socket.identifier]
    if kind == "GEOMETRY":
        # A missing attribute's Alpha is 1 in Cycles' Attribute node (svm_node_attr reads it
        # as a float3, whose alpha is 1).
        color, fac, alpha = _attribute_outputs(c, node.attribute_name, 1)
    else:
        # Every object has one (0, 0, 0, 0 where no property is found): found everywhere.
        # (A View Layer's is the same for every object; through the same path.)
        color, fac, alpha = _attribute_outputs(
            c, object_attribute_key(kind, node.attribute_name), 0, "object_attribute")
    # The Vector output holds the colour's values in a vector register: a link to a number
    # averages a vector where it takes a colour's luminance.
    vector = c.alloc("vector")
    c.emit(tracer_inputs.COPY_VECTOR, vector, color)
    regs = {"Color": color, "Vector": vector, "Fac": fac, "Alpha": alpha}
    for identifier, reg in regs.items():
        c.remember(node, identifier, reg)
    return regs[socket.identifier]


def color_attribute(c, node, socket):
    """One Color Attribute output: the named colour attribute, or the mesh's default (render)
    one without a name; a mesh without it gives colour 0 and Alpha 0 (svm_node_vertex_color)."""
    color, _, alpha = _attribute_outputs(c, node.layer_name, 0)
    c.remember(node, "Color", color)
    c.remember(node, "Alpha", alpha)
    return color if socket.identifier == "Color" else alpha


def camera_data(c, node, socket):
    """The Camera Data node's outputs (one instruction); returns the one asked for."""
    regs = {"View Vector": c.alloc("vector"), "View Z Depth": c.alloc("float"),
            "View Distance": c.alloc("float")}
    c.emit(tracer_objects.CAMERA_DATA, *regs.values())
    for identifier, reg in regs.items():
        c.remember(node, identifier, reg)
    return regs[socket.identifier]


def _shader_nodes():
    """Every node of every material's tree and shader node group."""
    import bpy
    trees = [mat.node_tree for mat in bpy.data.materials if mat.node_tree is not None]
    trees += [group for group in bpy.data.node_groups if group.bl_idname == "ShaderNodeTree"]
    return [node for tree in trees for node in tree.nodes]


def attribute_requests():
    """(the mesh attributes any material or node group reads through Attribute (type
    Geometry) or Color Attribute nodes ("": the default colour attribute), the (type, name)
    of its Attribute nodes of type Object, Instancer and View Layer)."""
    names, properties = set(), set()
    for node in _shader_nodes():
        if node.bl_idname == "ShaderNodeAttribute":
            if node.attribute_type == "GEOMETRY" and node.attribute_name:
                names.add(node.attribute_name)
            elif node.attribute_type in ("OBJECT", "INSTANCER", "VIEW_LAYER"):
                properties.add((node.attribute_type, node.attribute_name))
        elif node.bl_idname == "ShaderNodeVertexColor":
            names.add(node.layer_name)
    return sorted(names), sorted(properties)


def uses_object_data():
    """Whether any material or node group reads the object's data (Object Info, or a Texture
    Coordinate node's Normal): then the scene's objects carry their matrix, colour, pass index
    and random id."""
    return any(node.bl_idname in ("ShaderNodeObjectInfo", "ShaderNodeTexCoord")
               for node in _shader_nodes())


NODE_OUTPUTS = {
    "ShaderNodeValue": value, "ShaderNodeRGB": value,
    "ShaderNodeLightPath": light_path, "ShaderNodeNewGeometry": geometry,
    "ShaderNodeTexCoord": texture_coordinate, "ShaderNodeUVMap": uv_map,
    "ShaderNodeFresnel": fresnel, "ShaderNodeLayerWeight": layer_weight,
    "ShaderNodeTexImage": image_texture,
    "ShaderNodeObjectInfo": object_info, "ShaderNodeAttribute": attribute,
    "ShaderNodeVertexColor": color_attribute, "ShaderNodeCameraData": camera_data,
}
