"""The node-tree readers the material, lamp and world conversions share: a link followed back to
the node that feeds it (source_in, source, follow, linked_socket: through reroutes, muted nodes
and node groups, as Cycles follows them), the active output node (active_output), and a node's
input values (Inputs: a Value or RGB node linked to an input is its constant, as Cycles folds
it), which records in a Coverage what it reads and what it replaces.
"""
from __future__ import annotations

import math

from ...tracer import scene as scene_mod
from ...tracer.shader.colorspace import RGB_TO_Y
from .coverage import node_text


def _muted_input(node, output):
    """The input a muted node passes to `output` (its internal link), or None: then Cycles
    leaves the link's target unlinked, at its own value."""
    for internal in node.internal_links:
        if internal.to_socket.identifier == output.identifier and not internal.is_muted:
            return internal.from_socket
    return None


def _group_output(group):
    """The active Group Output of a group node's tree (the one Blender evaluates), or None."""
    tree = group.node_tree
    outputs = [n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"] if tree else []
    return next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)


def _socket_by_identifier(sockets, identifier):
    return next((s for s in sockets if s.identifier == identifier), None)


class Source:
    """Where a link chain ends: the node and output feeding an input (None: nothing), the groups
    it lies inside (outermost first), and the socket whose own value the input takes when
    nothing feeds it (a group node's input, when the chain leaves a group through its Group
    Input)."""

    def __init__(self, node, output, groups, value):
        self.node, self.output, self.groups, self.value = node, output, groups, value


def source_in(socket, groups=()):
    """The Source of an input inside `groups`: followed through reroutes, muted links (which
    pass nothing), muted nodes (their internal links), and node groups (into a group's active
    Group Output, and out of its Group Input to the group node's input), as Blender and Cycles
    flatten them."""
    value = socket
    while socket is not None and socket.is_linked:
        link = socket.links[0]
        if link.is_muted or not link.is_valid:
            break
        node = link.from_node
        if node.bl_idname == "NodeReroute":
            socket = node.inputs[0]
        elif node.mute:
            socket = _muted_input(node, link.from_socket)
        elif node.bl_idname == "ShaderNodeGroup" and _group_output(node) is not None:
            socket = _socket_by_identifier(_group_output(node).inputs,
                                           link.from_socket.identifier)
            groups = (*groups, node)
        elif node.bl_idname == "NodeGroupInput" and groups:
            socket = _socket_by_identifier(groups[-1].inputs, link.from_socket.identifier)
            groups, value = groups[:-1], socket
        elif node.bl_idname == "NodeGroupInput":
            break
        else:
            return Source(node, link.from_socket, groups, value)
    return Source(None, None, groups, value if value is not None else socket)


# Nodes whose output is a constant of their own (Cycles folds them into the inputs they feed).
CONSTANT_NODES = ("ShaderNodeValue", "ShaderNodeRGB")


def is_constant(socket, groups=()):
    """Whether an input takes a constant: nothing linked, or a Value or RGB node."""
    return _gives_constant(source_in(socket, groups).node)


def _gives_constant(node):
    """Whether an input fed by `node` (None: nothing) takes a constant."""
    return node is None or node.bl_idname in CONSTANT_NODES


def source(socket):
    """(node, output socket) feeding an input (see source_in); (None, None) if none."""
    found = source_in(socket)
    return found.node, found.output


def follow(socket):
    """The node feeding an input socket (see source_in), or None."""
    return source(socket)[0]


def linked_socket(socket):
    """The output socket feeding an input (see source_in), or None."""
    return source(socket)[1]


def active_output(tree, idname):
    """The tree's output node of type idname that Cycles renders (the active one), or None."""
    outputs = [n for n in tree.nodes if n.bl_idname == idname]
    for n in outputs:
        if n.is_active_output and n.target in ("ALL", "CYCLES"):
            return n
    return next((n for n in outputs if n.target in ("ALL", "CYCLES")), None)


def _value_text(sock):
    """A socket's unlinked value as a message shows it."""
    value = sock.default_value
    if sock.type in ("RGBA", "VECTOR", "ROTATION"):
        return "(" + ", ".join(f"{float(c):g}" for c in value[:3]) + ")"
    return f"{float(value):g}"


# What Snell renders instead of a linked normal or tangent.
IGNORED_LINKS = {"Normal": "shaded with the mesh's normals",
                 "Coat Normal": "shaded with the mesh's normals", "Tangent": "rendered isotropic"}


class _Value:
    """A socket's value converted to another socket's type, as Blender converts a link."""

    def __init__(self, default_value, type):
        self.default_value, self.type = default_value, type


