#!/usr/bin/env python3
"""Compile Snell's kernels into a cache that ships in the extension: the first render after
installing then loads them instead of compiling them for two minutes.

    .venv/bin/python tools/build_kernel_cache.py OUT [--package bl_ext.user_default.snell ...]

Compiles integrator.warm_up's kernels with this Python (it must be the Python of the Blender the
cache is for: 3.11 for Blender 4.2-5.0) for the generic CPU of this architecture,
once per package name Snell is imported under (Blender imports an extension installed from a
file as bl_ext.user_default.snell; Numba's cache entries hold the name). Writes
OUT/<jit.cache_key_for(jit.generic_target())>/ and prints its size; jit copies that folder, found under tracer/data/kernels
in the installed extension, into the user's cache on first use.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

DEFAULT_PACKAGES = ["bl_ext.user_default.snell"]


def folder_size(path: str) -> int:
    return sum(os.path.getsize(os.path.join(d, f)) for d, _, files in os.walk(path) for f in files)


def build(out: str, packages: list[str]) -> str:
    """Compile the kernels under each package name into out; returns the cache folder."""
    from snell.addon.kernel_warmup import warm_up_command
    from snell.tracer import jit
    if os.path.realpath(os.path.dirname(jit.TRACER_DIR)) != os.path.realpath(ROOT):
        sys.exit(f"build_kernel_cache: this Python imports snell from {jit.TRACER_DIR}, not "
                 f"{ROOT} (set PYTHONPATH)")
    # The generic CPU: the cache serves every machine of this architecture (tracer/jit.py).
    env = dict(os.environ, SNELL_KERNEL_CACHE=os.path.abspath(out), NUMBA_CPU_NAME="generic",
               NUMBA_CPU_FEATURES="")
    with tempfile.TemporaryDirectory() as tmp:
        # The package's folder must bear its last name, as in an installed extension.
        root = os.path.join(tmp, packages[0].rsplit(".", 1)[-1])
        os.symlink(ROOT, root)
        for name in packages:
            print(f"build_kernel_cache: compiling the kernels as {name} (minutes)", flush=True)
            subprocess.run(warm_up_command(name, root), env=env, check=True, cwd=tmp)
    return os.path.join(os.path.abspath(out), jit.cache_key_for(jit.generic_target()))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="the folder the cache is written under")
    parser.add_argument("--package", action="append", dest="packages",
                        help=f"a package name Snell is imported under (default {DEFAULT_PACKAGES})")
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    folder = build(args.out, args.packages or DEFAULT_PACKAGES)
    print(f"build_kernel_cache: {folder}: {folder_size(folder) / 1e6:.1f} MB")


if __name__ == "__main__":
    main()
