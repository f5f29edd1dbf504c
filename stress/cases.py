"""The cases of `snell stress`: what a case is, how its outcome is measured, and the matrix.

The cases themselves live by group: glass.py (white furnaces, slabs, nested and degenerate
surfaces), lens.py (thin lens), lights.py (lamps) and extremes.py (image sizes, peak memory). A
case renders one or more tracer Scenes (built in Python, no bpy) and returns an Outcome: the
measured value and what bounds its error. Four kinds of check (stress/runner.py applies them):

- exact: every sample has a known value (a white furnace: exactly 1). The only error allowed is
  float rounding (`tolerance`) plus `allowance`, the share of samples the integrator itself
  counted as ended early (stats: total internal reflection under a refraction-only BSDF,
  samples rejected by Cycles' shading-normal rules, paths cut by the depth limit): each such
  event turns exactly one sample of 1 into 0, so the deficit must equal their count / N.
- statistical: a Monte Carlo estimate; its standard error comes from the samples' own variance
  (the independent sampler, so that per-pixel variances are honest), and the runner allows
  z * SE with z Sidak-corrected over all statistical cases.
- at most: a one-sided bound (peak memory, samples that differ from a reference).
- not supported: the feature does not exist; the table says so instead of faking a result.

The analytic values are computed here independently of the tracer's own code (a textbook
Fresnel, not tracer/specular.py): a shared formula would make a wrong formula pass.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..tracer.integrator import Renderer
from .geometry import WHITE

EXACT, STATISTICAL, AT_MOST, UNSUPPORTED = "exact", "statistical", "at most", "not supported"
UNIT_ROUNDING = 2.0 ** -53
ENDED_EVENTS = ("tir_absorbed", "rejected", "depth_limited")   # each ends one sample at 0


@dataclass
class Outcome:
    """What one case measured, and the deterministic parts of its error bound."""
    measured: float
    se: float | None = None       # standard error of `measured` (statistical checks)
    tolerance: float = 0.0        # float rounding (exact checks)
    allowance: float = 0.0        # counted events (exact) or slack (at most)
    events: int = 0               # counted early ends behind the allowance
    nan_count: int = 0            # NaN/Inf samples over all renders of the case
    image: np.ndarray | None = None      # (H, W, 3) linear, for the report
    error_map: np.ndarray | None = None  # (H, W) signed error, for the report
    error_label: str = "error map"
    note: str = ""
    settings: dict = field(default_factory=dict)


@dataclass
class Case:
    """One stress case: what it measures, its analytic value and how to run it."""
    id: str
    group: str
    measures: str
    failure_means: str
    check: str
    analytic: float
    run: Callable[[int, int], Outcome] | None   # (threads, seed) -> Outcome
    quick: bool = False
    expected_failure: str = ""     # why this case is known to fail (shown in the table)


# ---------------------------------------------------------------------------------------------
# Analytic values


def fresnel_unpolarised(cos_i: float, n: float) -> float:
    """Reflectance of a smooth dielectric for unpolarised light from the outside
    (textbook s/p form)."""
    sin2_t = (1.0 - cos_i * cos_i) / (n * n)
    if sin2_t >= 1.0:
        return 1.0
    cos_t = math.sqrt(1.0 - sin2_t)
    rs = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    rp = (cos_t - n * cos_i) / (cos_t + n * cos_i)
    return 0.5 * (rs * rs + rp * rp)


def slab_transmission(f: float, max_depth: int | None) -> float:
    """Light through a lossless slab, each face reflecting f (the same from both sides, Stokes):
    (1 - f)^2 sum_k f^2k over the paths that fit in max_depth bounces (2 + 2k bounces for k
    internal round trips); None is the limit (1 - f) / (1 + f)."""
    if max_depth is None:
        return (1.0 - f) / (1.0 + f)
    trips = (max_depth - 2) // 2
    return sum((1.0 - f) ** 2 * f ** (2 * k) for k in range(trips + 1)) if max_depth >= 2 else 0.0


# ---------------------------------------------------------------------------------------------
# Rendering and measuring


def render(scn, threads, seed):
    """Render a case's scene with its seed and the independent sampler (honest variances)."""
    return Renderer(scn, scn.settings(seed=seed, threads=threads, sampler="independent")).render()


def settings_of(scn):
    """The render settings a table row shows."""
    w, h = scn.camera["resolution"]
    return {"resolution": f"{w}x{h}", "spp": scn.render["spp"],
            "max_depth": scn.render["max_depth"]}


def image_mean(result):
    """Mean of channel 0 over all samples and its standard error (pixels are independent)."""
    npix = result.width * result.height
    mean = float(result.sum[..., 0].sum()) / (npix * result.spp)
    se = math.sqrt(float(result.variance_of_mean()[..., 0].sum())) / npix
    return mean, se


Z_LABEL = "per-pixel z: (pixel - analytic) / its standard error"


def z_map(result, expected):
    """Per-pixel (pixel - expected) / its standard error; +-99 where a pixel has no variance."""
    var = result.variance_of_mean()[..., 0]
    diff = result.mean()[..., 0] - expected
    return np.where(var > 0, diff / np.sqrt(np.where(var > 0, var, 1.0)), np.sign(diff) * 99.0)


def furnace_outcome(result, scn, note=""):
    """An exact white-furnace outcome: the mean of all samples against 1, counted ends allowed."""
    n = result.width * result.height * result.spp
    # Every sample is a product of weights of exactly 1, hence exactly 0 or 1, and the float64
    # sums of integers below 2^53 are exact; the tolerance bounds the rounding anyway: one
    # product rounding per bounce plus one per addition.
    measured = float(result.sum[..., 0].sum()) / n
    events = sum(int(result.stats.get(k, 0)) for k in ENDED_EVENTS)
    tolerance = (scn.render["max_depth"] + 2 + n) * UNIT_ROUNDING
    channels_equal = np.array_equal(result.sum[..., 0], result.sum[..., 2])
    img = result.mean()
    return Outcome(measured=measured if channels_equal else math.nan, tolerance=tolerance,
                   allowance=events / n, events=events, nan_count=result.nan_count, image=img,
                   error_map=img[..., 0] - 1.0, error_label="image - 1", settings=settings_of(scn),
                   note=(note + "; " if note else "") + events_note(result.stats))


def events_note(stats):
    """The counted early ends, for the table's note."""
    parts = [f"{k} {stats.get(k, 0)}" for k in ENDED_EVENTS if stats.get(k, 0)]
    return "ended early: " + (", ".join(parts) if parts else "none")


LOSSLESS = ("mirror", "glass", "refraction")


def material(kind, ior=1.5):
    """A white mirror, glass or refraction-only material."""
    mat = {"name": kind, "kind": kind, "color": WHITE}
    if kind != "mirror":
        mat["ior"] = float(ior)
    return mat
