"""Index helpers for compacting wavefront arrays."""
from __future__ import annotations

import numpy as np


def select(mask: np.ndarray):
    """Indices where mask holds, or a whole slice when it holds everywhere (no gather needed)."""
    return slice(None) if mask.all() else np.flatnonzero(mask)


def count(sel, n: int) -> int:
    """How many of n entries a selection from `select` picks."""
    return n if isinstance(sel, slice) else len(sel)
