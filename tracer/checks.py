"""The checks of a scene's fields that name the field at fault, and SceneError, which they raise.

Below both scene.py (the scene file) and settings.py (the render settings), so that a bad value
reads the same wherever it was written.
"""
from __future__ import annotations

import math


class SceneError(ValueError):
    """A scene file or scene description that cannot be rendered; the message names the field."""


def short(value, limit=60) -> str:
    """repr(value) cut to `limit` characters: a message stays one readable line."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def finite_number(value, name, minimum=None, exclusive=False, maximum=None):
    """value as a float if it is a finite number in range, else a SceneError naming the field."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SceneError(f"{name}: expected a number, got {short(value)}")
    try:
        value = float(value)
    except OverflowError:  # an integer beyond float64
        raise SceneError(f"{name}: out of range ({short(value)})") from None
    if not math.isfinite(value):
        raise SceneError(f"{name}: is NaN or Inf")
    if minimum is not None and (value <= minimum if exclusive else value < minimum):
        raise SceneError(f"{name}: must be {'>' if exclusive else '>='} {minimum}, got {value!r}")
    if maximum is not None and value > maximum:
        raise SceneError(f"{name}: must be <= {maximum}, got {value!r}")
    return value


def int_in(value, name, minimum, maximum, what="integer"):
    """value if it is an integer (not a bool) in [minimum, maximum], else a SceneError naming it."""
    if isinstance(value, bool) or not isinstance(value, int) or not minimum <= value <= maximum:
        raise SceneError(f"{name}: expected {what} from {minimum} to {maximum}, got {short(value)}")
    return value
