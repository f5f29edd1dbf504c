"""User errors and how they reach the user: CliError, the one-line message, argument types.

Every command module (cli.py, validation/commands.py, addon/blendfile.py, ...) imports these
from here; this module imports nothing from the package, so it sits below all of them and the
commands never need to import cli.py (which imports them to dispatch).
"""
from __future__ import annotations

import argparse
import contextlib
import math
import os
import signal
import sys
import tempfile

EXIT_ERROR = 1        # a user error: missing or bad file, bad scene, unwritable output
EXIT_USAGE = 2        # bad options (argparse's status)
EXIT_INTERRUPTED = 130  # Ctrl-C: 128 + SIGINT, as a shell reports it


class CliError(Exception):
    """A user error, reported as one line."""


def one_line(message) -> str:
    """The message with every run of whitespace (newlines included) made one space."""
    return " ".join(str(message).split())


def print_error(message) -> None:
    """Print `snell: error: <message>` as one line on stderr."""
    print(f"snell: error: {one_line(message)}", file=sys.stderr, flush=True)


def warn(message) -> None:
    """Print `snell: warning: <message>` as one line on stderr."""
    print(f"snell: warning: {one_line(message)}", file=sys.stderr)


@contextlib.contextmanager
def ctrl_c_held():
    """Ctrl-C during the block takes effect after it, through the handler there was before.
    For Blender's own work that runs Python (its start-up, opening a file): a KeyboardInterrupt
    raised in there crashed the process or was swallowed by Blender (issue 31 item 9's hunt)."""
    caught = []
    try:
        previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    except ValueError:          # not the main thread, which alone receives signals
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if caught and callable(previous):
            previous(signal.SIGINT, None)


def _at_least(convert, minimum, what, maximum=None):
    """An argparse type: convert(text), finite and >= minimum (and <= maximum if given), else a
    usage error naming it."""
    def parse(text):
        try:
            value = convert(text)
        except ValueError:
            value = None
        if value is None or not math.isfinite(value) or value < minimum:
            raise argparse.ArgumentTypeError(f"expected {what} >= {minimum:g}, got {text!r}")
        if maximum is not None and value > maximum:
            raise argparse.ArgumentTypeError(f"expected {what} <= {maximum}, got {text!r}")
        return value
    return parse


def int_at_least(minimum: int, maximum: int | None = None):
    """An argparse type: an integer >= minimum (and <= maximum), else a usage error naming it."""
    return _at_least(int, minimum, "an integer", maximum)


def number_at_least(minimum: float, maximum: float | None = None):
    """An argparse type: a finite number >= minimum (and <= maximum), else a usage error."""
    return _at_least(float, minimum, "a number", maximum)


# What the atomic writes (tracer/atomic.py) add to a name for their temporary file beside it:
# "." + base + "." + mkstemp's 8 random characters + ".tmp" + the extension; a report's
# directory: "." + name + "." + 8 + ".tmp".
TEMPORARY_EXTRA = len(".." + "x" * 8 + ".tmp")


def check_writable_directory(path: str, option: str, report: bool = False) -> None:
    """CliError unless `path` can be written: its directory exists and takes new files, its name
    (and the temporary name the atomic write gives it first) fits the file system, and `path`
    is not a directory, a device, a FIFO or a socket (for a report, `report=True`: is no file)."""
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        what = "is not a directory" if os.path.exists(directory) else "does not exist"
        raise CliError(f"{option} {path}: directory {directory} {what}")
    if report and os.path.exists(path) and not os.path.isdir(path):
        raise CliError(f"{option} {path}: is a file, expected a directory for the report")
    if not report and os.path.isdir(path):
        raise CliError(f"{option} {path}: is a directory")
    if not report and os.path.exists(path) and not os.path.isfile(path):
        # Writing replaces the path with a new file: never a device node such as /dev/null.
        raise CliError(f"{option} {path}: exists and is not a regular file (a device, FIFO or "
                       "socket); Snell only replaces regular files")
    name = os.fsencode(os.path.basename(os.path.abspath(path)))
    try:
        longest = os.pathconf(directory, "PC_NAME_MAX")
    except (OSError, ValueError):
        longest = 255
    if len(name) + TEMPORARY_EXTRA > longest:
        raise CliError(f"{option} {path}: file name too long ({len(name)} bytes; at most "
                       f"{longest - TEMPORARY_EXTRA} in {directory})")
    # os.access ignores read-only file systems and says yes to root: try what the write will do.
    try:
        fd, probe = tempfile.mkstemp(prefix=".snell-write-test.", dir=directory)
    except OSError as exc:
        raise CliError(f"{option} {path}: cannot write to directory {directory} "
                       f"({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)


def check_input_file(path: str, extensions=(".blend",)) -> None:
    """CliError unless `path` is an existing file with one of the extensions."""
    if os.path.splitext(path)[1].lower() not in extensions:
        raise CliError(f"{path}: expected a {' or '.join(extensions)} file")
    if os.path.isdir(path):
        raise CliError(f"{path}: is a directory, expected a {' or '.join(extensions)} file")
    if os.path.exists(path) and not os.path.isfile(path):
        raise CliError(f"{path}: is not a regular file (a device, FIFO or socket), expected a "
                       f"{' or '.join(extensions)} file")
    if not os.path.isfile(path):
        raise CliError(f"{path}: no such file")
