"""Image output: linear float EXR, 8-bit sRGB PNG, and NaN/Inf clean-up.

Images are (H, W, 3) arrays of linear Rec.709 RGB with row 0 at the TOP, as OpenImageIO stores
them. EXRs are written with OpenEXR's bindings (each channel in its own type: the sample counts
as 32-bit unsigned integers), PNGs and every read with OpenImageIO; both are imported only by
the functions that read or write files: the add-on running inside Blender hands pixels to the
RenderEngine API instead and must not depend on them.

Writes are atomic: the image goes to a temporary file in the destination directory, then is renamed
over the destination, so an interrupted or failed write never leaves a partial image behind.
"""
from __future__ import annotations

import contextlib
import os

import numpy as np

from .atomic import atomic_path


def _as_rgb(rgb, what="image") -> np.ndarray:
    arr = np.asarray(rgb)
    if arr.ndim != 3 or arr.shape[2] != 3 or arr.shape[0] == 0 or arr.shape[1] == 0:
        raise ValueError(f"{what}: expected an (H, W, 3) array, got shape {arr.shape}")
    return arr


FLOAT32_MAX = float(np.finfo(np.float32).max)


def as_float32(values) -> np.ndarray:
    """Values as float32, those beyond float32's range as +-Inf: what NumPy's cast gives them,
    without its "overflow encountered in cast" RuntimeWarning on the user's terminal."""
    values = np.asarray(values)
    if values.dtype != np.float32 and values.size:
        big = np.abs(values) > FLOAT32_MAX
        if big.any():
            values = np.where(big, np.copysign(np.inf, values), values)
    return values.astype(np.float32)


def sanitize(rgb) -> tuple[np.ndarray, int]:
    """Return (a float32 copy with every NaN/Inf channel set to 0,
    the number of pixels affected)."""
    arr = np.array(as_float32(_as_rgb(rgb)), dtype=np.float32, copy=True)
    bad = ~np.isfinite(arr)
    bad_pixels = int(np.count_nonzero(bad.any(axis=2)))
    if bad_pixels:
        arr[bad] = 0.0
    return arr, bad_pixels


def srgb_oetf(linear) -> np.ndarray:
    """The exact piecewise sRGB transfer function (IEC 61966-2-1), float64, no clamping."""
    v = np.asarray(linear, dtype=np.float64)
    return np.where(v <= 0.0031308, 12.92 * v,
                    1.055 * np.power(np.maximum(v, 0.0031308), 1.0 / 2.4) - 0.055)


def to_srgb8(rgb) -> np.ndarray:
    """Blender's Standard view transform to 8 bits: sRGB curve, clamp to [0, 1], round.

    NaN/Inf become 0 first (see sanitize).
    """
    clean, _ = sanitize(rgb)
    encoded = np.clip(srgb_oetf(clean), 0.0, 1.0)
    return np.rint(encoded * 255.0).astype(np.uint8)


def _write_atomic(path, pixels: np.ndarray, typedesc: str, attributes: dict,
                  channel_names=None) -> None:
    import OpenImageIO as oiio

    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise OSError(f"{path}: cannot write image, directory {directory} does not exist")
    with atomic_path(path) as tmp:
        out = oiio.ImageOutput.create(tmp)
        if out is None:
            reason = oiio.geterror().replace(tmp, path) or "unsupported format"
            raise OSError(f"{path}: cannot write image ({reason})")
        height, width, channels = pixels.shape
        spec = oiio.ImageSpec(width, height, channels, typedesc)
        if channel_names is not None:
            spec.channelnames = tuple(channel_names)
            # A channel named A is the alpha (a PNG's RGBA); others are data.
            spec.alpha_channel = list(channel_names).index("A") if "A" in channel_names else -1
        for name, value in attributes.items():
            spec.attribute(name, value)
        ok = out.open(tmp, spec) and out.write_image(pixels)
        err = out.geterror() if not ok else ""
        ok = out.close() and ok
        if not ok:
            reason = (err or out.geterror() or "unknown error").replace(tmp, path)
            raise OSError(f"{path}: cannot write image ({reason})")


def write_exr(path, rgb, channels=None) -> int:
    """Write linear RGB as a 32-bit float EXR (lossless ZIP compression), top row first, plus
    any extra named (H, W) channels, e.g. {"samples": counts}: integer arrays as 32-bit unsigned
    channels (every count to 2^32 - 1 exact), the others as float.

    NaN/Inf in the RGB are written as 0; returns how many pixels that affected.
    """
    clean, bad = sanitize(rgb)
    names = ["R", "G", "B"]
    layers = [clean[..., 0], clean[..., 1], clean[..., 2]]
    for name, values in (channels or {}).items():
        values = _channel_values(name, values)
        if values.shape != clean.shape[:2]:
            raise ValueError(f"channel {name!r}: expected shape {clean.shape[:2]}, "
                             f"got {values.shape}")
        names.append(name)
        layers.append(values)
    _write_exr_atomic(path, dict(zip(names, layers)))
    return bad


