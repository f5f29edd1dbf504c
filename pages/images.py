"""Pixels for the pages: PNG encoding, text labels, upscaling and the blue-white-red scale of
signed maps. No bpy (PNGs and text through OpenImageIO)."""
from __future__ import annotations

import os
import tempfile

import numpy as np


def diverging(values, limit):
    """Blue (-limit) - white (0) - red (+limit) as uint8 (H, W, 3)."""
    t = np.clip(np.nan_to_num(np.asarray(values, np.float64)) / max(limit, 1e-30), -1.0, 1.0)
    pos, neg = np.clip(t, 0, 1)[..., None], np.clip(-t, 0, 1)[..., None]
    white = np.ones(t.shape + (3,))
    red, blue = np.array([0.75, 0.05, 0.05]), np.array([0.05, 0.2, 0.8])
    rgb = white * (1 - pos - neg) + red * pos + blue * neg
    return np.rint(np.clip(rgb, 0, 1) * 255).astype(np.uint8)


def colour_bar(limit, width=256, height=14):
    """The legend of diverging(): -limit to +limit left to right, uint8 (height, width, 3)."""
    ramp = np.linspace(-limit, limit, width)[None, :].repeat(height, axis=0)
    return diverging(ramp, limit)


def png_bytes(pixels8) -> bytes:
    """Encode a uint8 (H, W, 3) array as PNG through OpenImageIO."""
    import OpenImageIO as oiio
    pixels8 = np.ascontiguousarray(pixels8, np.uint8)
    h, w, c = pixels8.shape
    fd, tmp = tempfile.mkstemp(suffix=".png")
    os.close(fd)
    try:
        out = oiio.ImageOutput.create(tmp)
        out.open(tmp, oiio.ImageSpec(w, h, c, "uint8"))
        out.write_image(pixels8)
        out.close()
        with open(tmp, "rb") as f:
            return f.read()
    finally:
        os.remove(tmp)


def text_label(text, width, height=22, size=14):
    """A dark strip with white text (OpenImageIO's built-in font)."""
    import OpenImageIO as oiio
    buf = oiio.ImageBuf(oiio.ImageSpec(width, height, 3, "float"))
    oiio.ImageBufAlgo.fill(buf, (0.12, 0.12, 0.12))
    oiio.ImageBufAlgo.render_text(buf, 4, height - 6, text, size, "", (1, 1, 1))
    return np.rint(np.clip(buf.get_pixels(oiio.FLOAT), 0, 1) * 255).astype(np.uint8)


def upscale(pixels8, width):
    """Nearest-neighbour upscale to about `width` pixels wide (integer factor, at least 1)."""
    k = max(1, width // pixels8.shape[1])
    return pixels8.repeat(k, axis=0).repeat(k, axis=1)
