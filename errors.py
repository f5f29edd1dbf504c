"""User errors and how they reach the user: CliError, the one-line message, argument types.

Every command module (cli.py, compare/commands.py, compare/bench_command.py, ...) imports these
from here; this module imports nothing from the package, so it sits below all of them and the
commands never need to import cli.py (which imports them to dispatch).
"""
from __future__ import annotations

import argparse
import sys

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


def int_at_least(minimum: int):
    """An argparse type: an integer >= minimum, else a usage error naming the value."""
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < minimum:
            raise argparse.ArgumentTypeError(f"expected an integer >= {minimum}, got {text!r}")
        return value
    return parse
