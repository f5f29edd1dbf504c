"""Small sample windows for tests: the progressive passes and the fixed-sample windows of
tracer/passes.py sized for a test's few pixels."""
from __future__ import annotations

from snell.tracer import passes


def sample_windows(monkeypatch, pixels: int, samples: int, count: int = 1) -> None:
    """Fixed-sample windows of `samples` samples of `pixels` pixels, each `count` passes
    (passes.PASS_PATHS and WINDOW_PASSES; samples a multiple of count)."""
    monkeypatch.setattr(passes, "PASS_PATHS", samples // count * pixels)
    monkeypatch.setattr(passes, "WINDOW_PASSES", count)
