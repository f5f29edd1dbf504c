"""Open Image Denoise (OIDN 2.x) through its C API: the "RT" filter on a rendered image, guided by
the Denoising Albedo and Denoising Normal passes, with Cycles' prefilter modes and quality.

OIDN is loaded with ctypes from a library already on the machine, never downloaded: the one
Blender ships beside its executable (and the `bpy` wheel in its `lib` folder), pyoidn's wheel,
or the system's. The add-on passes Blender's folder (`blender_dirs`); the command line finds the
`bpy` wheel without importing it. Why ctypes on Blender's copy rather than pyoidn: the README's
Dependencies section (measurements in docs/measurements.md#denoising).

Cycles' prefilter modes (intern/cycles/integrator/denoiser_oidn.cpp): none hands the guiding
passes to the filter as they are and tells it they are clean (cleanAux); fast hands them over
noisy (the filter denoises them with the colour); accurate first denoises the albedo and the
normal with filters of their own, then hands them over as clean.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import glob
import importlib.util
import os
import sys
import threading
import time
from typing import NamedTuple

import numpy as np

PREFILTERS = ("none", "fast", "accurate")        # Cycles' denoising_prefilter, lower case
QUALITIES = ("high", "balanced", "fast")         # Cycles' denoising_quality, lower case
# OIDN's enums (oidn.h): device type CPU, image format FLOAT3, quality values.
_DEVICE_CPU = 1
_FORMAT_FLOAT3 = 3
_QUALITY = {"high": 6, "balanced": 5, "fast": 4}
ENV_LIBRARY = "SNELL_OIDN_LIBRARY"    # a path to libOpenImageDenoise, used instead of searching
# OIDN's network darkens images only a few pixels across (a constant 0.5 came out 0.11 at 1x1,
# 0.2 at 1x7, within 1% at 16x16 away from the border): smaller images are denoised padded to
# this size with their edge pixels, then cropped back.
MIN_SIDE = 16


class DenoiseError(Exception):
    """OIDN could not be loaded or failed; the message names what is missing or what failed."""


class Denoised(NamedTuple):
    """A denoised image and what cleaning its inputs took."""
    image: np.ndarray        # (H, W, 3) float32
    nan_guides: int          # pixels of the guiding passes whose NaN/Inf were set to 0
    seconds: float           # time in OIDN (the filters' execution)
    library: str             # the library file used


def _library_names() -> list[str]:
    """The file names OIDN's main library has on this platform."""
    if sys.platform == "win32":
        return ["OpenImageDenoise.dll"]
    if sys.platform == "darwin":
        return ["libOpenImageDenoise.2.dylib", "libOpenImageDenoise.dylib"]
    return ["libOpenImageDenoise.so.2", "libOpenImageDenoise.so"]


def _package_dir(name: str) -> str | None:
    """The folder of an installed package, found without importing it (bpy's import takes
    seconds and the tracer must not import it)."""
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    return list(spec.submodule_search_locations)[0]


def candidate_paths(blender_dirs=()) -> list[str]:
    """Where OIDN's library is looked for: $SNELL_OIDN_LIBRARY alone if set, else in order the
    folders given (Blender's), the `bpy` wheel, pyoidn's wheel, then the system's library path."""
    if os.environ.get(ENV_LIBRARY):
        return [os.environ[ENV_LIBRARY]]
    paths = []
    folders = list(blender_dirs)
    for package, subdirs in (("bpy", ("lib", "blender.shared", ".")), ("pyoidn", ("oidn/lib",
                                                                                   "oidn/bin"))):
        base = _package_dir(package)
        if base:
            folders += [os.path.join(base, sub) for sub in subdirs]
    for folder in folders:
        for name in _library_names():
            paths += sorted(glob.glob(os.path.join(folder, name)))
    system = ctypes.util.find_library("OpenImageDenoise")
    if system:
        paths.append(system)
    return paths


