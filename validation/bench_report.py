"""What `snell bench` writes and prints: bench.json, the log-log plot (bench.svg), the tables (HTML
and Markdown) and bench.html. No bpy (the runs are bench.py's, the numbers bench_curves.py's).
"""
from __future__ import annotations

import html
import json
import math
import os

import numpy as np

from ..pages.html_page import data_uri, page
from ..pages.images import png_bytes, text_label, upscale
from ..pages.plots import loglog_svg
from ..pages.sample_map import ramp
from ..tracer.image import to_srgb8
from ..tracer.provenance import provenance
from .bench_curves import ADAPTIVE_RENDERERS, light_share

SCHEMA = 1


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
        json.dump(_finite({**data, "provenance": provenance()}), f, indent=2, sort_keys=True)
    os.replace(tmp, path)


# ---------------------------------------------------------------------------------------------
# Plot: log-log relMSE against wall time, one panel per scene, one polyline per renderer


COLOURS = {"snell": "#d62728", "snell_path_tracer": "#ff9896", "snell_without": "#ff9896",
           "cycles": "#1f77b4", "snell_denoised": "#7a0a0a", "cycles_denoised": "#0a2f5c"}
LABELS = {"snell": "Snell", "snell_path_tracer": "Snell, path tracer only",
          "snell_without": "Snell without the new strategy", "cycles": "Cycles",
          "snell_denoised": "Snell + OIDN", "cycles_denoised": "Cycles + OIDN"}
LADDERS = ("snell", "snell_path_tracer", "snell_without", "cycles", "snell_denoised",
           "cycles_denoised")


def renderers(scene) -> list:
    """The ladders a bench scene has, in display order."""
    return [r for r in LADDERS if r in scene]


def is_snell(ladder) -> bool:
    """Whether a ladder is one of Snell's (its points have Snell's timings and counters)."""
    return ladder.startswith("snell")


def svg_plot(scenes, key="relmse", label="relMSE") -> str:
    """One inline SVG: a log-log panel of `key` against wall time for each scene."""
    return loglog_svg([(sc["name"], [(LABELS[r], COLOURS[r],
                                      [(p["wall_s"], p[key]) for p in sc[r]["points"]])
                                     for r in renderers(sc)]) for sc in scenes],
                      "wall time (s)", label)


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
            snell = is_snell(r)
            for p in sc[r]["points"]:
                parts = (f"export {p['export_s']:.2f} + build {p['build_s']:.2f} "
                         f"+ render {p['render_s']:.2f}"
                         if snell else f"load {p['load_s']:.2f} + render {p['render_s']:.2f}")
                if "denoise_s" in p:
                    parts += f" + denoise {p['denoise_s']:.2f}"
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


SUMMARY_HEADER = ["scene", "Snell", "size", "target relMSE", "Snell s", "Cycles s",
                  "Snell / Cycles", "ratio (slope -1 fits)", "Snell LSQ slope", "Cycles LSQ slope",
                  "Snell relMSE x s (median)",
                  "Cycles relMSE x s (median)", "reference noise relMSE", "caustic region",
                  "caustic relMSE gain at equal time"]


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
                         ("n/a" if c.get("saved_share") is None
                          else f"{100 * c['saved_share']:.0f}%"),
                         fmt(eq["ratio"]), fmt(eq["time_ratio"]), fmt(eq["relmse_ratio"])])
    return rows


ADAPTIVE_HEADER = ["scene", "threshold", "Snell s", "Cycles s", "Snell relMSE", "Cycles relMSE",
                   "Snell FLIP", "Cycles FLIP", "Snell mean spp", "Cycles mean spp",
                   "Snell saved", "Cycles saved", "Snell / Cycles at equal error",
                   "time ratio", "relMSE ratio"]


def denoised_rows(data):
    """One row per scene of the denoised comparison: targets (a) and (b), measured."""
    rows = []
    for sc in data["scenes"]:
        dn = sc.get("denoised")
        if not dn:
            continue
        a, b = dn["time_target"], dn["fewer_samples_target"]
        ratios = [r["ratio"] for r in b["points"]]
        rows.append([sc["name"], f"{sc['width']}x{sc['height']}",
                     fmt(a["relmse"]["target"]), fmt(a["relmse"]["snell_s"]),
                     fmt(a["relmse"]["cycles_s"]), fmt(a["relmse"]["ratio"]),
                     fmt(a["flip"]["target"]), fmt(a["flip"]["ratio"]),
                     "met" if a["met"] else "not met",
                     (f"{fmt(min(ratios))}-{fmt(max(ratios))} ({len(ratios)} points)"
                      if ratios else "n/a (no point)"),
                     "met" if b["met"] else "not met"])
    return rows


