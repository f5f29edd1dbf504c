"""The shading-normal nodes of a program, compiled one output at a time (NODE_OUTPUTS, as
input_nodes.py's): the Normal Map node in tangent, object and world space (Cycles'
NormalMapNode, scene/shader_nodes.cpp, run as tracer/shader/normals.py), and the Bump node
where Cycles folds it away (its Height unlinked)."""
from __future__ import annotations

from ....tracer.shader import inputs as tracer_inputs, normals as tracer_normals

# Blender's Normal Map spaces in Cycles' order (tracer.shader.normals.SPACE_*).
SPACES = ("TANGENT", "OBJECT", "WORLD", "BLENDER_OBJECT", "BLENDER_WORLD")
FRAME_KINDS = ("tangent", "tangent_sign", "tangent_normal")     # tracer.scene.TEXCOORD_KINDS


def uses_normal_maps():
    """(whether any material or node group has a Normal Map node, whether one is in tangent
    space: then meshes keep their UV maps' tangents)."""
    import bpy
    trees = [mat.node_tree for mat in bpy.data.materials if mat.node_tree is not None]
    trees += [group for group in bpy.data.node_groups if group.bl_idname == "ShaderNodeTree"]
    spaces = {node.space for tree in trees for node in tree.nodes
              if node.bl_idname == "ShaderNodeNormalMap"}
    return bool(spaces), "TANGENT" in spaces


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
    """The Bump node's Normal as Cycles folds it when its Height is unlinked (BumpNode::
    constant_fold): its Normal input, or the shading normal. A linked Height is warned and
    left out: the same normal."""
    if c.is_linked(node, "Height"):
        c.warn(node, "is linked, which Snell does not evaluate (the Bump node's height at "
                     "offset positions)", "the Normal input unbent", input="Height")
    else:
        c.coverage.evaluate(node, "bump with no height: the normal unchanged, as Cycles folds it")
    if c.is_linked(node, "Normal"):
        return c.input(node, "Normal", "vector")
    out = c.alloc("vector")
    c.emit(tracer_inputs.GEOMETRY, out, tracer_inputs.G_NORMAL)
    return out


NODE_OUTPUTS = {"ShaderNodeNormalMap": normal_map, "ShaderNodeBump": bump}
