"""Image Texture nodes as the scene file's texture entries (ImageTextures), and Mapping nodes as
the affine maps of their Vector (mapping_of, which the world's Environment Texture uses too).

materials.py hands on the Image Texture of each texturable input; ImageTextures converts it,
reading each image once into the scene's image list and naming the texture coordinates (a UV
map, Generated) it reads. The depsgraph walk gathers those coordinates over the scene's parts.
"""
from __future__ import annotations

import numpy as np

from .nodes import Inputs, source_in


def uses_image_textures():
    """Whether any material has an Image Texture node (then meshes keep their UV maps)."""
    import bpy
    return any(node.bl_idname == "ShaderNodeTexImage" for mat in bpy.data.materials
               if mat.node_tree is not None for node in mat.node_tree.nodes)


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
        self.image_index = {}  # bpy image pointer -> index in self.images
        self.texcoord_keys = []  # (kind, UV map name) of the textures' coordinates

    def convert(self, node, issues, groups=()):
        """The scene file's texture entry of an Image Texture node (inside groups, a tuple of
        group nodes), its image and coordinates
        added to the scene's; None (with an issue: the input's unlinked value is used) if it
        cannot be read."""
        from .images import ImageUnreadable, read_image
        where = f"node {node.name!r}"
        image = node.image
        if image is None:
            issues.append(f"{where}: no image: using the input's unlinked value")
            return None
        key = image.original.as_pointer() if hasattr(image, "original") else image.as_pointer()
        if key not in self.image_index:
            notes = []
            try:
                pixels, source, colorspace = read_image(image, notes.append, decode=False)
            except ImageUnreadable as exc:
                issues.append(f"{where}: image {image.name!r} {exc}: using the input's unlinked "
                              f"value")
                return None
            for note in notes:
                issues.append(f"{where}: image {image.name!r}: {note}")
            self.images.append({"name": image.name, "source": source, "colorspace": colorspace,
                                "pixels": pixels})
            self.image_index[key] = len(self.images) - 1
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
        if coord not in self.texcoord_keys:
            self.texcoord_keys.append(coord)
        return {"image": self.image_index[key], "texcoord": self.texcoord_keys.index(coord),
                "interpolation": interpolation, "extension": node.extension.lower(),
                "matrix": np.asarray(matrix, np.float64).tolist(),
                "offset": np.asarray(offset, np.float64).tolist()}
