"""The numbers of `snell bench`: error metrics against the reference, the ladder's next step,
the error-against-time curves and their fits, time to equal error, the caustic region. No bpy
(the renders run in bench.py, the JSON, plot and page are bench_report.py's).

Definitions (stated again in bench.json under "definitions"):
- relMSE = mean over pixels and channels of ((I - R)^2 - var) / (N^2 + eps), eps =
  metrics.RELMSE_EPS, after dropping the largest metrics.RELMSE_DROP fraction of the per-value
  terms (fireflies) as `snell compare` does; var is the reference's variance of the mean and N
  the mean of the pixel's neighbours in R (metrics.relmse_against_estimate): the reference is a
  Monte Carlo estimate too, and the plain (I - R)^2 / (R^2 + eps) both counts its noise as the
  image's error and favours images darker than it.
- RMSE = sqrt(mean((I - R)^2)), no values dropped. FLIP = mean HDR-FLIP (metrics.flip).
- efficiency figure = relMSE x wall time (constant for an unbiased renderer; lower wins).
- time to equal error: per renderer, log(time) is interpolated piecewise-linearly in log(relMSE)
  along the ladder, at the first point where the curve reaches the target; the target is the
  larger of the two renderers' smallest reached relMSE, so both curves reach it.
- as users render: both renderers adaptive at the same noise thresholds; at each threshold,
  Snell's time to Cycles' relMSE along Snell's threshold curve (the same interpolation) over
  Cycles' time, and the plain time and relMSE ratios (equal_threshold).
- denoised: the time-to-equal-error rule on both denoised ladders, on relMSE and FLIP (target
  (a), denoised_time_target), and each denoised point's FLIP over the undenoised ladder's at 10
  times its samples (target (b), fewer_samples_target).
"""
from __future__ import annotations

import math

import numpy as np

from . import metrics

# ---------------------------------------------------------------------------------------------
# Error metrics against the converged reference


def errors(image, reference: metrics.Estimate) -> dict:
    """relMSE (its reference noise taken out: metrics.relmse_against_estimate), RMSE and FLIP
    of image against the reference."""
    flip = metrics.flip(reference.mean, image)
    return {"relmse": metrics.relmse_against_estimate(image, reference.mean, reference.var),
            "rmse": metrics.rmse(image, reference.mean),
            "flip": float("nan") if flip is None else flip}


def reference_noise(reference, variance_of_mean) -> dict:
    """The reference's own error: the expected relMSE (R^2 the weight) and RMSE its noise alone
    adds to a point (the bench's relMSE takes it out; its RMSE keeps it)."""
    r = np.asarray(reference, np.float64)
    v = np.asarray(variance_of_mean, np.float64)
    return {"relmse": float(np.mean(v / (r * r + metrics.RELMSE_EPS))),
            "rmse": float(math.sqrt(np.mean(v)))}


# ---------------------------------------------------------------------------------------------
# Ladder and curves


def next_spp(spp: int, wall_s: float, *, max_spp: int, time_cap_s: float):
    """The ladder's next sample count (doubling), or None when it would pass max_spp or, predicted
    as twice this point's wall time, the time cap."""
    nxt = spp * 2
    if nxt > max_spp or 2.0 * wall_s > time_cap_s:
        return None
    return nxt


