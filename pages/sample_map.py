"""Heat maps of per-pixel sample counts (adaptive sampling), for the bench's and the validator's
pages. No bpy.

The ramp is viridis (dark violet to yellow): perceptually uniform and its lightness rises
monotonically, so more samples always read as brighter, in grey print too.
"""
from __future__ import annotations

import numpy as np

from .images import png_bytes, text_label, upscale

# viridis at 9 evenly spaced points (matplotlib's table, sampled); linear between them.
VIRIDIS = np.array([
    (0x44, 0x01, 0x54), (0x47, 0x2c, 0x7a), (0x3b, 0x51, 0x8b), (0x2c, 0x71, 0x8e),
    (0x21, 0x90, 0x8d), (0x27, 0xad, 0x81), (0x5c, 0xc8, 0x63), (0xaa, 0xdc, 0x32),
    (0xfd, 0xe7, 0x25)], np.float64)
DISPLAY_WIDTH = 256   # the map is upscaled (whole pixels) to about this width, room for the legend
BAR_HEIGHT = 10


def ramp(t) -> np.ndarray:
    """The colour ramp at t in [0, 1] (clipped) as uint8 (..., 3)."""
    t = np.clip(np.nan_to_num(np.asarray(t, np.float64)), 0.0, 1.0)
    x = t * (len(VIRIDIS) - 1)
    i = np.minimum(x.astype(np.int64), len(VIRIDIS) - 2)
    f = (x - i)[..., None]
    return np.rint(VIRIDIS[i] * (1 - f) + VIRIDIS[i + 1] * f).astype(np.uint8)


def sample_map_rgb(counts, vmax=None) -> np.ndarray:
    """uint8 (H, W, 3): 0 samples at the dark end, vmax (default the largest count) and above at
    the bright end."""
    counts = np.asarray(counts, np.float64)
    if counts.ndim != 2:
        raise ValueError(f"sample counts must be (H, W), not {counts.shape}")
    top = float(counts.max(initial=0.0)) if vmax is None else float(vmax)
    if top <= 0:  # nothing sampled (or a zero scale): all at the dark end, no division by 0
        return ramp(np.zeros(counts.shape))
    return ramp(counts / top)


def sample_map_png(counts, vmax=None) -> bytes:
    """A PNG of the counts on the ramp (0 to vmax, default the largest count), upscaled, above a
    colour bar and a caption with the smallest and largest count and the scale."""
    counts = np.asarray(counts)
    image = upscale(sample_map_rgb(counts, vmax), DISPLAY_WIDTH)
    width = image.shape[1]
    bar = ramp(np.linspace(0.0, 1.0, width))[None].repeat(BAR_HEIGHT, axis=0)
    low, high = (int(counts.min()), int(counts.max())) if counts.size else (0, 0)
    caption = text_label(f"samples {low}-{high}, scale 0-{high if vmax is None else vmax:g}",
                         width)
    return png_bytes(np.concatenate([image, bar, caption]))


__all__ = ["sample_map_png", "sample_map_rgb", "ramp"]
