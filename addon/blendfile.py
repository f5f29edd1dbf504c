"""Opening and rendering .blend files for the commands, with one error naming the file.

Blender reports an unreadable file or a failed render as RuntimeError("Error: Loading
\"/abs/path\" failed: ...: Missing DNA block"); the commands turn that into
`<file>: cannot open (Missing DNA block)`.
"""
from __future__ import annotations

import os
import re

from ..errors import CliError, ctrl_c_held


class BlendFileError(CliError):
    """A .blend file Blender cannot open, or cannot render."""


def blender_reason(exc) -> str:
    """The last, specific part of a Blender error message, without the file's path."""
    text = " ".join(str(exc).split())
    text = re.sub(r"^(Error|Warning):\s*", "", text)
    text = re.sub(r"\s*in file \".*?\"", "", text)
    return text.rsplit(": ", 1)[-1].strip() or "unknown error"


def open_blend(path):
    """Open path as Blender's current file; BlendFileError naming it if Blender cannot."""
    import bpy
    if not os.path.isfile(path):
        raise BlendFileError(f"{path}: no such file")
    try:
        # Ctrl-C held: raised inside a load handler (Cycles' version_update), Blender printed
        # its traceback, dropped the handler's work and went on, and the command did not stop.
        with ctrl_c_held():
            bpy.ops.wm.open_mainfile(filepath=os.path.abspath(path))
    except RuntimeError as exc:
        raise BlendFileError(f"{path}: cannot open as a .blend file "
                             f"({blender_reason(exc)})") from None


def render_still(path, renderer="Cycles"):
    """bpy.ops.render.render(write_still=True) of the open file; BlendFileError naming it."""
    import bpy
    try:
        # Ctrl-C held, as in open_blend: raised in the Python a render runs (Cycles' engine, a
        # render handler), Blender printed it and went on, and `compare` ended with exit 0.
        with ctrl_c_held():
            bpy.ops.render.render(write_still=True)
    except RuntimeError as exc:
        raise BlendFileError(f"{path}: {renderer} cannot render it "
                             f"({blender_reason(exc)})") from None
