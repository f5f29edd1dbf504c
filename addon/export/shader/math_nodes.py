"""The value nodes' compile functions for shader programs: Value, Math, Vector Math, Clamp, Map
Range, Mapping, Separate/Combine XYZ (rows of tracer/shader/math_nodes.py). Cycles' own compile
steps are in scene/shader_nodes.cpp (MathNode, VectorMathNode, ClampNode, MapRangeNode,
VectorMapRangeNode, MappingNode, SeparateXYZNode, CombineXYZNode)."""
from __future__ import annotations

from ....tracer.shader import math_nodes as ops


def _index(c, node, names, value, what):
    """The literal int of an enum value, or 0 with a warning if this Blender has a newer one."""
    if value in names:
        return names.index(value)
    c.warn(node, f"{what} {value} is not evaluated", names[0].replace("_", " ").title())
    return 0


def _input(c, node, identifier, kind):
    """c.input, or 0 for a socket the node's mode hides (Math's third value, Vector Math's
    Scale, Mapping's Location for vectors): Cycles reads it but the formula ignores it."""
    for socket in node.inputs:
        if socket.identifier == identifier and getattr(socket, "is_unavailable", False):
            return c.constant(0.0 if kind == "float" else (0.0, 0.0, 0.0))
    return c.input(node, identifier, kind)


def compile_math(c, node):
    """Math: one MATH row (its Clamp option in the row, as Cycles' added Clamp node)."""
    op = _index(c, node, ops.MATH_OPERATIONS, node.operation, "operation")
    out = c.alloc("float")
    c.emit(ops.MATH, op, int(node.use_clamp), c.input(node, "Value", "float"),
           _input(c, node, "Value_001", "float"), _input(c, node, "Value_002", "float"), out)
    return {"Value": out}


def compile_vector_math(c, node):
    """Vector Math: one VECTOR_MATH row writing both outputs."""
    op = _index(c, node, ops.VECTOR_MATH_OPERATIONS, node.operation, "operation")
    value, vector = c.alloc("float"), c.alloc("vector")
    c.emit(ops.VECTOR_MATH, op, c.input(node, "Vector", "vector"),
           _input(c, node, "Vector_001", "vector"), _input(c, node, "Vector_002", "vector"),
           _input(c, node, "Scale", "float"), value, vector)
    return {"Value": value, "Vector": vector}


def compile_clamp(c, node):
    """Clamp: one CLAMP row."""
    kind = _index(c, node, ops.CLAMP_TYPES, node.clamp_type, "clamp type")
    out = c.alloc("float")
    c.emit(ops.CLAMP, kind, c.input(node, "Value", "float"), c.input(node, "Min", "float"),
           c.input(node, "Max", "float"), out)
    return {"Result": out}


def compile_map_range(c, node):
    """Map Range: float (the six inputs gathered into two vectors, then MAP_RANGE) or vector
    (VECTOR_MAP_RANGE for the factor, VECTOR_MAP_APPLY for the result)."""
    kind = _index(c, node, ops.MAP_RANGE_TYPES, node.interpolation_type, "interpolation")
    if node.data_type == "FLOAT_VECTOR":
        factor, out = c.alloc("vector"), c.alloc("vector")
        c.emit(ops.VECTOR_MAP_RANGE, kind, c.input(node, "Vector", "vector"),
               c.input(node, "From_Min_FLOAT3", "vector"),
               c.input(node, "From_Max_FLOAT3", "vector"),
               c.input(node, "Steps_FLOAT3", "vector"), factor)
        # svm_node_vector_map_range ignores Clamp for the smooth steps
        use_clamp = int(node.clamp) if kind in (ops.RANGE_LINEAR, ops.RANGE_STEPPED) else 0
        c.emit(ops.VECTOR_MAP_APPLY, use_clamp, factor, c.input(node, "To_Min_FLOAT3", "vector"),
               c.input(node, "To_Max_FLOAT3", "vector"), out)
        return {"Vector": out}
    p, q, out = c.alloc("vector"), c.alloc("vector"), c.alloc("float")
    c.emit(ops.COMBINE_XYZ, c.input(node, "Value", "float"), c.input(node, "From Min", "float"),
           c.input(node, "From Max", "float"), p)
    c.emit(ops.COMBINE_XYZ, c.input(node, "To Min", "float"), c.input(node, "To Max", "float"),
           c.input(node, "Steps", "float"), q)
    c.emit(ops.MAP_RANGE, kind, int(node.clamp), p, q, out)
    return {"Result": out}


def compile_mapping(c, node):
    """Mapping: one MAPPING row (location, rotation and scale may be linked)."""
    kind = _index(c, node, ops.MAPPING_TYPES, node.vector_type, "type")
    out = c.alloc("vector")
    c.emit(ops.MAPPING, kind, c.input(node, "Vector", "vector"),
           _input(c, node, "Location", "vector"), c.input(node, "Rotation", "vector"),
           c.input(node, "Scale", "vector"), out)
    return {"Vector": out}


def compile_separate_xyz(c, node):
    """Separate XYZ: one SEPARATE_XYZ row."""
    x, y, z = c.alloc("float"), c.alloc("float"), c.alloc("float")
    c.emit(ops.SEPARATE_XYZ, c.input(node, "Vector", "vector"), x, y, z)
    return {"X": x, "Y": y, "Z": z}


def compile_combine_xyz(c, node):
    """Combine XYZ: one COMBINE_XYZ row."""
    out = c.alloc("vector")
    c.emit(ops.COMBINE_XYZ, c.input(node, "X", "float"), c.input(node, "Y", "float"),
           c.input(node, "Z", "float"), out)
    return {"Vector": out}


def compile_value(c, node):
    """Value: a constant (Cycles' ValueNode)."""
    return {"Value": c.constant(float(node.outputs[0].default_value))}


COMPILERS = {
    "ShaderNodeValue": compile_value,
    "ShaderNodeMath": compile_math,
    "ShaderNodeVectorMath": compile_vector_math,
    "ShaderNodeClamp": compile_clamp,
    "ShaderNodeMapRange": compile_map_range,
    "ShaderNodeMapping": compile_mapping,
    "ShaderNodeSeparateXYZ": compile_separate_xyz,
    "ShaderNodeCombineXYZ": compile_combine_xyz,
}
