"""Keep Blender's console chatter off our standard output (imports no bpy)."""
from __future__ import annotations

import contextlib
import os
import sys
import threading

# One silence for the whole process, however many threads ask for it: descriptor 1 is the
# process's, and two threads each saving and restoring it would, in the order A in, B in, A
# out, B out, leave it on /dev/null for good (B saved A's /dev/null).
_LOCK = threading.Lock()
_silence = {"depth": 0, "saved": None}


@contextlib.contextmanager
def stdout_silenced(active: bool = True):
    """Send file descriptor 1 to /dev/null for the duration.

    Blender writes its status lines ("Read blend: ...", "Fra:1 Mem:...", "Saved: ...") straight to
    file descriptor 1, past sys.stdout; its errors still arrive as exceptions. Nested and
    overlapping silences (from other threads too) end when the last one does.
    """
    if not active:
        yield
        return
    _enter()
    try:
        yield
    finally:
        _leave()


def _flush() -> None:
    if sys.stdout is not None:      # None when the process started with descriptor 1 closed
        with contextlib.suppress(OSError, ValueError):
            sys.stdout.flush()


def _enter() -> None:
    with _LOCK:
        if _silence["depth"] == 0:
            _flush()
            try:
                _silence["saved"] = os.dup(1)
            except OSError:         # descriptor 1 closed: /dev/null takes it for the duration
                _silence["saved"] = None
            null = os.open(os.devnull, os.O_WRONLY)
            if null != 1:
                os.dup2(null, 1)
                os.close(null)
        _silence["depth"] += 1


def _leave() -> None:
    with _LOCK:
        _silence["depth"] -= 1
        if _silence["depth"] == 0:
            _flush()
            saved, _silence["saved"] = _silence["saved"], None
            if saved is None:
                os.close(1)         # closed it was
            else:
                os.dup2(saved, 1)
                os.close(saved)
