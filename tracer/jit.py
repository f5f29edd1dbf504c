"""How Snell's compiled code is compiled: Numba, without the GIL, cached on disk.

Every scalar physics function and every wavefront kernel is decorated with `jit`. Kernels release
the GIL, so chunks of paths run in parallel on the integrator's own thread pool (not Numba's
parallel=True threading layer, which would load its own TBB or OpenMP next to Blender's and
Embree's). error_model="numpy" makes x / 0 give inf or NaN, as numpy does, instead of raising:
the integrator counts non-finite samples and never writes them to an image.

The compiled machine code is cached on disk: Numba's default (the __pycache__ next to the
sources, or its user-wide cache) unless set_cache_dir() is called before the first kernel module
is imported; inside Blender the add-on points it at the extension's user directory.
"""
from __future__ import annotations

import numba

OPTIONS = {"nogil": True, "cache": True, "error_model": "numpy"}


def jit(fn):
    """Compile fn with Snell's options (nogil, cached, numpy error model)."""
    return numba.njit(**OPTIONS)(fn)


def set_cache_dir(path: str) -> None:
    """Cache compiled kernels under path; call before any kernel module is imported."""
    numba.config.CACHE_DIR = path
