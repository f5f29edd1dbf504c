"""Shader node trees compiled to programs (tracer/shader/program.py): the Compiler
(compiler.py), the closures (closure_nodes.py), the input nodes (input_nodes.py), the
shading-normal nodes (normal_nodes.py) and the families of value nodes (FAMILIES: modules whose
COMPILERS compile a node's outputs at once).

compile_material turns a material's Surface into the scene file's "program" material.
"""
from __future__ import annotations

from . import color_nodes, math_nodes, procedural_textures
from .closure_nodes import compile_displacement, compile_surface
from .compiler import Compiler
from .input_nodes import NODE_OUTPUTS as INPUT_OUTPUTS
from .normal_nodes import NODE_OUTPUTS as NORMAL_OUTPUTS

NODE_OUTPUTS = {**INPUT_OUTPUTS, **NORMAL_OUTPUTS}

# Families of value nodes: modules with COMPILERS = {node idname: compile(compiler, node) ->
# {output identifier: register}}.
FAMILIES = (math_nodes, color_nodes, procedural_textures)


def compile_material(name, surface_socket, resources, coverage, displacement_method="BUMP"):
    """The scene file's program material for a Material Output's Surface socket (and the
    output's Displacement, as bump for these displacement methods), its nodes' entries
    recorded in coverage; CompileError if it cannot be compiled."""
    c = Compiler(name, resources, coverage, NODE_OUTPUTS, FAMILIES)
    compile_displacement(c, surface_socket.node, displacement_method)
    compile_surface(c, surface_socket)
    if any(x < 0.0 for x in c.emission):
        c.emission_varies = True    # no light to sample: its hits add it, as Cycles does
    mat = {"name": name, "kind": "program", "program": c.program()}
    if not c.emission_varies and any(c.emission):
        mat["emission"] = [float(x) for x in c.emission]
    return mat