class _Oidn:
    """OIDN's C functions, typed."""

    def __init__(self, path: str):
        self.path = path
        lib = ctypes.CDLL(path)
        vp, cp, sz = ctypes.c_void_p, ctypes.c_char_p, ctypes.c_size_t
        signatures = {
            "oidnNewDevice": (vp, [ctypes.c_int]),
            "oidnSetDeviceInt": (None, [vp, cp, ctypes.c_int]),
            "oidnCommitDevice": (None, [vp]),
            "oidnGetDeviceError": (ctypes.c_int, [vp, ctypes.POINTER(cp)]),
            "oidnReleaseDevice": (None, [vp]),
            "oidnNewFilter": (vp, [vp, cp]),
            "oidnSetSharedFilterImage": (None, [vp, cp, vp, ctypes.c_int, sz, sz, sz, sz, sz]),
            "oidnSetFilterBool": (None, [vp, cp, ctypes.c_bool]),
            "oidnSetFilterInt": (None, [vp, cp, ctypes.c_int]),
            "oidnCommitFilter": (None, [vp]),
            "oidnExecuteFilter": (None, [vp]),
            "oidnReleaseFilter": (None, [vp]),
        }
        for name, (restype, argtypes) in signatures.items():
            try:
                function = getattr(lib, name)
            except AttributeError as exc:
                raise DenoiseError(f"{path}: not an Open Image Denoise 2 library (no {name})") \
                    from exc
            function.restype, function.argtypes = restype, argtypes
            setattr(self, name[4:], function)

    def check(self, device, doing: str):
        """Raise DenoiseError with OIDN's message if the device holds an error."""
        message = ctypes.c_char_p()
        code = self.GetDeviceError(device, ctypes.byref(message))
        if code != 0:
            text = message.value.decode(errors="replace") if message.value else f"error {code}"
            raise DenoiseError(f"Open Image Denoise failed {doing}: {text}")


_loaded: dict = {}
_lock = threading.Lock()


def load(blender_dirs=()) -> _Oidn:
    """OIDN's library (loaded once per process); DenoiseError naming where it was looked for if
    none loads."""
    with _lock:
        if "oidn" in _loaded:
            return _loaded["oidn"]
        tried = []
        for path in candidate_paths(blender_dirs):
            try:
                _loaded["oidn"] = _Oidn(path)
                return _loaded["oidn"]
            except (OSError, DenoiseError) as exc:
                tried.append(f"{path} ({exc})")
        where = "; ".join(tried) if tried else "none found"
        raise DenoiseError(
            "Open Image Denoise (libOpenImageDenoise 2.x) is not available: it ships with Blender "
            "and the bpy wheel (pip install 'snell[blender]'), or set "
            f"{ENV_LIBRARY}=/path/to/{_library_names()[0]} (tried: {where})")


def clean_guide(values) -> tuple[np.ndarray, int]:
    """A guiding pass as contiguous float32 with NaN/Inf set to 0, and how many pixels had any."""
    arr = np.array(values, dtype=np.float32, copy=True, order="C")
    bad = ~np.isfinite(arr)
    count = int(np.count_nonzero(bad.reshape(arr.shape[0], arr.shape[1], -1).any(axis=2)))
    arr[bad] = 0.0
    return arr, count