DENOISED_HEADER = ["scene", "size", "target relMSE (denoised)", "Snell + OIDN s",
                   "Cycles + OIDN s", "Snell / Cycles (relMSE)", "target FLIP (denoised)",
                   "Snell / Cycles (FLIP)", "(a) at most 0.5", "(b) FLIP denoised at n / "
                   "undenoised at 10 n", "(b) below 1"]


def caustic_rows(data):
    """One row per caustic scene (bench_scenes.py): issue 34's targets for Snell and for Snell
    without the new strategy, each against Cycles as users would set it up."""
    rows = []
    for sc in data["scenes"]:
        ct = sc.get("caustic_targets")
        if not ct:
            continue
        setup = ct["setup"]
        s, w = ct["snell"], ct["snell_without"]
        rows.append([sc["name"], setup["strategy"] + (" (biased: its error includes bias)"
                                                      if setup["biased"] else ""),
                     f"{sc['width']}x{sc['height']}", sc["reference"]["renderer"],
                     fmt(sc["caustic_region"].get("reference_noise_relmse")),
                     "on" if setup["guiding"] else "off",
                     _caustic_ratio(s), "met" if s["caustic_met"] else "not met",
                     fmt(s["time_ratio"]), "met" if s["time_met"] else "not met",
                     _caustic_ratio(w), fmt(w["time_ratio"])])
    return rows


def _caustic_ratio(figures) -> str:
    """The caustic relMSE ratio, marked where it is a bound or Cycles' curve was extrapolated."""
    how = figures.get("caustic_how", "interpolated")
    return fmt(figures["caustic_relmse_ratio"]) + ("" if how == "interpolated" else
                                                   " (at most)" if how == "bound" else f" ({how})")


CAUSTIC_HEADER = ["scene", "Snell's new strategy", "size", "reference",
                  "reference's own caustic relMSE", "Cycles path guiding",
                  "caustic relMSE at equal time, Snell / Cycles", "(at most 0.2)",
                  "time to equal error, Snell / Cycles", "(at most 0.5)",
                  "without: caustic relMSE ratio", "without: time ratio"]


def _caustic_section(data, figures):
    """The HTML of the caustic scenes: their targets' table, setups and equal-time images."""
    rows = caustic_rows(data)
    if not rows:
        return ""
    d = data["definitions"]
    out = [f"<h2>Caustic scenes (issue 34)</h2>\n<p class='small'>"
           f"{html.escape(d['caustic_targets'])}</p>\n{_table(rows, CAUSTIC_HEADER)}"]
    for sc in data["scenes"]:
        ct = sc.get("caustic_targets")
        if not ct:
            continue
        setup, e = ct["setup"], ct["equal_time"]
        cycles_set = "; ".join(f"{k} = {v} ({why})" for k, v, why in setup["cycles_settings"])
        caption = (f"{sc['name']} at equal time: reference ({sc['reference']['renderer']}: "
                   f"{sc['reference']['why']}); Snell ({setup['strategy']}) {e['snell']['spp']} "
                   f"spp, {e['snell']['wall_s']:.2f} s; {setup['without_label']} "
                   f"{e['snell_without']['spp']} spp, {e['snell_without']['wall_s']:.2f} s; "
                   f"Cycles {e['cycles']['spp']} spp, {e['cycles']['wall_s']:.2f} s "
                   f"({cycles_set})")
        png = (figures or {}).get(sc["name"])
        img = f"<img src='{data_uri(png)}'>" if png else ""
        out.append(f"<figure>{img}<figcaption>{html.escape(caption)}</figcaption></figure>")
    return "\n".join(out) + "\n"


def _table(rows, header):
    out = ["<table><tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>"]
    out += ["<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>"
            for row in rows]
    return "\n".join(out + ["</table>"])


