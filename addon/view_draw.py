"""Drawing the viewport's image and messages through Blender's gpu module (main thread only).

The engine binds Blender's display space shader around draw_texture (view_draw), so Blender's
colour management turns Snell's linear radiance into display values as it does for Cycles. The
texture is RGBA32F, values made finite and clamped. Tests stand in for this module's GpuDrawing
(the gpu module refuses to draw in background mode).
"""
from __future__ import annotations

import numpy as np

# Largest value the texture holds: far above any display transform's white, finite in float16
# and float32 alike (a GPU may store RGBA32F textures at lower precision).
DISPLAY_LIMIT = 65504.0


def display_pixels(image: np.ndarray, alpha: np.ndarray | None = None) -> np.ndarray:
    """The (h, w, 4) float32 texture rows (bottom row first, as OpenGL's) of a (h, w, 3) linear
    image whose row 0 is the top: non-finite values 0, the rest clamped to [0, DISPLAY_LIMIT];
    with its (h, w) alpha (premultiplied colour: the viewport shows through), else opaque."""
    h, w = image.shape[:2]
    rgba = np.ones((h, w, 4), np.float32)
    rgba[:, :, :3] = np.nan_to_num(image[::-1], nan=0.0, posinf=0.0, neginf=0.0)
    np.clip(rgba[:, :, :3], 0.0, DISPLAY_LIMIT, out=rgba[:, :, :3])
    if alpha is not None:
        rgba[:, :, 3] = alpha[::-1]
    return rgba


class GpuDrawing:
    """Blender's gpu, gpu_extras and blf, as the viewport uses them."""

    def texture(self, rgba: np.ndarray):
        """A float texture of (h, w, 4) float32 pixels."""
        import gpu
        h, w = rgba.shape[:2]
        flat = np.ascontiguousarray(rgba, np.float32).reshape(-1)
        # A buffer of the array's own size and shape wraps its memory (no per-value copy).
        data = gpu.types.Buffer("FLOAT", flat.size, flat)
        return gpu.types.GPUTexture((w, h), format="RGBA32F", data=data)

    def draw_texture(self, texture, x: int, y: int, width: int, height: int):
        """Draw a texture stretched over a rectangle of the region (pixels, from bottom-left)."""
        import gpu
        from gpu_extras.presets import draw_texture_2d
        gpu.state.blend_set("ALPHA_PREMULT")
        draw_texture_2d(texture, (x, y), width, height)
        gpu.state.blend_set("NONE")

    def text(self, x: int, y: int, lines: list[str], size: float = 13.0):
        """Draw lines of text downwards from (x, y), the region's pixels from bottom-left."""
        import blf
        font = 0
        blf.size(font, size)
        blf.color(font, 1.0, 0.85, 0.3, 1.0)
        blf.enable(font, blf.SHADOW)
        blf.shadow(font, 3, 0.0, 0.0, 0.0, 1.0)
        for i, line in enumerate(lines):
            blf.position(font, x, y - i * size * 1.5, 0.0)
            blf.draw(font, line)
        blf.disable(font, blf.SHADOW)
