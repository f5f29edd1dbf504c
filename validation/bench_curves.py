"""The pure-Python half of `snell bench`: error metrics, ladders, curve fits, cache keys, the
JSON, the log-log SVG plot and the HTML page. No bpy (the renders run in addon/bench.py).

Definitions (stated again in bench.json under "definitions"):
- relMSE = mean over pixels and channels of (I - R)^2 / (R^2 + eps), eps = metrics.RELMSE_EPS,
  after dropping the largest metrics.RELMSE_DROP fraction of the per-value terms (fireflies); the
  same rule as `snell compare` (compare/metrics.py).
- RMSE = sqrt(mean((I - R)^2)), no values dropped. FLIP = mean HDR-FLIP (metrics.flip).
- efficiency figure = relMSE x wall time (constant for an unbiased renderer; lower wins).
- time to equal error: per renderer, log(time) is interpolated piecewise-linearly in log(relMSE)
  along the ladder, at the first point where the curve reaches the target; the target is the
  larger of the two renderers' smallest reached relMSE, so both curves reach it.
- as users render: both renderers adaptive at the same noise thresholds; at each threshold,
  Snell's time to Cycles' relMSE along Snell's threshold curve (the same interpolation) over
  Cycles' time, and the plain time and relMSE ratios (equal_threshold).
"""
from __future__ import annotations

import hashlib
import html
import json
import math
import os

import numpy as np

from ..tracer.atomic import atomic_path
from . import metrics

SCHEMA = 1


# ---------------------------------------------------------------------------------------------
# Error metrics against the converged reference


def errors(image, reference) -> dict:
    flip = metrics.flip(reference, image)
    return {"relmse": metrics.relmse(image, reference), "rmse": metrics.rmse(image, reference),
            "flip": float("nan") if flip is None else flip}


def reference_noise(reference, variance_of_mean) -> dict:
    """The reference's own error: the expected relMSE and RMSE its noise alone adds to a point."""
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