def markdown_table(data) -> str:
    """The per-point and summary tables as Markdown (printed by the CLI, pasted in notes)."""
    def md(rows, header):
        lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
        return "\n".join(lines + ["| " + " | ".join(str(c) for c in r) + " |" for r in rows])
    out = md(summary_rows(data), SUMMARY_HEADER) + "\n\n" + md(table_rows(data), HEADER)
    if caustic_rows(data):
        out += "\n\n" + md(caustic_rows(data), CAUSTIC_HEADER)
    if adaptive_rows(data):
        out += "\n\n" + md(adaptive_rows(data), ADAPTIVE_HEADER)
    if denoised_rows(data):
        out += "\n\n" + md(denoised_rows(data), DENOISED_HEADER)
    return out


FLIP_SCALE = 0.5   # the FLIP maps' colour scale: 0 (dark) to this value and above (yellow)


def flip_map_rgb(values) -> np.ndarray:
    """A per-pixel FLIP map on the viridis ramp, 0 to FLIP_SCALE, uint8 (H, W, 3)."""
    return ramp(np.asarray(values, np.float64) / FLIP_SCALE)


def denoised_figures_png(reference, snell, cycles, maps, equal_time) -> dict:
    """PNGs of the denoised pair at equal time: {"reference", "snell", "cycles", "snell_flip",
    "cycles_flip"} each alone, and "strip": the five side by side under labels."""
    width = 256
    tiles = {"reference": to_srgb8(reference), "snell": to_srgb8(snell),
             "cycles": to_srgb8(cycles), "snell_flip": flip_map_rgb(maps["snell"]),
             "cycles_flip": flip_map_rgb(maps["cycles"])}
    tiles = {k: upscale(v, width) for k, v in tiles.items()}
    e = equal_time
    captions = {"reference": "reference (undenoised)",
                "snell": f"Snell+OIDN {e['snell_spp']} spp {e['snell_s']:.1f} s",
                "snell_flip": f"Snell FLIP {e['snell_flip']:.3f}",
                "cycles": f"Cycles+OIDN {e['cycles_spp']} spp {e['cycles_s']:.1f} s",
                "cycles_flip": f"Cycles FLIP {e['cycles_flip']:.3f}"}
    order = ("reference", "snell", "snell_flip", "cycles", "cycles_flip")
    out = {k: png_bytes(v) for k, v in tiles.items()}
    out["strip"] = png_bytes(labelled_strip([(captions[k], tiles[k]) for k in order]))
    return out


def labelled_strip(tiles) -> np.ndarray:
    """[(caption, uint8 (H, W, 3))] side by side under their captions, white gaps between."""
    h = max(t.shape[0] for _, t in tiles)
    gap = np.full((h + 22, 4, 3), 255, np.uint8)
    columns = []
    for caption, t in tiles:
        padded = np.zeros((h, t.shape[1], 3), np.uint8)
        padded[:t.shape[0]] = t
        columns += [np.concatenate([text_label(caption, t.shape[1]), padded]), gap]
    return np.concatenate(columns[:-1], axis=1)


def equal_time_png(tiles, width=256) -> bytes:
    """A PNG of linear images [(caption, (H, W, 3))] side by side (sRGB, upscaled to about
    `width` pixels each), under their captions."""
    return png_bytes(labelled_strip([(c, upscale(to_srgb8(image), width)) for c, image in tiles]))


