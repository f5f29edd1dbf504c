"""The scene's world as the scene file's world dict (convert_world): a Background node's colour
and strength, or an equirectangular Environment Texture (through a Mapping node or not).
"""
from __future__ import annotations

import math
import warnings as _pywarnings

import numpy as np

from ...tracer.scene import SceneError
from .coverage import node_text
from .nodes import Inputs, active_output, follow
from .textures import mapping_of


def convert_world(world, warn, images=None):
    """World dict: the Background node's Color x Strength, else world.color; black if none. An
    Environment Texture on the Background's Color (through a Mapping node or not) makes an
    environment map whose image is appended to `images` (the scene's image list)."""
    if world is None:
        return {"color": [0.0, 0.0, 0.0]}
    with _pywarnings.catch_warnings():
        _pywarnings.simplefilter("ignore", DeprecationWarning)  # use_nodes goes in Blender 6
        use_nodes = getattr(world, "use_nodes", True)
    tree = world.node_tree if use_nodes else None
    if tree is None:
        return {"color": [float(c) for c in world.color[:3]]}
    out = active_output(tree, "ShaderNodeOutputWorld")
    volume = follow(out.inputs["Volume"]) if out is not None else None
    if volume is not None:
        warn(f"world {world.name!r}: node {out.name!r}: input 'Volume' is linked to "
             f"{node_text(volume)}, which Snell does not render: rendered without it (clear "
             f"air)")
    node = follow(out.inputs["Surface"]) if out is not None else None
    if node is None:
        return {"color": [0.0, 0.0, 0.0]}  # Cycles renders an unconnected world black
    if node.bl_idname != "ShaderNodeBackground":
        warn(f"world {world.name!r}: node {out.name!r}: input 'Surface' is linked to "
             f"{node_text(node)}, which Snell cannot evaluate: using black")
        return {"color": [0.0, 0.0, 0.0]}
    issues = []
    inp = Inputs(node, issues)
    texture = follow(node.inputs["Color"])
    environment = texture is not None and texture.bl_idname == "ShaderNodeTexEnvironment"
    # The colour is read only without a map (reading a linked one notes the link).
    color = None if environment else inp.color("Color")
    strength = inp.value("Strength")
    if not math.isfinite(strength):
        raise SceneError(f"world {world.name!r}: Background Strength is {strength} (not a "
                         "finite number)")
    if color is not None and not all(math.isfinite(c) for c in color):
        raise SceneError(f"world {world.name!r}: Background Color contains NaN or Inf")
    strength = max(strength, 0.0)
    for issue in issues:
        warn(f"world {world.name!r}: {issue}")
    if environment:
        return _environment(world, texture, strength, warn, images if images is not None else [])
    return {"color": (np.array(color) * strength).tolist()}


# Cycles' colour for an image it cannot load (TEX_IMAGE_MISSING_R/G/B).
MISSING_IMAGE = [1.0, 0.0, 1.0]
TEXCOORD_DIRECTIONS = ("Generated", "Object")     # in the world, both are the ray direction


def _environment_mapping(world, texture, warn):
    """(A, b): the Environment Texture's coordinate is A d + b for direction d (a Mapping node
    on its Vector input, or none)."""
    where = f"world {world.name!r}: node {texture.name!r}"
    tm = getattr(texture, "texture_mapping", None)
    if tm is not None and (any(abs(v) > 0 for v in tm.translation)
                           or any(abs(v) > 0 for v in tm.rotation)
                           or any(abs(v - 1) > 0 for v in tm.scale)):
        warn(f"{where}: its own texture mapping (sidebar) is ignored; use a Mapping node")
    source = follow(texture.inputs["Vector"])
    if source is None:
        return np.eye(3), np.zeros(3)
    if source.bl_idname == "ShaderNodeTexCoord":
        return _texcoord_output(world, texture, source, warn)
    if source.bl_idname != "ShaderNodeMapping":
        warn(f"{where}: its Vector is linked to {source.name!r} ({source.bl_idname}), which Snell "
             f"cannot evaluate: using the view direction")
        return np.eye(3), np.zeros(3)
    issues = []
    try:
        a, b = mapping_of(source, issues)
    except ValueError:
        a = None
    for issue in issues:
        warn(f"world {world.name!r}: {issue}")
    upstream = follow(source.inputs["Vector"])
    if upstream is None:
        warn(f"world {world.name!r}: node {source.name!r}: its Vector is not connected (Cycles "
             f"then maps every direction to one point of the image): using the view direction")
    elif upstream.bl_idname == "ShaderNodeTexCoord":
        _texcoord_output(world, source, upstream, warn)
    else:
        warn(f"world {world.name!r}: node {source.name!r}: its Vector is linked to "
             f"{upstream.name!r} ({upstream.bl_idname}), which Snell cannot evaluate: using the "
             f"view direction")
    if a is None or not abs(np.linalg.det(a)) > 1e-12:
        warn(f"world {world.name!r}: node {source.name!r}: a zero scale makes the mapping "
             f"singular: ignoring the Mapping node")
        return np.eye(3), np.zeros(3)
    return a, b


def _texcoord_output(world, node, texcoord, warn):
    """The identity mapping for a Texture Coordinate output that is the direction in the world;
    a warning for the others."""
    name = node.inputs["Vector"].links[0].from_socket.name
    if name not in TEXCOORD_DIRECTIONS:
        warn(f"world {world.name!r}: node {texcoord.name!r}: output {name!r} is not supported in "
             f"the world: using the view direction (Generated)")
    return np.eye(3), np.zeros(3)


def _environment(world, texture, strength, warn, images):
    """The world dict of an Environment Texture into a Background of this strength."""
    from .images import ImageUnreadable, read_image
    where = f"world {world.name!r}: node {texture.name!r}"
    if texture.projection != "EQUIRECTANGULAR":
        warn(f"{where}: {texture.projection.lower().replace('_', ' ')} projection is not "
             f"supported: using black")
        return {"color": [0.0, 0.0, 0.0]}
    image = texture.image
    if image is None:
        warn(f"{where}: no image: using Cycles' missing-image colour")
        return {"color": [c * strength for c in MISSING_IMAGE]}
    try:
        pixels, source, _ = read_image(
            image, lambda text: warn(f"{where}: image {image.name!r}: {text}"))
    except ImageUnreadable as exc:
        warn(f"{where}: image {image.name!r} {exc}: using Cycles' missing-image colour")
        return {"color": [c * strength for c in MISSING_IMAGE]}
    interpolation = texture.interpolation.lower()
    if interpolation not in ("linear", "closest"):
        warn(f"{where}: {texture.interpolation} interpolation is not supported: using Linear")
        interpolation = "linear"
    matrix, offset = _environment_mapping(world, texture, warn)
    images.append({"name": image.name, "source": source, "pixels": pixels})
    return {"color": [0.0, 0.0, 0.0],
            "environment": {"image": len(images) - 1, "strength": float(strength),
                            "matrix": np.asarray(matrix, np.float64).tolist(),
                            "offset": np.asarray(offset, np.float64).tolist(),
                            "interpolation": interpolation}}