def median_run(runs: list) -> dict:
    """One point's stats from repeated runs: those of the run with the median wall time (the
    lower one of an even count, so that its parts still add up), with the largest peak memory
    and every run's wall time."""
    ordered = sorted(runs, key=lambda r: r["wall_s"])
    out = dict(ordered[(len(ordered) - 1) // 2])
    out["peak_rss_mb"] = max(r["peak_rss_mb"] for r in runs)
    out["runs"] = len(runs)
    out["wall_s_runs"] = [r["wall_s"] for r in runs]
    return out


def time_at_error(times, errs, target):
    """Seconds at which the log-log curve (points in ladder order) first reaches `target`:
    log t interpolated linearly in log error between the two points around the crossing.
    None if the curve never reaches it."""
    pts = [(float(t), float(e)) for t, e in zip(times, errs) if t > 0 and e > 0]
    if not pts or target <= 0:
        return None
    if pts[0][1] <= target:
        return pts[0][0]  # reached at the first point (no extrapolation to earlier times)
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if e1 <= target:
            if e1 == e0:
                return t1
            f = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
    return None


def sample_summary(counts, cap) -> dict:
    """Mean, smallest and largest samples per pixel of an (H, W) count array, and the share of
    the budget (cap in every pixel) left unused (RenderResult.saved_share's definition)."""
    counts = np.asarray(counts, np.int64)
    mean = float(counts.mean())
    return {"mean_spp": mean, "pixel_spp_min": int(counts.min()),
            "pixel_spp_max": int(counts.max()), "saved_share": 1.0 - mean / cap}


def loglog_fit(times, errs):
    """Least-squares line log(error) = intercept + slope log(time); slope near -1 when unbiased."""
    x = np.log(np.asarray(times, np.float64))
    y = np.log(np.asarray(errs, np.float64))
    if len(x) < 2 or np.ptp(x) == 0:
        return {"slope": float("nan"), "intercept": float(y.mean()) if len(y) else float("nan")}
    slope, intercept = np.polyfit(x, y, 1)
    return {"slope": float(slope), "intercept": float(intercept)}


def unit_slope_fit(times, errs):
    """The least-squares line of slope -1 (an unbiased renderer's): log(error) = a - log(time),
    a = mean(log(error x time)); its time at error e is exp(a) / e."""
    a = float(np.mean(np.log(np.asarray(errs, np.float64) * np.asarray(times, np.float64))))
    return {"slope": -1.0, "intercept": a}


def time_to_equal(snell_points, cycles_points, key="relmse") -> dict:
    """Snell's and Cycles' times to the larger of their two smallest `key` errors along their
    ladders (time_at_error, so both reach it), and Snell / Cycles (NaN where not reached)."""
    ts, es = [p["wall_s"] for p in snell_points], [p[key] for p in snell_points]
    tc, ec = [p["wall_s"] for p in cycles_points], [p[key] for p in cycles_points]
    target = max(min(es), min(ec))
    t_s, t_c = time_at_error(ts, es, target), time_at_error(tc, ec, target)
    nan = float("nan")
    return {"target": target, "snell_s": nan if t_s is None else t_s,
            "cycles_s": nan if t_c is None else t_c,
            "ratio": nan if not (t_s and t_c) else t_s / t_c}


def equal_error(snell_points, cycles_points) -> dict:
    """Time-to-equal-error of Snell over Cycles at the larger of the two smallest relMSEs."""
    ts, es = [p["wall_s"] for p in snell_points], [p["relmse"] for p in snell_points]
    tc, ec = [p["wall_s"] for p in cycles_points], [p["relmse"] for p in cycles_points]
    eq = time_to_equal(snell_points, cycles_points)
    us, uc = unit_slope_fit(ts, es), unit_slope_fit(tc, ec)
    return {
        "target_relmse": eq["target"],
        "snell_s": eq["snell_s"],
        "cycles_s": eq["cycles_s"],
        "ratio": eq["ratio"],
        # free least-squares slopes, to judge the ladder (-1 once fixed costs no longer dominate)
        "snell_slope": loglog_fit(ts, es)["slope"],
        "cycles_slope": loglog_fit(tc, ec)["slope"],
        # slope -1 fits: the ratio of geometric-mean relMSE x time, the same at every target
        "fit_ratio": math.exp(us["intercept"] - uc["intercept"]),
    }


def equal_threshold(snell_points, cycles_points) -> list:
    """At each noise threshold both renderers ran (points with "threshold", "wall_s", "relmse"):
    Snell / Cycles time to equal error, and the plain time and relMSE ratios.

    The target is Cycles' relMSE at the threshold; Snell's time to it is interpolated along
    Snell's threshold curve (time_at_error, loosest threshold first). Where Snell's curve never
    gets that low, the roles swap: Snell's relMSE at the threshold, Cycles' time to it along
    Cycles' curve (which reaches it, having gone lower), so the ratio is always one of equal
    error."""
    def curve(points):
        ordered = sorted(points, key=lambda p: -p["threshold"])
        return [p["wall_s"] for p in ordered], [p["relmse"] for p in ordered]

    ts, es = curve(snell_points)
    tc, ec = curve(cycles_points)
    snell_at = {p["threshold"]: p for p in snell_points}
    out = []
    for c in sorted(cycles_points, key=lambda p: -p["threshold"]):
        s = snell_at.get(c["threshold"])
        if s is None:
            continue
        t_s, t_c, target = time_at_error(ts, es, c["relmse"]), c["wall_s"], c["relmse"]
        along = "snell"
        if t_s is None:
            t_s, target, along = s["wall_s"], s["relmse"], "cycles"
            t_c = time_at_error(tc, ec, target)
        out.append({"threshold": c["threshold"], "target_relmse": target, "along": along,
                    "snell_s": t_s, "cycles_s": t_c, "ratio": t_s / t_c,
                    "time_ratio": s["wall_s"] / c["wall_s"],
                    "relmse_ratio": s["relmse"] / c["relmse"],
                    "mean_spp_ratio": s["mean_spp"] / c["mean_spp"]})
    return out


# The renderers of the "as users render" comparison (both adaptive at the same thresholds).
ADAPTIVE_RENDERERS = ("snell", "cycles")


def nearest_threshold(thresholds, wanted=0.01):
    """The threshold nearest `wanted` in log scale (the summary's and the sample maps' point)."""
    return min(thresholds, key=lambda t: abs(math.log(t / wanted)))


def error_at_time(times, errs, t):
    """The log-log curve's error at time t (linear in log-log between the points around it,
    extended from the nearest two outside them); None without two points."""
    pts = sorted((float(a), float(e)) for a, e in zip(times, errs) if a > 0 and e > 0)
    if len(pts) < 2 or t <= 0:
        return None
    lt = math.log(t)
    i = 1
    while i < len(pts) - 1 and math.log(pts[i][0]) < lt:
        i += 1
    (t0, e0), (t1, e1) = pts[i - 1], pts[i]
    if t1 == t0:
        return e1
    f = (lt - math.log(t0)) / (math.log(t1) - math.log(t0))
    return math.exp(math.log(e0) + f * (math.log(e1) - math.log(e0)))


def gain_at_equal_time(points, other, key) -> dict:
    """How many times lower `key` is in `points` than in `other` at the same wall time: at each
    of `points`, other's error at that time (log-log interpolation, extrapolated from its two
    nearest points outside its range) over this point's. The median is over the points inside
    other's time range, or over all of them when none is."""
    to = [p["wall_s"] for p in other]
    ratios = []
    for p in points:
        e = error_at_time(to, [q[key] for q in other], p["wall_s"])
        if e is not None and p[key] > 0:
            ratios.append({"wall_s": p["wall_s"], "spp": p["spp"], "ratio": e / p[key],
                           "extrapolated": not min(to) <= p["wall_s"] <= max(to)})
    inside = [r["ratio"] for r in ratios if not r["extrapolated"]] or [r["ratio"] for r in ratios]
    return {"key": key, "median": float(np.median(inside)) if inside else 0.0, "points": ratios}


# The caustic region: pixels where the light tracer's image is at least this share of the
# reference (the light that glass and mirrors focus, which a path tracer finds by rare paths).
CAUSTIC_SHARE = 0.1


def light_share(light, reference) -> np.ndarray:
    """The light tracer's image over the reference per pixel (channels summed), (H, W)."""
    return (np.asarray(light, np.float64).sum(axis=2)
            / np.maximum(np.asarray(reference, np.float64).sum(axis=2), 1e-6))


# Issue 34's targets on its caustic scenes (bench_scenes.py), each Snell / Cycles at most: the
# caustic region's relMSE at equal time, and the whole image's time to equal error.
CAUSTIC_RELMSE_TARGET = 0.2
CAUSTIC_TIME_TARGET = 0.5


def caustic_ratio(points, cycles) -> tuple:
    """(Snell / Cycles caustic relMSE at equal time, how it was found): "interpolated" (1 /
    gain_at_equal_time's median); where every Snell point is faster than every Cycles point
    (Cycles' fixed costs), "bound": Snell's slowest point over Cycles' lowest error, an upper
    bound since both errors only fall with time; else "extrapolated" (Cycles' curve extended)."""
    gain = gain_at_equal_time(points, cycles, "caustic_relmse")
    if not all(r["extrapolated"] for r in gain["points"]):
        return (1.0 / gain["median"] if gain["median"] > 0 else float("nan")), "interpolated"
    slowest = max(points, key=lambda p: p["wall_s"])
    if slowest["wall_s"] <= min(p["wall_s"] for p in cycles):
        return slowest["caustic_relmse"] / min(p["caustic_relmse"] for p in cycles), "bound"
    return (1.0 / gain["median"] if gain["median"] > 0 else float("nan")), "extrapolated"


def caustic_targets(scene, ladders=("snell", "snell_without")) -> dict:
    """Issue 34's targets for each of a caustic scene's Snell ladders against its Cycles ladder:
    the caustic region's relMSE at equal time, Snell / Cycles (caustic_ratio), at most
    CAUSTIC_RELMSE_TARGET; the whole image's time to equal error (equal_error's ratio), at most
    CAUSTIC_TIME_TARGET (caustic_ratio says how the first was found). NaN and not met where
    the scene has no caustic region."""
    cycles = scene["cycles"]["points"]
    out = {"caustic_relmse_target": CAUSTIC_RELMSE_TARGET, "time_target": CAUSTIC_TIME_TARGET}
    for key in ladders:
        points = scene[key]["points"]
        eq = equal_error(points, cycles)
        ratio, how = (caustic_ratio(points, cycles)
                      if all("caustic_relmse" in p for p in points + cycles)
                      else (float("nan"), "no caustic region"))
        out[key] = {"caustic_relmse_ratio": ratio, "caustic_how": how,
                    "caustic_extrapolated": how == "extrapolated",
                    "caustic_met": bool(ratio <= CAUSTIC_RELMSE_TARGET),
                    "time_ratio": eq["ratio"], "time_target_relmse": eq["target_relmse"],
                    "time_met": bool(eq["ratio"] <= CAUSTIC_TIME_TARGET)}
    return out


def efficiency_summary(points) -> dict:
    """relMSE x wall time per point; the median over the ladder and the value at the last point."""
    eff = [p["relmse"] * p["wall_s"] for p in points]
    return {"median": float(np.median(eff)), "last": float(eff[-1])}


# ---------------------------------------------------------------------------------------------
# The denoised comparison: both renderers denoised by Open Image Denoise, held against the same
# (undenoised) reference. A denoised image is biased, so its error curve flattens instead of
# falling as 1 / time: only interpolation along the ladder (time_to_equal) is used, no fits.

# Target (a): denoised Snell reaches Cycles + OIDN's denoised error in at most this share of
# Cycles' time. Target (b): Snell denoised at 1 / FEWER_SAMPLES of the samples has a lower FLIP
# than Snell undenoised.
TIME_SHARE_TARGET = 0.5
FEWER_SAMPLES = 10


def denoised_time_target(snell_points, cycles_points) -> dict:
    """Target (a) on relMSE and on FLIP: time_to_equal along the two denoised ladders, whether
    Snell / Cycles is at most TIME_SHARE_TARGET, and at each Cycles point Snell's time to that
    point's error over its time (reached False where Snell's ladder never gets as low)."""
    out = {"share": TIME_SHARE_TARGET}
    for key in ("relmse", "flip"):
        eq = time_to_equal(snell_points, cycles_points, key)
        ts, es = [p["wall_s"] for p in snell_points], [p[key] for p in snell_points]
        each = []
        for c in cycles_points:
            t = time_at_error(ts, es, c[key])
            row = {"spp": c["spp"], "cycles_s": c["wall_s"], "error": c[key],
                   "reached": t is not None}
            if t is not None:
                row.update(snell_s=t, ratio=t / c["wall_s"])
            each.append(row)
        out[key] = {**eq, "met": bool(eq["ratio"] <= TIME_SHARE_TARGET), "at_cycles_points": each}
    out["met"] = out["relmse"]["met"] and out["flip"]["met"]
    return out


def value_at_spp(points, spp, key):
    """`key` at `spp` samples along a ladder: linear in log-log between the two ladder points
    around it; None outside the ladder (never extrapolated)."""
    pts = sorted((p["spp"], p[key]) for p in points if p["spp"] > 0 and p[key] > 0)
    for (n0, e0), (n1, e1) in zip(pts, pts[1:]):
        if n0 <= spp <= n1:
            if n1 == n0:
                return e0
            f = (math.log(spp) - math.log(n0)) / (math.log(n1) - math.log(n0))
            return math.exp(math.log(e0) + f * (math.log(e1) - math.log(e0)))
    if pts and pts[-1][0] == spp:
        return pts[-1][1]
    return None


def fewer_samples_target(denoised_points, noisy_points, factor=FEWER_SAMPLES) -> dict:
    """Target (b): for each denoised point at n spp whose n x factor lies on the noisy ladder,
    its FLIP over the noisy ladder's FLIP at n x factor spp (value_at_spp); met when there is at
    least one such point and every ratio is below 1."""
    rows = []
    for p in denoised_points:
        noisy = value_at_spp(noisy_points, p["spp"] * factor, "flip")
        if noisy is not None:
            rows.append({"spp": p["spp"], "noisy_spp": p["spp"] * factor,
                         "denoised_flip": p["flip"], "noisy_flip": noisy,
                         "ratio": p["flip"] / noisy})
    return {"factor": factor, "points": rows, "evaluated": len(rows),
            "met": bool(rows) and all(r["ratio"] < 1.0 for r in rows)}


def equal_time_pair(snell_points, cycles_points) -> tuple:
    """(Snell index, Cycles index) of the images shown side by side: Cycles' last (most
    converged) point and the Snell point nearest its wall time in log time."""
    j = len(cycles_points) - 1
    t = math.log(cycles_points[j]["wall_s"])
    i = min(range(len(snell_points)), key=lambda k: abs(math.log(snell_points[k]["wall_s"]) - t))
    return i, j


def flip_map(reference, image) -> np.ndarray:
    """Per-pixel HDR-FLIP of image against reference, (H, W); its mean is metrics.flip's."""
    import flip_evaluator
    ref = np.ascontiguousarray(np.clip(np.nan_to_num(reference), 0, None), np.float32)
    tst = np.ascontiguousarray(np.clip(np.nan_to_num(image), 0, None), np.float32)
    if not ref.any() and not tst.any():
        return np.zeros(ref.shape[:2], np.float32)
    error, _, _ = flip_evaluator.evaluate(ref, tst, "HDR", applyMagma=False)
    return np.asarray(error, np.float32).reshape(ref.shape[:2])
