"""Keep Blender's console chatter off our standard output (imports no bpy)."""
from __future__ import annotations

import contextlib
import os
import sys


@contextlib.contextmanager
def stdout_silenced(active: bool = True):
    """Send file descriptor 1 to /dev/null for the duration.

    Blender writes its status lines ("Read blend: ...", "Fra:1 Mem:...", "Saved: ...") straight to
    file descriptor 1, past sys.stdout; its errors still arrive as exceptions.
    """
    if not active:
        yield
        return
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)
