"""A render's progress and adaptive sampling in words, for `snell render`, `snell batch` and F12.

They take a RenderResult (tracer/integrator.py) while it renders or when it is done. With adaptive
sampling the integrator's pass count is only an estimate: progress is the samples of the pixels
that sampled longest over the budget, and the share of pixels still sampling.
"""
from __future__ import annotations


def fraction_done(result) -> float:
    """The progress bar's share: samples done over the budget."""
    return min(1.0, result.spp / result.spp_budget) if result.spp_budget else 0.0


def pixels_sampling(result) -> str:
    """'37% of pixels sampling' while adaptive sampling runs, else ''."""
    if result.sample_count is None:
        return ""
    return f"{100.0 * result.active_share:.0f}% of pixels sampling"


def time_left(result, elapsed: float) -> float:
    """Seconds left at the rate so far if every pixel still sampling runs to the budget (an upper
    bound with adaptive sampling, which stops pixels sooner); NaN before the first samples."""
    done = result.spp if result.sample_count is None else float(result.sample_count.mean())
    if done <= 0:
        return float("nan")
    return elapsed * (result.spp_budget - result.spp) * result.active_share / done


def describe_adaptive(result) -> str:
    """'adaptive 0.01: 212 spp mean, 1024 max, 79% of samples saved' for a render that sampled
    adaptively, '' for one that did not."""
    if result.sample_count is None:
        return ""
    return (f"adaptive {result.noise_threshold:g}: {float(result.sample_count.mean()):.0f} spp "
            f"mean, {result.spp} max, {100.0 * result.saved_share:.0f}% of samples saved")
