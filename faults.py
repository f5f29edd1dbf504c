"""A command's last words on a fatal signal: the Python stacks of all its threads.

Snell, Cycles (inside bpy), Embree, OpenImageIO and Numba share one process and its threads; a
crash in any of them (SIGABRT, SIGSEGV, SIGFPE, SIGBUS, SIGILL) would otherwise end the command
with the shell's one word, "Aborted" (issue 31, item 9). While a command runs, Python's
faulthandler writes every thread's stack into a pipe; a small copier process reads it and, if
anything came, writes it under a line naming the command to stderr and, for a command with a
report directory, into FAULT_FILE there. A pipe because faulthandler writes to one file only,
and a process because the crashing one cannot be trusted to copy anything after the signal.
"""
from __future__ import annotations

import contextlib
import faulthandler
import os
import subprocess
import sys

FAULT_FILE = "fatal-error.txt"

# The copier: everything the pipe brings until the command's process is gone (end of file),
# headed by argv[1], to stderr and to the file argv[2] (its directory made: a report directory
# is written whole at the end, so during the command it does not exist yet).
_COPIER = r"""
import os, sys
data = sys.stdin.buffer.read()
if data:
    text = sys.argv[1].encode() + b"\n" + data
    try:
        sys.stderr.buffer.write(text)
        sys.stderr.flush()
    except OSError:
        pass
    if sys.argv[2]:
        try:
            os.makedirs(os.path.dirname(sys.argv[2]), exist_ok=True)
            with open(sys.argv[2], "wb") as f:
                f.write(text)
        except OSError:
            pass
"""


def header(command: str) -> str:
    """The line above the stacks."""
    return (f"snell {command}: crashed on a fatal signal; the Python stacks of all threads "
            "follow (please report them)")


@contextlib.contextmanager
def fault_stacks(command: str, report_dir: str | None = None):
    """While the block runs, a fatal signal writes every thread's Python stack to stderr (and
    to report_dir/FAULT_FILE), under a line naming the command."""
    was_enabled = faulthandler.is_enabled()
    copier = _start_copier(command, report_dir)
    if copier is None:              # no process to copy with: straight to stderr
        target = sys.__stderr__
    else:
        target = copier.stdin
    try:
        faulthandler.enable(file=target, all_threads=True)
    except (AttributeError, ValueError, OSError):    # a stderr with no file descriptor
        target = None
    try:
        yield
    finally:
        if target is not None:
            faulthandler.disable()
        if copier is not None:
            copier.stdin.close()    # end of file: the copier leaves without a word
            with contextlib.suppress(subprocess.TimeoutExpired):
                copier.wait(timeout=2.0)     # it started long ago: a millisecond
        if was_enabled and sys.__stderr__ is not None:   # a caller's own (pytest's)
            with contextlib.suppress(ValueError, OSError, AttributeError):
                faulthandler.enable(file=sys.__stderr__, all_threads=True)


def _start_copier(command: str, report_dir: str | None):
    """The copier process, its stdin the pipe's writing end; None if it cannot start."""
    path = os.path.abspath(os.path.join(report_dir, FAULT_FILE)) if report_dir else ""
    try:
        # Its own session: a Ctrl-C at the terminal must not end it before the command.
        return subprocess.Popen([sys.executable, "-I", "-S", "-c", _COPIER, header(command), path],
                                stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                start_new_session=True)
    except (OSError, ValueError):
        return None
