"""A material's node tree compiled to a shader program (tracer/shader/program.py), as Cycles'
SVM compiler does it (scene/svm.cpp): from the output's Surface back through the closures
(Mix and Add Shader hand each side its weight) to the value nodes that feed them, each node
compiled once, its instructions before those of the nodes that read it.

The Compiler is what the node modules (closure_nodes.py, input_nodes.py, and one module per
family of value nodes) see: `input` compiles what feeds an input and returns its register,
`emit` appends an instruction. Registers are Reg objects until `program` lays them out:
constants first (the program's "constants"), then the rest.

A memo scope (`scope`) compiles a subgraph again, each node anew, with the constants shared:
the Bump node's Height at the hit moved by its differentials (normal_nodes.py) and a bump
displacement's three evaluations (closure_nodes.py), as Cycles copies those nodes
(scene/shader_graph.cpp refine_bump_nodes, bump_from_displacement).

Constant factors fold as they compile: a Mix Shader of constant factor gives its sides
constant weights (a side of weight 0 is not compiled at all), so that a material whose mixes
are all constant costs no instruction for them.
"""
from __future__ import annotations

import math
from contextlib import contextmanager

from ....tracer.scene import SceneError
from ....tracer.shader import inputs as tracer_inputs
from ....tracer.shader.program import MAX_REGISTERS, SLOTS
from ..coverage import node_text
from ..nodes import LUMINANCE, _as_type, source_in


class CompileError(Exception):
    """A tree the compiler cannot turn into a program (the text says why)."""


def _input_text(node, sock):
    """An input as the user sees it: its name, and which one where the node has several of
    that name (a Math node's three 'Value's)."""
    same = [s for s in node.inputs if s.name == sock.name and s.enabled]
    if len(same) < 2:
        return repr(sock.name)
    return f"{sock.name!r} ({same.index(sock) + 1} of {len(same)})"


class Reg:
    """A register while the program is compiled: a float (width 1) or a vector or colour
    (width 3), among the constants (with its values) or not."""

    def __init__(self, kind, constant=None):
        self.kind = kind                  # "float", "vector" or "color"
        self.constant = constant          # the values of a constant register, else None
        self.index = None                 # its place, once laid out

    @property
    def width(self):
        return 1 if self.kind == "float" else 3


SOCKET_KINDS = {"VALUE": "float", "INT": "float", "BOOLEAN": "float", "RGBA": "color",
                "VECTOR": "vector"}


