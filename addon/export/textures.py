"""Image Texture nodes as the scene file's texture entries (ImageTextures), and Mapping nodes as
the affine maps of their Vector (mapping_of, which the world's Environment Texture uses too).

materials.py hands on the Image Texture of each texturable input; ImageTextures converts it,
reading each image once into the scene's image list and naming the texture coordinates (a UV
map, Generated) it reads. The depsgraph walk gathers those coordinates over the scene's parts.
"""
from __future__ import annotations

import numpy as np

from .nodes import Inputs, source_in


# Nodes that read texture coordinates: every texture node (Image and procedural), Texture
# Coordinate and UV Map.
READS_COORDINATES = ("ShaderNodeTexCoord", "ShaderNodeUVMap")


def uses_image_textures():
    """Whether any material or node group has a node that reads texture coordinates (then
    meshes keep their UV maps, Generated and object coordinates)."""
    import bpy
    trees = [mat.node_tree for mat in bpy.data.materials if mat.node_tree is not None]
    trees += [group for group in bpy.data.node_groups if group.bl_idname == "ShaderNodeTree"]
    return any(node.bl_idname.startswith("ShaderNodeTex") or node.bl_idname in READS_COORDINATES
               for tree in trees for node in tree.nodes)


def mapping_of(node, issues, groups=()):
    """(A, b) of a Mapping node (inside groups), whose output is A v + b up to a positive factor
    (ValueError for a type it does not know); its linked inputs are noted in issues."""
    from ...tracer.lights.world import mapping_transform
    inputs = Inputs(node, issues, groups)
    kind = node.vector_type
    location = inputs.vector("Location") if kind in ("POINT", "TEXTURE") else [0.0, 0.0, 0.0]
    return mapping_transform(kind, location, inputs.vector("Rotation"), inputs.vector("Scale"))


class ImageTextures:
    """The scene's images and texture coordinates, as its Image Texture nodes are converted."""

    def __init__(self, images):
        self.images = images  # the scene's images (the world's environment map joins them)
        self.image_index_of = {}  # bpy image pointer -> index in self.images
        self.texcoord_keys = []  # (kind, UV map name) of the textures' coordinates

    def image_index(self, node, issues, instead="using the input's unlinked value"):
        """The scene's index of an Image Texture node's image, read on first use; None (with
        an issue naming the node and what is rendered `instead`) if it has none or it cannot
        be read."""
        from .images import ImageUnreadable, read_image
        where = f"node {node.name!r}"
        image = node.image
        if image is None:
            issues.append(f"{where}: no image: {instead}")
            return None
        key = image.original.as_pointer() if hasattr(image, "original") else image.as_pointer()
        if key not in self.image_index_of:
            notes = []
            try:
                pixels, source, colorspace = read_image(image, notes.append, decode=False)
            except ImageUnreadable as exc:
                issues.append(f"{where}: image {image.name!r} {exc}: {instead}")
                return None
            for note in notes:
                issues.append(f"{where}: image {image.name!r}: {note}")
            self.images.append({"name": image.name, "source": source, "colorspace": colorspace,
                                "pixels": pixels})
            self.image_index_of[key] = len(self.images) - 1
        return self.image_index_of[key]

    def texcoord_index(self, kind, name=""):
        """The scene's index of a texture coordinate entry (uv and a map name, generated,
        object), added on first use."""
        if (kind, name) not in self.texcoord_keys:
            self.texcoord_keys.append((kind, name))
        return self.texcoord_keys.index((kind, name))

    def convert(self, node, issues, groups=()):
        """The scene file's texture entry of an Image Texture node (inside groups, a tuple of
        group nodes), its image and coordinates
        added to the scene's; None (with an issue: the input's unlinked value is used) if it
        cannot be read."""
        where = f"node {node.name!r}"
        index = self.image_index(node, issues)
        if index is None:
            return None
        interpolation = node.interpolation.lower()
        if interpolation not in ("linear", "closest"):
            issues.append(f"{where}: {node.interpolation} interpolation is not supported: using "
                          f"Linear")
            interpolation = "linear"
        if node.projection != "FLAT":
            issues.append(f"{where}: {node.projection.lower()} projection is not supported: "
                          f"using Flat")
        matrix, offset = np.eye(3), np.zeros(3)
        found = source_in(node.inputs["Vector"], groups)
        source_node = found.node
        if source_node is not None and source_node.bl_idname == "ShaderNodeMapping":
            matrix, offset = mapping_of(source_node, issues, found.groups)
            found = source_in(source_node.inputs["Vector"], found.groups)
            source_node = found.node
        coord = ("uv", "")
        if source_node is None:
            pass
        elif source_node.bl_idname == "ShaderNodeUVMap":
            coord = ("uv", source_node.uv_map)
        elif source_node.bl_idname == "ShaderNodeTexCoord":
            output = found.output.name
            if output == "Generated":
                coord = ("generated", "")
            elif output != "UV":
                issues.append(f"{where}: texture coordinate {output!r} is not supported: using "
                              f"the active UV map")
        else:
            issues.append(f"{where}: its Vector is linked to {source_node.name!r}, which Snell "
                          f"cannot evaluate: using the active UV map")
        return {"image": index, "texcoord": self.texcoord_index(*coord),
                "interpolation": interpolation, "extension": node.extension.lower(),
                "matrix": np.asarray(matrix, np.float64).tolist(),
                "offset": np.asarray(offset, np.float64).tolist()}