def _denoised_section(data, figures):
    """The HTML of the denoised comparison, marked as not tested: its table, FLIP against time
    and each scene's denoised pair at equal time with their FLIP maps."""
    rows = denoised_rows(data)
    if not rows:
        return ""
    d = data["definitions"]
    scenes = [sc for sc in data["scenes"] if sc.get("denoised")]
    out = [f"<h2>Denoised (not tested)</h2>\n<p class='small'><b>Not tested:</b> "
           f"{html.escape(d['denoised'])}</p>\n{_table(rows, DENOISED_HEADER)}\n"
           f"<p class='small'>{html.escape(d['time_target'])}</p>\n"
           f"<p class='small'>{html.escape(d['fewer_samples_target'])}</p>\n"
           f"<h3>FLIP against wall time</h3>\n{svg_plot(scenes, 'flip', 'FLIP')}\n"
           f"<p class='small'>{html.escape(d['equal_time'])}; FLIP maps from 0 (dark) to "
           f"{FLIP_SCALE:g} and above (yellow).</p>"]
    for sc in scenes:
        fig = (figures or {}).get(sc["name"])
        if not fig:
            continue
        e = sc["denoised"]["equal_time"]
        captions = {"reference": "reference (undenoised)",
                    "snell": f"Snell + OIDN, {e['snell_spp']} spp, {e['snell_s']:.2f} s "
                             "(not tested)",
                    "snell_flip": f"Snell + OIDN's FLIP map, mean {e['snell_flip']:.3g}",
                    "cycles": f"Cycles + OIDN, {e['cycles_spp']} spp, {e['cycles_s']:.2f} s "
                              "(not tested)",
                    "cycles_flip": f"Cycles + OIDN's FLIP map, mean {e['cycles_flip']:.3g}"}
        out.append(f"<h3>{html.escape(sc['name'])}: denoised at equal time</h3>\n<div>"
                   + "".join(f"<figure><img src='{data_uri(fig[k])}'><figcaption>"
                             f"{html.escape(c)}</figcaption></figure>"
                             for k, c in captions.items()) + "</div>")
    return "\n".join(out) + "\n"


def share_map_png(light, reference) -> bytes:
    """A grey PNG of the light tracer's share of the reference per pixel (black 0, white 1)."""
    grey = np.round(np.clip(light_share(light, reference), 0.0, 1.0) * 255).astype(np.uint8)
    return png_bytes(np.repeat(grey[..., None], 3, axis=2))


def _share_maps(data, maps):
    """The HTML of each scene's light-tracer share map and caustic-region figures."""
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


def write_html(path, data, svg, maps=None, sample_maps=None, denoised_figures=None,
               equal_time_figures=None):
    """The bench page; maps: {scene name: PNG of the light tracer's share}; sample_maps: {scene
    name: {renderer: PNG of its samples per pixel}}; denoised_figures: {scene name:
    denoised_figures_png's PNGs}; equal_time_figures: {caustic scene name: equal_time_png's}."""
    d = data["definitions"]
    s = data["settings"]
    refs = "".join(
        f"<li>{html.escape(sc['name'])}: {sc['reference']['seeds']} "
        f"{'Snell batches' if sc['reference'].get('renderer') == 'snell' else 'Cycles seeds'} x "
        f"{sc['reference']['spp_per_seed']} spp = {sc['reference']['spp']} spp, "
        f"{sc['reference']['render_s']:.1f} s "
        f"({'cached' if sc['reference']['cached'] else 'rendered now'}); "
        f"own noise: relMSE {fmt(sc['reference']['noise_relmse'])}, "
        f"RMSE {fmt(sc['reference']['noise_rmse'])}</li>"
        for sc in data["scenes"])
    body = (
        f"<h1>Snell vs Cycles: time against error{' (quick)' if data['quick'] else ''}</h1>\n"
        f"<p class='small'>{s['threads']} threads each, max depth {s['max_depth']}, resolution "
        f"{s['resolution_percentage']}% of the file's, ladder {s['min_spp']}, {2 * s['min_spp']}, "
        f"... spp up to {s['max_spp']} "
        f"spp or a predicted {s['time_cap_s']:g} s per point.</p>\n"
        f"<h2>Error against wall time</h2>\n{svg}\n"
        f"<h2>Time to equal error</h2>\n{_table(summary_rows(data), SUMMARY_HEADER)}\n"
        f"<p class='small'>{html.escape(d['time_to_equal_error'])}</p>\n"
        f"{_caustic_section(data, equal_time_figures)}"
        f"{_share_maps(data, maps)}"
        f"{_adaptive_section(data, sample_maps)}"
        f"{_denoised_section(data, denoised_figures)}"
        f"<h2>Ladder points</h2>\n{_table(table_rows(data), HEADER)}\n"
        f"<h2>Definitions</h2><ul>" + "".join(f"<li><b>{html.escape(k)}</b>: {html.escape(v)}</li>"
                                               for k, v in d.items()) + "</ul>\n"
        f"<h2>References</h2><ul>{refs}</ul>\n")
    with open(path, "w") as f:
        f.write(page("snell bench", body))