def _as_oidn_sees(color, guides: dict):
    """(colour, guides, back) as OIDN is handed them: rows bottom first, as Cycles' render buffer
    holds them, and padded to MIN_SIDE a side with edge pixels; back(output) undoes both."""
    # OIDN's network is not symmetric under a vertical flip: the same image handed over top row
    # first came out 2-2.5% (mean |difference| / mean) off Cycles' own denoised image
    # (tests/validation/test_denoise_call_matches_cycles.py).
    arrays = [color[::-1]] + [v[::-1] for v in guides.values()]
    crop = (slice(None), slice(None))
    if min(color.shape[:2]) < MIN_SIDE:
        pads = [((MIN_SIDE - n + 1) // 2 if n < MIN_SIDE else 0) for n in color.shape[:2]]
        crop = tuple(slice(p, p + n) for p, n in zip(pads, color.shape[:2]))
        widths = [(p, max(MIN_SIDE - n - p, 0)) for p, n in zip(pads, color.shape[:2])] + [(0, 0)]
        arrays = [np.pad(a, widths, mode="edge") for a in arrays]
    arrays = [np.ascontiguousarray(a) for a in arrays]
    return (arrays[0], dict(zip(guides, arrays[1:])),
            lambda output: np.ascontiguousarray(output[crop][::-1]))


def denoise(color, albedo=None, normal=None, prefilter: str = "accurate",
            quality: str = "high", threads: int = 0, blender_dirs=()) -> Denoised:
    """Denoise an (H, W, 3) linear HDR image, guided by the albedo (and normal, which needs the
    albedo) passes, with Cycles' prefilter mode and OIDN's quality. Raises DenoiseError."""
    if prefilter not in PREFILTERS:
        raise ValueError(f"denoise: prefilter {prefilter!r} is not one of {', '.join(PREFILTERS)}")
    if quality not in QUALITIES:
        raise ValueError(f"denoise: quality {quality!r} is not one of {', '.join(QUALITIES)}")
    if normal is not None and albedo is None:
        raise ValueError("denoise: OIDN takes a normal pass only with an albedo pass")
    color, _ = clean_guide(color)
    if color.ndim != 3 or color.shape[2] != 3:
        raise ValueError(f"denoise: expected an (H, W, 3) image, got shape {color.shape}")
    nan_guides = 0
    guides = {}
    for name, values in (("albedo", albedo), ("normal", normal)):
        if values is not None:
            guides[name], bad = clean_guide(values)
            if guides[name].shape != color.shape:
                raise ValueError(f"denoise: the {name} pass has shape {guides[name].shape}, "
                                 f"the image {color.shape}")
            nan_guides += bad
    oidn = load(blender_dirs)
    color, guides, back = _as_oidn_sees(color, guides)
    height, width, _ = color.shape
    output = np.zeros_like(color)
    device = oidn.NewDevice(_DEVICE_CPU)
    if not device:
        raise DenoiseError("Open Image Denoise could not create a CPU device")
    filters = []
    start = time.perf_counter()
    try:
        if threads > 0:
            oidn.SetDeviceInt(device, b"numThreads", int(threads))
        oidn.CommitDevice(device)
        oidn.check(device, "creating its device")

        def run(inputs: dict, out: np.ndarray, clean_aux: bool):
            """One RT filter over `inputs` ({OIDN image name: array}) into `out`."""
            flt = oidn.NewFilter(device, b"RT")
            filters.append(flt)
            for name, arr in list(inputs.items()) + [("output", out)]:
                oidn.SetSharedFilterImage(flt, name.encode(), arr.ctypes.data, _FORMAT_FLOAT3,
                                          width, height, 0, 12, 12 * width)
            # The colour is HDR; an albedo or normal filtered alone is not (OIDN's docs).
            oidn.SetFilterBool(flt, b"hdr", "color" in inputs)
            oidn.SetFilterBool(flt, b"cleanAux", clean_aux)
            oidn.SetFilterInt(flt, b"quality", _QUALITY[quality])
            oidn.CommitFilter(flt)
            oidn.check(device, "setting up a filter")
            oidn.ExecuteFilter(flt)
            oidn.check(device, "denoising")

        if prefilter == "accurate":
            for name in list(guides):
                filtered = np.zeros_like(color)
                run({name: guides[name]}, filtered, False)
                guides[name] = filtered
        run({"color": color, **guides}, output, prefilter != "fast")
    finally:
        for flt in filters:
            oidn.ReleaseFilter(flt)
        oidn.ReleaseDevice(device)
    seconds = time.perf_counter() - start
    output = back(output)
    output, _ = clean_guide(output)
    return Denoised(output, nan_guides, seconds, oidn.path)


class Outcome(NamedTuple):
    """A render's image after denoising (or its noisy image, when OIDN could not run) and the
    layers written beside it."""
    image: np.ndarray                # what to show: denoised, or the noisy image
    noisy: np.ndarray                # the render's own (noisy) image, float32 (H, W, 3)
    albedo: np.ndarray | None        # the Denoising Albedo pass (None: not rendered)
    normal: np.ndarray | None        # the Denoising Normal pass, camera space
    denoised: bool
    warning: str                     # what the user should know ("": nothing)
    nan_guides: int                  # guiding-pass samples and pixels whose NaN/Inf were left out
    seconds: float


def denoise_result(result, settings, blender_dirs=()) -> Outcome:
    """Denoise a RenderResult with its settings' input passes, prefilter and quality; if OIDN
    cannot run, the noisy image and a warning saying why (a missing or failing OIDN is never an
    exception)."""
    noisy = result.mean()
    has = getattr(result, "has_features", False)
    albedo = result.denoising_albedo() if has else None
    normal = result.denoising_normal() if has else None
    nan = result.feature_nan_count if has else 0
    wanted = settings.denoising_input_passes
    warning = ""
    if wanted != "color" and not has:
        warning = "denoised from the image alone: this render made no denoising passes"
    try:
        out = denoise(noisy, albedo if wanted != "color" else None,
                      normal if wanted == "albedo_normal" else None,
                      settings.denoising_prefilter, settings.denoising_quality,
                      settings.render_threads, blender_dirs)
    except DenoiseError as exc:
        return Outcome(noisy, noisy, albedo, normal, False,
                       f"{exc}; the image is written undenoised", nan, 0.0)
    return Outcome(out.image, noisy, albedo, normal, True, warning, nan + out.nan_guides,
                   out.seconds)