UINT32_MAX = 2 ** 32 - 1


def _channel_values(name, values) -> np.ndarray:
    """An extra channel's values as the EXR stores them: integers as uint32, others float32."""
    values = np.asarray(values)
    if values.dtype.kind not in "iu":
        return as_float32(values)
    if values.size and (values.min() < 0 or values.max() > UINT32_MAX):
        raise ValueError(f"channel {name!r}: counts must lie in 0 .. {UINT32_MAX}, "
                         f"got {values.min()} .. {values.max()}")
    return values.astype(np.uint32)


def _write_exr_atomic(path, planes: dict) -> None:
    """Write named (H, W) float32 or uint32 planes as one ZIP-compressed scanline EXR.

    OpenEXR's own bindings, not OpenImageIO's: OpenImageIO's Python ImageOutput takes one buffer
    type for every channel and converts a FLOAT buffer to a UINT channel through float32 (and
    normalised to [0, 1]), so a count of 2^24 + 1 came back as 16777218 and 2^31 - 1 as
    2147483648 (measured with OpenImageIO 3.0.21); OpenEXR writes each array in its own type.
    """
    import OpenEXR

    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise OSError(f"{path}: cannot write image, directory {directory} does not exist")
    if not path.lower().endswith(".exr"):
        raise OSError(f"{path}: cannot write image (an EXR's name ends in .exr)")
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    planes = {name: np.ascontiguousarray(plane) for name, plane in planes.items()}
    with atomic_path(path) as tmp:
        try:
            with OpenEXR.File(header, planes) as exr:
                exr.write(tmp)
        except Exception as exc:    # OpenEXR raises bare Exceptions naming the file it had
            raise OSError(f"{path}: cannot write image ({str(exc).replace(tmp, path)})") from None


def write_png(path, rgb, alpha=None) -> int:
    """Write linear RGB as an 8-bit sRGB PNG (Standard view transform), with an (H, W) alpha
    (the colour premultiplied by it, as the EXR's) as straight alpha when given; returns NaN/Inf
    pixels."""
    clean, bad = sanitize(rgb)
    if alpha is None:
        _write_atomic(path, np.ascontiguousarray(to_srgb8(clean)), "uint8", {})
        return bad
    a = np.clip(np.nan_to_num(as_float32(alpha)), 0.0, 1.0)[..., None]
    # PNG stores straight colour: undo the premultiplication where anything is covered.
    straight = np.where(a > 0.0, clean / np.maximum(a, 1e-12), 0.0)
    pixels = np.concatenate([to_srgb8(straight), np.rint(a * 255.0).astype(np.uint8)], axis=2)
    _write_atomic(path, np.ascontiguousarray(pixels), "uint8", {}, ("R", "G", "B", "A"))
    return bad


def read_exr(path) -> np.ndarray:
    """Read an image's first three channels as an (H, W, 3) float32 array, top row first
    (OpenImageIO puts R, G, B first whatever other channels an EXR holds)."""
    with _opened(path) as (inp, path):
        if inp.spec().nchannels < 3:
            raise OSError(f"{path}: expected RGB, the image has {inp.spec().nchannels} channel(s)")
        return _read(inp, path, 0, 3)


def read_channel(path, name) -> np.ndarray:
    """Read one named channel of an image (e.g. "samples") as an (H, W) array: uint32 for an
    unsigned-integer channel (sample counts, exact), float32 otherwise."""
    import OpenImageIO as oiio

    with _opened(path) as (inp, path):
        spec = inp.spec()
        names = list(spec.channelnames)
        if name not in names:
            raise OSError(f"{path}: no channel {name!r} (it has {', '.join(names)})")
        index = names.index(name)
        if spec.channelformat(index).basetype == oiio.BASETYPE.UINT:
            # Read in the file's own type: OpenImageIO converts UINT to float normalised and
            # through float32 (2^24 + 1 would read as 2^24).
            return _read(inp, path, index, index + 1, "uint")[..., 0]
        return _read(inp, path, index, index + 1)[..., 0]


@contextlib.contextmanager
def _opened(path):
    """(an open OpenImageIO ImageInput, the path as a string), closed afterwards."""
    import OpenImageIO as oiio

    path = os.fspath(path)
    if not os.path.exists(path):
        raise OSError(f"{path}: no such file")
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise OSError(f"{path}: cannot read image ({oiio.geterror() or 'unknown format'})")
    try:
        yield inp, path
    finally:
        inp.close()


def _read(inp, path, begin, end, kind="float") -> np.ndarray:
    """Channels begin .. end - 1 of an open image as an (H, W, end - begin) array of kind
    ("float": float32, "uint": uint32)."""
    spec = inp.spec()
    pixels = inp.read_image(0, 0, begin, end, kind)
    if pixels is None:
        raise OSError(f"{path}: cannot read image ({inp.geterror() or 'unknown error'})")
    dtype = np.uint32 if kind == "uint" else np.float32
    return np.asarray(pixels, dtype=dtype).reshape(spec.height, spec.width, end - begin)
