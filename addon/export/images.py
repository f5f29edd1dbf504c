"""Blender images as the scene file stores them: float32 (H, W, 3) pixels, top row first.

Files (external or packed into the .blend) are read with OpenImageIO, as they are on disk; images
Blender generated (no file) come from their pixel buffer. Colour: an image whose colour space is
sRGB is converted to linear with the exact sRGB curve, Non-Color and the linear Rec.709 spaces
are kept as they are; any other space is kept as well, with a warning. Image sequences and
movies are not read (a warning; the caller uses a constant).
"""
from __future__ import annotations

import os
import tempfile

import numpy as np

LINEAR_SPACES = ("Linear Rec.709", "Linear", "scene_linear", "Linear BT.709",
                 "Linear Rec.709 (sRGB)")
DATA_SPACES = ("Non-Color", "Raw", "data")
SRGB_SPACES = ("sRGB", "sRGB 2.1", "sRGB IEC61966-2.1")
UNREAD_SOURCES = {"SEQUENCE": "an image sequence", "MOVIE": "a movie",
                  "TILED": "a tiled (UDIM) image"}


class ImageUnreadable(ValueError):
    """An image Snell cannot read; the message says why (the caller names the node)."""


def srgb_to_linear(v: np.ndarray) -> np.ndarray:
    """The exact piecewise sRGB decoding of float32 pixels (the tracer's, textures.py)."""
    from ...tracer.textures import srgb_to_linear_array
    v = np.ascontiguousarray(v, np.float32)
    out = np.empty_like(v)
    srgb_to_linear_array(v.reshape(-1), out.reshape(-1))
    return out


def _rgb(pixels: np.ndarray) -> np.ndarray:
    """(H, W, C) pixels as (H, W, 3): grey replicated, alpha dropped."""
    channels = pixels.shape[2]
    if channels in (1, 2):
        return np.repeat(pixels[:, :, :1], 3, axis=2)
    return pixels[:, :, :3]


def _read_file(path: str) -> np.ndarray:
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise ImageUnreadable(f"cannot read {path!r} ({oiio.geterror() or 'unknown format'})")
    try:
        pixels = inp.read_image(0, 0, 0, inp.spec().nchannels, "float")
    finally:
        inp.close()
    if pixels is None:
        raise ImageUnreadable(f"cannot read {path!r}")
    pixels = np.asarray(pixels, np.float32)
    return pixels.reshape(pixels.shape[0], pixels.shape[1], -1)


def _read_packed(image) -> np.ndarray:
    ext = os.path.splitext(image.filepath or image.name)[1] or ".png"
    fd, tmp = tempfile.mkstemp(suffix=ext)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(image.packed_file.data)
        return _read_file(tmp)
    finally:
        os.unlink(tmp)


def _read_buffer(image) -> np.ndarray:
    """A generated image's pixel buffer (RGBA floats, bottom row first)."""
    w, h = image.size
    if w == 0 or h == 0:
        raise ImageUnreadable("has no pixels")
    flat = np.empty(w * h * image.channels, np.float32)
    image.pixels.foreach_get(flat)
    return flat.reshape(h, w, image.channels)[::-1]


def read_image(image, warn, decode=True) -> tuple[np.ndarray, str, str]:
    """(float32 (H, W, 3) pixels, where they came from, their colour space: "linear", or "srgb"
    when decode is false and the image is sRGB: then the pixels stay encoded, to be decoded
    after interpolation as Cycles does) of a bpy image; warn(text) for what is approximated.
    ImageUnreadable when there is nothing to read."""
    import bpy
    if image.source in UNREAD_SOURCES:
        raise ImageUnreadable(f"is {UNREAD_SOURCES[image.source]}, which Snell does not read")
    if image.packed_file is not None:
        pixels, source = _read_packed(image), f"packed:{image.name}"
    elif image.source == "FILE":
        path = bpy.path.abspath(image.filepath, library=image.library)
        if not os.path.isfile(path):
            raise ImageUnreadable(f"file {path!r} not found")
        pixels, source = _read_file(path), path
    else:
        pixels, source = _read_buffer(image), f"generated:{image.name}"
    if pixels.ndim != 3 or pixels.shape[0] == 0 or pixels.shape[1] == 0:
        raise ImageUnreadable("has no pixels")
    rgb = np.ascontiguousarray(_rgb(pixels), np.float32)
    space = image.colorspace_settings.name
    colorspace = "linear"
    if space in SRGB_SPACES and not decode:
        colorspace = "srgb"
    elif space in SRGB_SPACES:
        rgb = srgb_to_linear(rgb)
    elif space not in LINEAR_SPACES + DATA_SPACES and not image.colorspace_settings.is_data:
        warn(f"colour space {space!r} is not supported: using the values as linear Rec.709")
    if not np.isfinite(rgb).all():
        bad = int((~np.isfinite(rgb)).any(axis=2).sum())
        warn(f"{bad} pixel(s) are NaN or Inf: set to 0")
        rgb = np.where(np.isfinite(rgb), rgb, 0.0).astype(np.float32)
    return rgb, source, colorspace