# Blender's and Cycles' colour-to-number conversion: the colour's luminance, with the weights
# of Blender's colour configuration (colorspace.RGB_TO_Y: 0.212639, 0.715169, 0.072192).
LUMINANCE = RGB_TO_Y


def _as_type(value, sock):
    """The value socket `value` read as the input `sock` reads it (a group's input may have
    another type than the socket it feeds inside)."""
    if value.type == sock.type:
        return value
    v = value.default_value
    if value.type in ("RGBA", "VECTOR"):
        c = [float(x) for x in v[:3]]
        if sock.type in ("RGBA", "VECTOR"):
            return _Value((*c, 1.0), sock.type)
        number = (sum(w * x for w, x in zip(LUMINANCE, c)) if value.type == "RGBA"
                  else sum(c) / 3.0)
        return _Value(number, sock.type)
    number = float(v)
    if sock.type in ("RGBA", "VECTOR"):
        return _Value((number, number, number, 1.0), sock.type)
    return _Value(number, sock.type)


class Inputs:
    """Reads the values of one node's inputs (the node inside `groups`, a tuple of group
    nodes: a flattened group's inputs come from the group node), recording in `coverage` (a
    Coverage, or a list of issues) what Snell ignores; `read` holds the inputs read, for
    unread_links."""

    def __init__(self, node, coverage, groups=()):
        self.node, self.coverage, self.groups = node, coverage, groups
        self.textures = {}     # scene field -> (the Image Texture node that drives it, groups)
        self.read = set()

    def _note(self, name, text):
        self.coverage.append(f"node {self.node.name!r}: input {name!r} {text}")

    def _socket(self, name, field=None):
        self.read.add(name)
        sock = self.node.inputs[name]
        found = source_in(sock, self.groups)
        value = _as_type(found.value or sock, sock)
        node = found.node
        if node is not None and node.bl_idname in CONSTANT_NODES:
            if hasattr(self.coverage, "evaluate"):
                self.coverage.evaluate(node, f"a constant, into {self.node.name!r} input {name!r}")
            return _as_type(found.output, sock)
        if node is not None:
            if (field in scene_mod.TEXTURE_SLOTS and node.bl_idname == "ShaderNodeTexImage"
                    and found.output.name == "Color"):
                self.textures[field] = (node, found.groups)
                return value
            what = ("an Image Texture's Alpha" if node.bl_idname == "ShaderNodeTexImage"
                    else node_text(node))
            self._note(name, f"is linked to {what}, which Snell cannot evaluate: using "
                             f"its unlinked value {_value_text(value)}")
        return value

    def _refuse_nan(self, name, value):
        """A scene field's constant value that is NaN is an error naming the node and input,
        and the Value or RGB node it came from (Inf is clamped to the field's range, as Cycles
        clamps it)."""
        values = value if isinstance(value, list) else [value]
        node = source_in(self.node.inputs[name], self.groups).node
        if _gives_constant(node) and any(math.isnan(v) for v in values):
            origin = f" from node {node.name!r}" if node is not None else ""
            raise scene_mod.SceneError(f"node {self.node.name!r}: input {name!r} is {value}"
                                       f"{origin} (not a number)")

    def color(self, name, field=None):
        """The input's RGB colour (an Image Texture on it is noted in self.textures when field
        names a texturable one)."""
        color = [float(c) for c in self._socket(name, field).default_value[:3]]
        if field is not None:
            self._refuse_nan(name, color)
        return color

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
        value = float(self._socket(name, field).default_value)
        self._refuse_nan(name, value)
        return _clamp(value, field)

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
            if sock is None:
                continue
            self.read.add(name)
            node = source_in(sock, self.groups).node
            if node is not None:
                self._note(name, f"is linked to {node_text(node)}, which Snell ignores: "
                                 f"{IGNORED_LINKS[name]}")

    def unread_links(self):
        """Note every linked input that was not read: nothing linked is dropped unsaid."""
        for sock in self.node.inputs:
            if not sock.enabled or sock.name in self.read:
                continue
            node = source_in(sock, self.groups).node
            if node is not None:
                self._note(sock.name, f"is linked to {node_text(node)}, which Snell does not "
                                      f"evaluate: ignored")


def _clamp(value, field):
    """A number within the scene file's range of `field`, where Cycles clamps the input too."""
    least, greatest, open_below = scene_mod.MATERIAL_RANGES[field]
    if open_below:
        least = 1e-5    # the one such range is an IOR's, > 0; Cycles takes at least 1e-5
    value = max(value, least)
    return value if greatest is None else min(value, greatest)
