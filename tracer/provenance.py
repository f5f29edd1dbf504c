"""What made a result: Snell's version and commit, Blender's version and the machine.

`snell --version` prints it and every report (compare, study, false-alarms, bench, stress; JSON
and HTML) records it, so a number can be traced to the code and the machine that produced it.
Never imports bpy: Blender's version comes from a bpy already imported, else from its wheel's
metadata (the `bpy` module), else it is None.
"""
from __future__ import annotations

import functools
import os
import platform
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@functools.cache
def snell_version() -> str:
    """The version in blender_manifest.toml (pyproject.toml's is the same, tests/unit checks)."""
    try:
        import tomllib
        with open(os.path.join(ROOT, "blender_manifest.toml"), "rb") as f:
            return str(tomllib.load(f)["version"])
    except (OSError, KeyError, ValueError, ImportError):
        return "unknown"


@functools.cache
def snell_commit() -> str | None:
    """The git commit of the checkout Snell runs from (with "+dirty" if it has changes), or None
    when it is not a git checkout (an installed extension) or git is missing."""
    def git(*args):
        return subprocess.run(["git", "-C", ROOT, *args], capture_output=True, text=True,
                              timeout=10, check=True).stdout.strip()
    try:
        if git("rev-parse", "--show-toplevel") != os.path.realpath(ROOT):
            return None     # Snell installed inside some other repository's tree
        commit = git("rev-parse", "--short=12", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None
    return commit + ("+dirty" if dirty else "")


def blender_version() -> str | None:
    """Blender's version: the running bpy's, else the installed bpy module's, else None."""
    bpy = sys.modules.get("bpy")
    if bpy is not None and hasattr(bpy, "app"):
        return bpy.app.version_string
    try:
        from importlib import metadata
        return metadata.version("bpy")
    except Exception:   # noqa: BLE001 - metadata raises PackageNotFoundError and worse
        return None


def machine() -> dict:
    """The machine: OS, architecture, processor and logical cores."""
    return {"os": platform.platform(terse=True), "arch": platform.machine(),
            "processor": _processor(), "cpu_count": os.cpu_count(),
            "python": platform.python_version()}


def _processor() -> str:
    """The processor's model name (Linux leaves platform.processor() empty; /proc/cpuinfo has it),
    else the architecture."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def provenance() -> dict:
    """Everything above, as a report's "provenance" object."""
    return {"snell": snell_version(), "commit": snell_commit(), "blender": blender_version(),
            "machine": machine()}


def describe(record: dict | None = None) -> str:
    """One line of it: `Snell 0.1.0 (commit abc123), Blender 5.0.1, Linux x86_64, 2 cores`."""
    p = record or provenance()
    m = p["machine"]
    commit = f" (commit {p['commit']})" if p["commit"] else ""
    blender = f"Blender {p['blender']}" if p["blender"] else "no Blender"
    return f"Snell {p['snell']}{commit}, {blender}, {m['os']} {m['arch']}, {m['cpu_count']} cores"
