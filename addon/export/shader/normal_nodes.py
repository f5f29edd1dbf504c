"""The shading-normal nodes of a program, compiled one output at a time (NODE_OUTPUTS, as
input_nodes.py's): the Normal Map node in tangent, object and world space (Cycles'
NormalMapNode, scene/shader_nodes.cpp, run as tracer/shader/normals.py); the Bump node, folded
away where Cycles folds it (its Height unlinked), else its Height compiled three times, at the
hit and at the hit moved by each differential (Cycles' refine_bump_nodes, scene/
shader_graph.cpp; run as tracer/shader/bump.py); and the Displacement and Vector Displacement
nodes that a bump displacement reads (closure_nodes.compile_displacement)."""
from __future__ import annotations

from ....tracer.shader import bump as tracer_bump, inputs as tracer_inputs, \
    normals as tracer_normals

# Blender's Normal Map spaces in Cycles' order (tracer.shader.normals.SPACE_*).
SPACES = ("TANGENT", "OBJECT", "WORLD", "BLENDER_OBJECT", "BLENDER_WORLD")
FRAME_KINDS = ("tangent", "tangent_sign", "tangent_normal")     # tracer.scene.TEXCOORD_KINDS


def uses_normal_maps():
    """(whether any material or node group has a Normal Map or a displacement node: then
    meshes keep their coordinates, the normal matrix among them; whether a Normal Map or a
    Vector Displacement is in tangent space: then they keep their UV maps' tangents too)."""
    import bpy
    trees = [mat.node_tree for mat in bpy.data.materials if mat.node_tree is not None]
    trees += [group for group in bpy.data.node_groups if group.bl_idname == "ShaderNodeTree"]
    nodes = [node for tree in trees for node in tree.nodes]
    maps = {node.space for node in nodes if node.bl_idname == "ShaderNodeNormalMap"}
    # Displacement nodes read the object's normal matrix among the coordinates, and a
    # tangent-space Vector Displacement the tangents too.
    displacements = {node.space for node in nodes if node.bl_idname in (
        "ShaderNodeDisplacement", "ShaderNodeVectorDisplacement")}
    return bool(maps or displacements), "TANGENT" in maps | displacements


def normal_map(c, node, socket):
    """The Normal Map node's Normal."""
    color = c.input(node, "Color", "color")
    strength = c.input(node, "Strength", "float")
    out = c.alloc("vector")
    space = SPACES.index(node.space)
    if space == tracer_normals.SPACE_TANGENT:
        # The UV map's frame (name "": each mesh's active render map, as Cycles' default).
        frame = [c.resources.texcoord_index(kind, node.uv_map) for kind in FRAME_KINDS]
        c.emit(tracer_normals.NORMAL_MAP_TANGENT, out, color, strength, *frame)
    elif space in (tracer_normals.SPACE_OBJECT, tracer_normals.SPACE_BLENDER_OBJECT):
        columns = [c.resources.texcoord_index("normal_matrix", axis) for axis in "xyz"]
        c.emit(tracer_normals.NORMAL_MAP_OBJECT, out, color, strength, space, *columns)
    else:
        c.emit(tracer_normals.NORMAL_MAP_WORLD, out, color, strength, space)
    uv = f" of UV map {node.uv_map!r}" if space == tracer_normals.SPACE_TANGENT and node.uv_map \
        else ""
    c.coverage.evaluate(node, f"normal map in {node.space.lower()} space{uv}")
    return out


def bump(c, node, socket):
    """The Bump node's Normal: with its Height unlinked, its Normal input or the shading normal,
    as Cycles folds it (BumpNode::constant_fold); else the normal bent by the Height's
    gradient."""
    if not c.is_linked(node, "Height"):
        c.coverage.evaluate(node, "bump with no height: the normal unchanged, as Cycles folds it")
        if c.is_linked(node, "Normal"):
            return c.input(node, "Normal", "vector")
        out = c.alloc("vector")
        c.emit(tracer_inputs.GEOMETRY, out, tracer_inputs.G_NORMAL)
        return out
    normal = c.input(node, "Normal", "vector") if c.is_linked(node, "Normal") else None
    width = filter_width(c, node)
    heights = three_heights(c, width, ("bump", c._key(node, "Height")),
                            lambda: c.input(node, "Height", "float"))
    out = c.alloc("vector")
    c.emit(tracer_bump.BUMP, out, normal, heights, c.input(node, "Strength", "float"),
           c.input(node, "Distance", "float"), int(bool(node.invert)), width)
    c.coverage.evaluate(node, "bump: the height's gradient from its values at the hit and at "
                              "the hit moved by its differentials")
    return out