class Compiler:
    """Compiles one material's tree (`name`: the material's, for warnings); `resources` gives
    the scene's images and texture coordinates (depsgraph's ImageTextures); node_outputs and
    families the nodes it compiles (shader/__init__.py's NODE_OUTPUTS and FAMILIES)."""

    def __init__(self, name, resources, coverage, node_outputs, families):
        self.name, self.resources = name, resources
        self.coverage = coverage
        self.families = families
        self.node_outputs = node_outputs
        self.rows = []                 # [opcode, slot, ...] with Reg objects in register slots
        self.data_values = []
        self.constants = {}            # values -> Reg (one register per distinct constant)
        self.blocks = []               # constant Regs of their own (Principled blocks)
        self.temps = []
        self.memo = {}                 # (scope, node, groups, output) -> Reg
        self.memo_scope = ()           # the memo scope nodes compile in (scope())
        self.read = set()              # (node, groups, input identifier) of inputs read
        self.visiting = set()
        self.groups = ()               # the groups of the node being compiled
        self.emission = [0.0, 0.0, 0.0]
        self.emission_varies = False
        self.refracts = False
        self.bump_displacement = False     # the program bumps the hit's normal first

    # -- registers and instructions -------------------------------------------------------

    def constant(self, value):
        """A register holding a constant (a number, or three)."""
        values = (float(value),) if not hasattr(value, "__len__") else \
            tuple(float(v) for v in value[:3])
        if values not in self.constants:
            self.constants[values] = Reg("float" if len(values) == 1 else "vector", values)
        return self.constants[values]

    def constant_block(self, values):
        """Registers of their own, in a row, holding these constants (they may be written)."""
        regs = [Reg("float", (float(v),)) for v in values]
        self.blocks.append(regs)
        return regs

    def alloc(self, kind):
        """A new register of kind "float", "vector" or "color"."""
        reg = Reg(kind)
        self.temps.append(reg)
        return reg

    def emit(self, opcode, *slots):
        """Append an instruction (slots: Regs, ints, or None for -1)."""
        row = [opcode, *slots] + [0] * (SLOTS - len(slots))
        self.rows.append([-1 if s is None else s for s in row])

    def data(self, values):
        """Store values in the program's data; returns their offset."""
        offset = len(self.data_values)
        self.data_values.extend(float(v) for v in values)
        return offset

    def warn(self, node, what, instead, input=None):
        """Record what is not evaluated and what is rendered instead (one warning each)."""
        self.coverage.replace(node, what, instead, input=input)

    def texcoord(self, node, kind, name=""):
        """The register of texture coordinates (uv with a map name, generated, object) at
        the hit."""
        key = (self.memo_scope, kind, name)
        if key not in self.memo:
            reg = self.alloc("vector")
            self.emit(tracer_inputs.TEXCOORD, reg, self.resources.texcoord_index(kind, name))
            self.memo[key] = reg
        return self.memo[key]

    @contextmanager
    def scope(self, name):
        """Compile in a memo scope of its own inside the current one (`name` tells it from
        the others): every node reached is compiled again, constants are shared."""
        saved = self.memo_scope
        self.memo_scope = saved + (name,)
        try:
            yield
        finally:
            self.memo_scope = saved

    def remember(self, node, identifier, reg):
        """Record reg as the register of another output of the node being compiled."""
        self.memo[self._key(node, identifier)] = reg

    # -- inputs ------------------------------------------------------------------------------

    def _socket(self, node, name):
        sock = node.inputs.get(name)
        if sock is None:
            sock = next((s for s in node.inputs if s.identifier == name), None)
        if sock is None:
            raise KeyError(f"node {node.name!r} has no input {name!r}")
        self.read.add(self._key(node, sock.identifier))
        return sock

    def _key(self, node, identifier, groups=None):
        groups = self.groups if groups is None else groups
        return (self.memo_scope, node.as_pointer(), tuple(g.as_pointer() for g in groups),
                identifier)

    def unread_links(self, node):
        """Warn for every linked input of the node that its compilation did not read: nothing
        linked is dropped unsaid."""
        for sock in node.inputs:
            if not sock.enabled or self._key(node, sock.identifier) in self.read:
                continue
            found = source_in(sock, self.groups)
            if found.node is not None:
                self.warn(node, f"is linked to {node_text(found.node)}, which Snell does not "
                                f"evaluate", "ignored", input=sock.name)

    def value(self, node, name):
        """An input's unlinked value as Blender converts it (a number or a list of three)."""
        sock = self._socket(node, name)
        found = source_in(sock, self.groups)
        value = _as_type(found.value or sock, sock).default_value
        value = [float(c) for c in value[:3]] if sock.type in ("RGBA", "VECTOR") else float(value)
        if not all(math.isfinite(v) for v in (value if isinstance(value, list) else [value])):
            # A program's constants are finite (the scene file's check): say which input.
            raise SceneError(f"material {self.name!r}: node {node.name!r}: input "
                             f"{_input_text(node, sock)} is {value} (not a finite number)")
        return value

    def is_linked(self, node, name):
        """Whether something feeds the input (through reroutes, groups and muted nodes)."""
        return source_in(self._socket(node, name), self.groups).node is not None

    def input(self, node, name, kind):
        """The register of an input as `kind`: what feeds it, converted as Cycles converts a
        link, or its unlinked value as a constant."""
        sock = self._socket(node, name)
        if any(not link.is_valid for link in sock.links):
            # Blender marks the link that closes a loop invalid; Cycles reads the input as
            # unlinked.
            self.warn(node, "is linked in a loop of links, which Blender marks invalid",
                      "using its unlinked value", input=sock.name)
        found = source_in(sock, self.groups)
        if found.node is None:
            return self.convert(self.constant(self.value(node, name)),
                                SOCKET_KINDS.get(sock.type, "float"), kind)
        reg = self.output(found.node, found.output, found.groups, sock)
        if reg is None:
            return self.convert(self.constant(self.value(node, name)),
                                SOCKET_KINDS.get(sock.type, "float"), kind)
        return self.convert(reg, reg.kind, kind)

    def output(self, node, socket, groups, into):
        """The register of a node's output (compiled once); None if it cannot be evaluated
        (warned: the input `into` takes its unlinked value)."""
        key = self._key(node, socket.identifier, groups)
        if key in self.memo:
            return self.memo[key]
        if key in self.visiting:
            self.warn(node, "is in a loop of links", "using the unlinked value of the input it "
                      "feeds", input=None)
            return None
        saved, self.groups = self.groups, groups
        self.visiting.add(key)
        try:
            known, reg = self._compile_output(node, socket)
            if known:
                self.unread_links(node)
                if reg is not None:
                    self.coverage.evaluate(node, "compiled into the material's shader program")
        finally:
            self.visiting.discard(key)
            self.groups = saved
        if not known:
            self.warn(node, f"is {node_text(node)}, which Snell does not evaluate",
                      f"input {into.name!r} of {into.node.name!r} uses its unlinked value")
        self.memo[key] = reg
        return reg

    def _compile_output(self, node, socket):
        """(whether Snell knows the node, the output's register or None: the node's compile
        function warned why)."""
        per_output = self.node_outputs.get(node.bl_idname)
        if per_output is not None:
            return True, per_output(self, node, socket)
        for family in self.families:
            compile_node = family.COMPILERS.get(node.bl_idname)
            if compile_node is not None:
                outputs = compile_node(self, node)
                # Every output of the node at once: record the others too.
                for identifier, reg in outputs.items():
                    self.remember(node, identifier, reg)
                return True, outputs.get(socket.identifier)
        return False, None

    def convert(self, reg, have, want):
        """reg (of kind `have`) as kind `want`, as Cycles converts a link (colour to number:
        luminance; vector to number: average; number to either: in every component)."""
        if want == have or (want != "float" and have != "float"):
            return reg          # a colour and a vector are the same three registers
        if reg.constant is not None:
            v = reg.constant
            if want == "float":
                weights = LUMINANCE if have == "color" else (1 / 3, 1 / 3, 1 / 3)
                return self.constant(sum(w * x for w, x in zip(weights, v)))
            return self.constant((v[0], v[0], v[0]))
        out = self.alloc(want)
        if want == "float":
            op = (tracer_inputs.COLOR_TO_FLOAT if have == "color"
                  else tracer_inputs.VECTOR_TO_FLOAT)
        else:
            op = tracer_inputs.FLOAT_TO_VECTOR
        self.emit(op, out, reg)
        return out

    # -- the program ---------------------------------------------------------------------------

    def program(self):
        """The scene file's program: registers laid out, constants first."""
        consts = []
        for reg in self.constants.values():
            reg.index = len(consts)
            consts.extend(reg.constant)
        for block in self.blocks:
            for reg in block:
                reg.index = len(consts)
                consts.extend(reg.constant)
        registers = len(consts)
        for reg in self.temps:
            reg.index = registers
            registers += reg.width
        if registers > MAX_REGISTERS:
            raise CompileError(f"needs {registers} registers, more than the {MAX_REGISTERS} "
                               f"a program has")
        code = [[s.index if isinstance(s, Reg) else int(s) for s in row] for row in self.rows]
        program = {"registers": registers, "constants": consts, "code": code,
                   "data": list(self.data_values), "emission_varies": self.emission_varies,
                   "refracts": self.refracts}
        if self.bump_displacement:
            program["bump_displacement"] = True
        return program

