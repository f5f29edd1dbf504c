"""A linear image as a PNG the way Blender shows the .blend it came from: through the scene's view
transform, look, exposure, gamma, display device and dither, by Blender's own colour management
(OpenColorIO with Blender's configuration), as a render result is saved."""
from __future__ import annotations

import os

import numpy as np

from .blendfile import open_blend


def write_png(path: str, rgb: np.ndarray, blend_path: str, alpha=None) -> None:
    """Write rgb (H, W, 3, scene-linear, top row first) as an 8-bit PNG through the colour
    management of blend_path's scene; with an (H, W) alpha (rgb premultiplied by it, as a
    render result's), an RGBA PNG as Blender saves a transparent film's."""
    import bpy
    if os.path.abspath(bpy.data.filepath or "") != os.path.abspath(blend_path):
        open_blend(blend_path)
    scene = bpy.context.scene
    h, w = rgb.shape[:2]
    rgba = np.ones((h, w, 4), np.float32)
    # Blender's rows go bottom to top; values that are not finite would reach OpenColorIO.
    rgba[..., :3] = np.nan_to_num(rgb[::-1], nan=0.0, posinf=0.0, neginf=0.0)
    if alpha is not None:
        rgba[..., 3] = alpha[::-1]
    image = bpy.data.images.new("snell-png", w, h, alpha=alpha is not None, float_buffer=True)
    try:
        image.colorspace_settings.name = _scene_linear()
        image.pixels.foreach_set(rgba.ravel())
        settings = scene.render.image_settings
        settings.file_format, settings.color_depth = "PNG", "8"
        settings.color_mode = "RGB" if alpha is None else "RGBA"
        image.save_render(filepath=os.path.abspath(path), scene=scene)
    finally:
        bpy.data.images.remove(image)


def _scene_linear() -> str:
    """The name of Blender's scene-linear colour space (Linear Rec.709 in Blender 4 and 5)."""
    import bpy
    names = bpy.types.ColorManagedInputColorspaceSettings.bl_rna.properties["name"].enum_items
    for name in ("Linear Rec.709", "Linear"):
        if name in names:
            return name
    raise RuntimeError("Blender's colour configuration has no scene-linear colour space")
