#!/usr/bin/env python3
"""Build the Snell Blender extension: one zip per platform in dist/.

    .venv/bin/python tools/build_extension.py [--blender /path/to/blender] [--output-dir dist]

1. Downloads the embreex wheels that blender_manifest.toml lists into wheels/ (unmodified PyPI
   wheels, through `pip download --only-binary=:all: --no-deps`; already present ones are kept).
2. Validates the manifest and builds with `--split-platforms`, using Blender's own extension tool:
   `blender --command extension ...` if --blender is given, else the same tool (bl_pkg's
   blender_ext.py) from the `bpy` module installed in this Python.
3. Compiles the kernels (tools/build_kernel_cache.py, minutes) and adds them to the zip of this
   machine's platform under tracer/data/kernels/, so that an installed extension's first render
   loads them instead of compiling; the other platforms' zips compile on first use.
   --no-kernels leaves them out.
Prints each zip with its size.
"""
from __future__ import annotations

import argparse
import glob
import importlib.util
import os
import platform
import re
import subprocess
import sys
import tempfile
import tomllib
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WHEEL = re.compile(r"(?P<name>[^-]+)-(?P<version>[^-]+)-cp(?P<py>\d)(?P<minor>\d+)-[^-]+-(?P<plat>[^-]+)\.whl$")


def manifest():
    with open(os.path.join(ROOT, "blender_manifest.toml"), "rb") as f:
        return tomllib.load(f)


def download_wheels(wheels):
    os.makedirs(os.path.join(ROOT, "wheels"), exist_ok=True)
    for rel in wheels:
        path = os.path.normpath(os.path.join(ROOT, rel))
        if os.path.isfile(path):
            continue
        m = WHEEL.match(os.path.basename(path))
        if not m:
            sys.exit(f"build_extension: cannot parse wheel name {rel}")
        # A compressed tag set (a.b) names several platforms; the last is a valid --platform.
        platform = m["plat"].split(".")[-1]
        cmd = [sys.executable, "-m", "pip", "download", f"{m['name']}=={m['version']}",
               "--only-binary=:all:", "--no-deps", "--python-version", f"{m['py']}.{m['minor']}",
               "--platform", platform, "--dest", os.path.dirname(path), "--quiet"]
        print("build_extension: downloading", os.path.basename(path), flush=True)
        subprocess.run(cmd, check=True)
        if not os.path.isfile(path):
            sys.exit(f"build_extension: pip did not produce {rel} (the manifest's wheel name "
                     f"must be PyPI's exact file name)")


def extension_tool(blender):
    """The command prefix for Blender's extension tool."""
    if blender:
        return [blender, "--factory-startup", "--command", "extension"]
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        sys.exit("build_extension: needs --blender or the bpy module (pip install 'snell[blender]')")
    found = []
    for location in spec.submodule_search_locations:
        found += glob.glob(os.path.join(location, "*", "scripts", "addons_core", "bl_pkg", "cli",
                                        "blender_ext.py"))
    if not found:
        sys.exit("build_extension: bl_pkg's blender_ext.py not found in the bpy module")
    return [sys.executable, found[0]]


def host_platform() -> str | None:
    """This machine's platform as the manifest names it (None: one it has no zip for)."""
    machine = platform.machine().lower()
    arch = {"x86_64": "x64", "amd64": "x64", "arm64": "arm64", "aarch64": "arm64"}.get(machine)
    system = {"linux": "linux", "darwin": "macos", "win32": "windows"}.get(sys.platform)
    return f"{system}_{arch}" if arch and system else None


def add_kernels(zip_path: str) -> None:
    """Compile the kernels and add them to zip_path under tracer/data/kernels/."""
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import build_kernel_cache
    with tempfile.TemporaryDirectory() as out:
        folder = build_kernel_cache.build(out, build_kernel_cache.DEFAULT_PACKAGES)
        with zipfile.ZipFile(zip_path, "a", zipfile.ZIP_DEFLATED) as z:
            for directory, _, files in os.walk(folder):
                for name in sorted(files):
                    path = os.path.join(directory, name)
                    rel = os.path.relpath(path, out).replace(os.sep, "/")
                    z.write(path, "tracer/data/kernels/" + rel)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--blender", help="a Blender 4.2+ executable (default: the bpy module's tool)")
    parser.add_argument("--output-dir", default=os.path.join(ROOT, "dist"))
    parser.add_argument("--no-kernels", action="store_true",
                        help="leave the compiled kernels out (the first render compiles them)")
    args = parser.parse_args(argv)
    info = manifest()
    download_wheels(info.get("wheels", []))
    tool = extension_tool(args.blender)
    os.makedirs(args.output_dir, exist_ok=True)
    subprocess.run(tool + ["validate", ROOT], check=True)
    subprocess.run(tool + ["build", "--source-dir", ROOT, "--output-dir", args.output_dir,
                           "--split-platforms"], check=True)
    prefix = f"{info['id']}-{info['version']}"
    host = os.path.join(args.output_dir, f"{prefix}-{host_platform()}.zip")
    if not args.no_kernels and os.path.isfile(host):
        add_kernels(host)
    for path in sorted(glob.glob(os.path.join(args.output_dir, prefix + "*.zip"))):
        print(f"build_extension: {path}: {os.path.getsize(path) / 1e6:.1f} MB")


if __name__ == "__main__":
    main()