def filter_width(c, node):
    """The constant register of the Bump node's Filter Width (Blender 4.3 and later; 0.1, its
    default, before): Cycles reads the unlinked value when it builds the graph."""
    if node.inputs.get("Filter Width") is None:
        return c.constant(0.1)
    if c.is_linked(node, "Filter Width"):
        c.warn(node, "is linked, which Cycles does not evaluate either", "using its unlinked "
               "value", input="Filter Width")
    return c.constant(c.value(node, "Filter Width"))


def three_heights(c, width, name, height):
    """The first of three registers in a row holding height() (a function compiling the height
    and returning its register) at the hit, at the hit moved along dP.dx and along dP.dy
    times the filter width (a register): the moved ones compiled again in memo scopes of their
    own (`name` and the axis) between OFFSET and RESTORE, as Cycles' copies of the nodes."""
    block = c.constant_block([0.0, 0.0, 0.0])
    c.emit(tracer_inputs.COPY_FLOAT, block[0], height())
    for axis, label in ((tracer_bump.AXIS_X, "dx"), (tracer_bump.AXIS_Y, "dy")):
        with c.scope((name, label)):
            c.emit(tracer_bump.OFFSET, axis, width)
            moved = height()
            c.emit(tracer_bump.RESTORE)
        c.emit(tracer_inputs.COPY_FLOAT, block[1 + axis], moved)
    return block[0]


def _object_matrix(c):
    """The scene's texture coordinates holding the object's normal matrix columns."""
    return [c.resources.texcoord_index("normal_matrix", axis) for axis in "xyz"]


def displacement(c, node, socket):
    """The Displacement node's vector: its normal times (Height - Midlevel) x Scale, in object
    space (through the object's matrix, as Cycles' svm_node_displacement) or world space."""
    normal = c.input(node, "Normal", "vector") if c.is_linked(node, "Normal") else None
    if node.space == "OBJECT":
        direction = c.alloc("vector")
        c.emit(tracer_bump.OBJECT_NORMAL, direction, normal, *_object_matrix(c))
        normal = direction
    out = c.alloc("vector")
    c.emit(tracer_bump.DISPLACEMENT, out, c.input(node, "Height", "float"),
           c.input(node, "Midlevel", "float"), c.input(node, "Scale", "float"), normal)
    c.coverage.evaluate(node, f"displacement in {node.space.lower()} space, as bump")
    return out


def vector_displacement(c, node, socket):
    """The Vector Displacement node's vector: (Vector - Midlevel) x Scale in tangent, object or
    world space (svm_node_vector_displacement)."""
    out = c.alloc("vector")
    c.emit(tracer_bump.VECTOR_DISPLACEMENT, out, c.input(node, "Vector", "vector"),
           c.input(node, "Midlevel", "float"), c.input(node, "Scale", "float"))
    if node.space == "TANGENT":
        # The active render UV map's tangents, as Cycles' VectorDisplacementNode reads them.
        world = c.alloc("vector")
        c.emit(tracer_bump.TANGENT_DIRECTION, world, out,
               c.resources.texcoord_index("tangent", ""),
               c.resources.texcoord_index("tangent_sign", ""), *_object_matrix(c))
        out = world
    elif node.space == "OBJECT":
        world = c.alloc("vector")
        c.emit(tracer_bump.OBJECT_DIRECTION, world, out, *_object_matrix(c))
        out = world
    c.coverage.evaluate(node, f"vector displacement in {node.space.lower()} space, as bump")
    return out


NODE_OUTPUTS = {"ShaderNodeNormalMap": normal_map, "ShaderNodeBump": bump,
                "ShaderNodeDisplacement": displacement,
                "ShaderNodeVectorDisplacement": vector_displacement}