def equal_error(snell_points, cycles_points) -> dict:
    """Time-to-equal-error of Snell over Cycles at the larger of the two smallest relMSEs."""
    ts, es = [p["wall_s"] for p in snell_points], [p["relmse"] for p in snell_points]
    tc, ec = [p["wall_s"] for p in cycles_points], [p["relmse"] for p in cycles_points]
    target = max(min(es), min(ec))
    t_s, t_c = time_at_error(ts, es, target), time_at_error(tc, ec, target)
    us, uc = unit_slope_fit(ts, es), unit_slope_fit(tc, ec)
    nan = float("nan")
    return {
        "target_relmse": target,
        "snell_s": nan if t_s is None else t_s,
        "cycles_s": nan if t_c is None else t_c,
        "ratio": nan if not (t_s and t_c) else t_s / t_c,
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
    Cycles' curve (which reaches it, having gone lower), so the ratio is always one of equal error."""
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


def share_map_png(light, reference) -> bytes:
    """A grey PNG of the light tracer's share of the reference per pixel (black 0, white 1)."""
    from ..pages.images import png_bytes
    grey = np.round(np.clip(light_share(light, reference), 0.0, 1.0) * 255).astype(np.uint8)
    return png_bytes(np.repeat(grey[..., None], 3, axis=2))


def efficiency_summary(points) -> dict:
    """relMSE x wall time per point; the median over the ladder and the value at the last point."""
    eff = [p["relmse"] * p["wall_s"] for p in points]
    return {"median": float(np.median(eff)), "last": float(eff[-1])}


# ---------------------------------------------------------------------------------------------
# Reference cache


def cache_key(blend_path, settings: dict, blender_version: str) -> str:
    """sha256 of the .blend bytes, the reference settings (JSON, sorted) and Blender's version."""
    h = hashlib.sha256()
    with open(blend_path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    h.update(json.dumps(settings, sort_keys=True, default=str).encode())
    h.update(blender_version.encode())
    return h.hexdigest()[:32]


def cache_load(directory, key):
    """(mean, variance_of_mean, meta) from the cache, or None."""
    path = os.path.join(directory, f"ref-{key}.npz")
    if not os.path.isfile(path):
        return None
    try:
        with np.load(path) as z:
            meta = json.loads(str(z["meta"]))
            return z["mean"], z["variance_of_mean"], meta
    except (OSError, ValueError, KeyError):
        return None  # a damaged entry is rendered again


def cache_store(directory, key, mean, variance_of_mean, meta):
    os.makedirs(directory, exist_ok=True)
    path = os.path.join(directory, f"ref-{key}.npz")
    with atomic_path(path) as tmp:
        np.savez_compressed(tmp, mean=np.asarray(mean, np.float32),
                            variance_of_mean=np.asarray(variance_of_mean, np.float32),
                            meta=np.array(json.dumps(meta, sort_keys=True, default=str)))
    return path


# ---------------------------------------------------------------------------------------------
# JSON


def _finite(value):
    if isinstance(value, dict):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None  # JSON has no NaN: missing = null
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def missing_values(data, path="") -> list:
    """Paths of null (or non-finite) values in the JSON tree: empty when every key is filled."""
    out = []
    if isinstance(data, dict):
        for k, v in data.items():
            out += missing_values(v, f"{path}.{k}" if path else k)
    elif isinstance(data, list):
        for i, v in enumerate(data):
            out += missing_values(v, f"{path}[{i}]")
    elif data is None or (isinstance(data, float) and not math.isfinite(data)):
        out.append(path)
    return out


def write_json(path, data):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(_finite(data), f, indent=2, sort_keys=True)
    os.replace(tmp, path)


# ---------------------------------------------------------------------------------------------
# Plot: log-log relMSE against wall time, one panel per scene, one polyline per renderer


COLOURS = {"snell": "#d62728", "snell_path_tracer": "#ff9896", "cycles": "#1f77b4"}
LABELS = {"snell": "Snell", "snell_path_tracer": "Snell, path tracer only", "cycles": "Cycles"}


def renderers(scene) -> list:
    """The ladders a bench scene has, in display order."""
    return [r for r in ("snell", "snell_path_tracer", "cycles") if r in scene]


def svg_plot(scenes) -> str:
    """One inline SVG: a log-log panel of relMSE against wall time for each scene."""
    from ..pages.plots import loglog_svg
    return loglog_svg([(sc["name"], [(LABELS[r], COLOURS[r],
                                      [(p["wall_s"], p["relmse"]) for p in sc[r]["points"]])
                                     for r in renderers(sc)]) for sc in scenes],
                      "wall time (s)", "relMSE")


# ---------------------------------------------------------------------------------------------
# HTML


def fmt(x, digits=3):
    """A number for the tables: 3 significant digits, n/a when missing or not finite."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    if isinstance(x, float):
        return f"{x:.{digits}g}"
    return str(x)


def table_rows(data):
    """One row per ladder point (scene, renderer, spp, wall, parts, errors, throughput, memory)."""
    rows = []
    for sc in data["scenes"]:
        for r in renderers(sc):
            snell = r != "cycles"
            for p in sc[r]["points"]:
                parts = (f"export {p['export_s']:.2f} + build {p['build_s']:.2f} + render {p['render_s']:.2f}"
                         if snell else f"load {p['load_s']:.2f} + render {p['render_s']:.2f}")
                rows.append([sc["name"], LABELS[r], p["spp"],
                             f"{p['wall_s']:.2f}", parts, fmt(p["relmse"]),
                             fmt(p.get("caustic_relmse")), fmt(p["rmse"]), fmt(p["flip"]),
                             fmt(p["relmse"] * p["wall_s"]),
                             f"{p['rays_per_second'] / 1e6:.2f} M" if snell else "n/a",
                             f"{100 * p['embree_share']:.0f}%" if snell else "n/a",
                             f"{p['peak_rss_mb']:.0f} ({p['peak_rss_above_baseline_mb']:+.0f})"])
    return rows


HEADER = ["scene", "renderer", "spp", "wall s", "parts (s)", "relMSE", "caustic relMSE", "RMSE",
          "FLIP", "relMSE x s", "rays/s", "Embree share", "peak RSS MB (over baseline)"]


def summary_rows(data):
    rows = []
    for sc in data["scenes"]:
        for r, key in (("snell", "time_to_equal_error"),
                       ("snell_path_tracer", "path_tracer_time_to_equal_error")):
            if key not in sc:
                continue
            eq = sc[key]
            region = sc.get("caustic_region", {})
            gain = sc.get("caustic_gain_at_equal_time", {}).get("median") if r == "snell" else None
            rows.append([sc["name"], LABELS[r], f"{sc['width']}x{sc['height']}",
                         fmt(eq["target_relmse"]), fmt(eq["snell_s"]), fmt(eq["cycles_s"]),
                         fmt(eq["ratio"]), fmt(eq["fit_ratio"]), fmt(eq["snell_slope"]),
                         fmt(eq["cycles_slope"]), fmt(sc[r]["efficiency"]["median"]),
                         fmt(sc["cycles"]["efficiency"]["median"]),
                         fmt(sc["reference"]["noise_relmse"]),
                         f"{100 * region.get('fraction', 0.0):.1f}%", fmt(gain)])
    return rows


SUMMARY_HEADER = ["scene", "Snell", "size", "target relMSE", "Snell s", "Cycles s", "Snell / Cycles",
                  "ratio (slope -1 fits)", "Snell LSQ slope", "Cycles LSQ slope", "Snell relMSE x s (median)",
                  "Cycles relMSE x s (median)", "reference noise relMSE", "caustic region",
                  "caustic relMSE gain at equal time"]


ADAPTIVE_RENDERERS = ("snell", "cycles")


def adaptive_rows(data):
    """One row per "as users render" point, both renderers side by side at each threshold."""
    rows = []
    for sc in data["scenes"]:
        ad = sc.get("adaptive")
        if not ad:
            continue
        by = {r: {p["threshold"]: p for p in ad[r]["points"]} for r in ADAPTIVE_RENDERERS}
        for eq in ad["equal_threshold"]:
            s, c = by["snell"][eq["threshold"]], by["cycles"][eq["threshold"]]
            rows.append([sc["name"], f"{eq['threshold']:g}",
                         f"{s['wall_s']:.2f}", f"{c['wall_s']:.2f}",
                         fmt(s["relmse"]), fmt(c["relmse"]), fmt(s["flip"]), fmt(c["flip"]),
                         f"{s['mean_spp']:.1f}", f"{c['mean_spp']:.1f}",
                         f"{100 * s['saved_share']:.0f}%",
                         "n/a" if c.get("saved_share") is None else f"{100 * c['saved_share']:.0f}%",
                         fmt(eq["ratio"]), fmt(eq["time_ratio"]), fmt(eq["relmse_ratio"])])
    return rows


ADAPTIVE_HEADER = ["scene", "threshold", "Snell s", "Cycles s", "Snell relMSE", "Cycles relMSE",
                   "Snell FLIP", "Cycles FLIP", "Snell mean spp", "Cycles mean spp",
                   "Snell saved", "Cycles saved", "Snell / Cycles at equal error",
                   "time ratio", "relMSE ratio"]


def _table(rows, header):
    out = ["<table><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>"]
    out += ["<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows]
    return "\n".join(out + ["</table>"])


def markdown_table(data) -> str:
    """The per-point and summary tables as Markdown (printed by the CLI, pasted in notes)."""
    def md(rows, header):
        lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
        return "\n".join(lines + ["| " + " | ".join(str(c) for c in r) + " |" for r in rows])
    out = md(summary_rows(data), SUMMARY_HEADER) + "\n\n" + md(table_rows(data), HEADER)
    if adaptive_rows(data):
        out += "\n\n" + md(adaptive_rows(data), ADAPTIVE_HEADER)
    return out


def _share_maps(data, maps):
    """The HTML of each scene's light-tracer share map and caustic-region figures."""
    from ..pages.html_page import data_uri
    out = []
    for sc in data["scenes"]:
        png = (maps or {}).get(sc["name"])
        region = sc.get("caustic_region")
        if png is None or not region:
            continue
        out.append(f"<figure><img src='{data_uri(png)}' width='{2 * sc['width']}'>"
                   f"<figcaption>{html.escape(sc['name'])}: the light tracer carries "
                   f"{100 * region['light_share_of_image']:.1f}% of the image; caustic region "
                   f"(share at least {region['share_threshold']:g}): {region['pixels']} pixels "
                   f"({100 * region['fraction']:.1f}%)</figcaption></figure>")
    if not out:
        return ""
    return ("<h2>The light tracer's share of the image</h2>\n<p class='small'>Per pixel, the "
            "light tracer's image over the reference (black 0, white 1), at the largest Snell "
            "point.</p>\n" + "\n".join(out) + "\n")


def _adaptive_section(data, sample_maps):
    """The HTML of the "as users render" comparison: its table and each scene's sample maps."""
    from ..pages.html_page import data_uri
    rows = adaptive_rows(data)
    if not rows:
        return ""
    figures = []
    for sc in data["scenes"]:
        for r, png in (sample_maps or {}).get(sc["name"], {}).items():
            figures.append(f"<figure><img src='{data_uri(png)}'><figcaption>"
                           f"{html.escape(sc['name'])}: {LABELS[r]}'s samples per pixel at "
                           f"threshold {sc['adaptive']['map_threshold']:g}</figcaption></figure>")
    s, d = data["settings"], data["definitions"]
    return (f"<h2>As users render: adaptive sampling at equal noise thresholds</h2>\n"
            f"<p class='small'>{html.escape(d['as_users_render'])}</p>\n"
            f"{_table(rows, ADAPTIVE_HEADER)}\n"
            f"<p class='small'>{html.escape(d['equal_threshold'])}</p>\n"
            + ("<p class='small'>Samples per pixel (dark: 0, yellow: the cap of "
               f"{s['adaptive_max_spp']}).</p>\n" + "\n".join(figures) + "\n" if figures else ""))


def write_html(path, data, svg, maps=None, sample_maps=None):
    """The bench page; maps: {scene name: PNG of the light tracer's share}; sample_maps: {scene
    name: {renderer: PNG of its samples per pixel}}."""
    from ..pages.html_page import page
    d = data["definitions"]
    s = data["settings"]
    refs = "".join(
        f"<li>{html.escape(sc['name'])}: {sc['reference']['seeds']} Cycles seeds x "
        f"{sc['reference']['spp_per_seed']} spp = {sc['reference']['spp']} spp, "
        f"{sc['reference']['render_s']:.1f} s ({'cached' if sc['reference']['cached'] else 'rendered now'}); "
        f"own noise: relMSE {fmt(sc['reference']['noise_relmse'])}, RMSE {fmt(sc['reference']['noise_rmse'])}</li>"
        for sc in data["scenes"])
    body = (
        f"<h1>Snell vs Cycles: time against error{' (quick)' if data['quick'] else ''}</h1>\n"
        f"<p class='small'>{s['threads']} threads each, max depth {s['max_depth']}, resolution "
        f"{s['resolution_percentage']}% of the file's, ladder {s['min_spp']}, {2 * s['min_spp']}, ... spp up to {s['max_spp']} "
        f"spp or a predicted {s['time_cap_s']:g} s per point.</p>\n"
        f"<h2>Error against wall time</h2>\n{svg}\n"
        f"<h2>Time to equal error</h2>\n{_table(summary_rows(data), SUMMARY_HEADER)}\n"
        f"<p class='small'>{html.escape(d['time_to_equal_error'])}</p>\n"
        f"{_share_maps(data, maps)}"
        f"{_adaptive_section(data, sample_maps)}"
        f"<h2>Ladder points</h2>\n{_table(table_rows(data), HEADER)}\n"
        f"<h2>Definitions</h2><ul>" + "".join(f"<li><b>{html.escape(k)}</b>: {html.escape(v)}</li>"
                                               for k, v in d.items()) + "</ul>\n"
        f"<h2>References</h2><ul>{refs}</ul>\n")
    with open(path, "w") as f:
        f.write(page("snell bench", body))
