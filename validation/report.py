"""HTML reports and PNG contact sheets for `snell compare` and `snell study`. No bpy.

A report directory holds report.html (self-contained: every image is embedded as a data: URI),
the same images as PNG files beside it, metrics.json (stable keys) and, for studies,
contact_sheet.png. Images are shown through Blender's Standard view transform at exposure 0, the
same for both renderers; the difference and z-score maps use a blue-white-red scale with a legend.
"""
from __future__ import annotations

import html
import json
import math
import os

import numpy as np

from ..pages.html_page import DISPLAY_WIDTH, data_uri, img, page, table
from ..pages.images import colour_bar, diverging, png_bytes, text_label, upscale
from ..pages.plots import rate_svg
from ..tracer.atomic import atomic_directory
from ..tracer.image import to_srgb8
from ..tracer.provenance import provenance

Z_RANGE = 6.0


# ---------------------------------------------------------------------------------------------
# Pixels


def outline_tiles(pixels8, tiles, colour=(0, 0, 0)):
    """The image with a one-pixel frame drawn inside each tile ({"y0", "x0", "size"})."""
    out = pixels8.copy()
    for t in tiles:
        y0, x0, k = t["y0"], t["x0"], t["size"]
        y1, x1 = min(y0 + k, out.shape[0]) - 1, min(x0 + k, out.shape[1]) - 1
        out[y0, x0:x1 + 1] = out[y1, x0:x1 + 1] = colour
        out[y0:y1 + 1, x0] = out[y0:y1 + 1, x1] = colour
    return out


def _pad_to(pixels8, h, w):
    out = np.full((h, w, 3), 40, np.uint8)
    out[:pixels8.shape[0], :pixels8.shape[1]] = pixels8
    return out


# ---------------------------------------------------------------------------------------------
# JSON


def _plain(value):
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items() if not isinstance(v, np.ndarray)}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def metrics_json(result) -> dict:
    """The stable-key numbers of one comparison (no images or maps)."""
    keys = ("verdict", "statistical_verdict", "not_comparable", "rule", "tests", "z_pass_fraction",
            "pixels", "pixels_failed", "pixels_exact_failed", "alpha", "alpha_pixel",
            "z_critical_normal", "tile_size", "tiles", "tiles_failed", "tile_max_abs_z",
            "sharpness_z", "sharpness_p", "sharpness_df", "sharpness_template",
            "sharpness_left_out", "failed_tests", "failing_tiles", "alpha_test", "light_allowance",
            "mean_variance_from", "exporter_notes", "cycles_caveats",
            "max_abs_z", "mean_a", "mean_b", "mean_a_se", "mean_b_se", "mean_z", "mean_ratio",
            "mean_ratio_se", "relmse", "relmse_eps", "relmse_dropped_fraction", "rmse",
            "bias_rmse", "noise_rmse", "flip", "label", "scene", "exporter_warnings",
            "cycles_settings", "snell_settings", "alpha_channel")
    out = {k: _plain(result[k]) for k in keys if k in result}
    out["snell"] = _plain({k: v for k, v in result["snell"].items() if k != "image"})
    if result.get("cycles"):
        out["cycles"] = _plain({k: v for k, v in result["cycles"].items() if k != "image"})
        out["snell"]["mean"] = out.pop("mean_a", None)
        out["snell"]["mean_se"] = out.pop("mean_a_se", None)
        out["cycles"]["mean"] = out.pop("mean_b", None)
        out["cycles"]["mean_se"] = out.pop("mean_b_se", None)
    else:
        out["cycles"] = None
    return out


def _write_json(path, data):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump({**data, "provenance": provenance()}, f, indent=2, sort_keys=True)
    os.replace(tmp, path)


# ---------------------------------------------------------------------------------------------
# HTML


def _verdict_class(v):
    return (v or "not comparable").replace(" ", "-")


def comparison_images(result):
    """{name: uint8 image} for one comparison (snell, cycles, diff, z), plus scale limits."""
    a = result["snell"]["image"]
    imgs = {"snell": to_srgb8(a)}
    limits = {}
    if result.get("cycles"):
        b = result["cycles"]["image"]
        imgs["cycles"] = to_srgb8(b)
        diff = result["maps"]["diff"].mean(axis=2)
        lim = float(np.percentile(np.abs(diff), 99)) or 1e-6
        limits["diff"] = lim
        imgs["diff"] = diverging(diff, lim)
        imgs["z"] = outline_tiles(diverging(result["maps"]["z"], Z_RANGE),
                                  result.get("failing_tiles", ()))
        limits["z"] = Z_RANGE
    return imgs, limits


def _numbers_table(result):
    ch = ("r", "g", "b")
    rows = [["verdict", result["verdict"]],
            ["statistical verdict", result.get("statistical_verdict")]]
    if result.get("cycles"):
        t = result["tests"]
        exact = result["pixels_exact_failed"]
        mismatches = f"; {exact} zero-variance mismatches" if exact else ""
        rows += [
            ["failed tests", ", ".join(result.get("failed_tests") or []) or "none"],
            ["level of each test (whole verdict 1%)",
             f"{result.get('alpha_test', result['alpha']):.4g}"],
            ["test 1: pixels passing (z-pass fraction)",
             f"{result['z_pass_fraction']:.5f} ({result['pixels_failed']} of "
             f"{result['pixels']} fail"
             f"{mismatches})"
             f" -> {'pass' if t['pixels'] else 'FAIL'}"],
            ["per-pixel alpha (Sidak)",
             f"{result['alpha_pixel']:.3g} (|z| > {result['z_critical_normal']:.2f} for a normal)"],
            ["max |z| over pixels", result["max_abs_z"]],
            [f"test 2: {result['tile_size']}x{result['tile_size']} tiles failing",
             f"{result['tiles_failed']} of {result['tiles']} "
             f"(max |z| {result['tile_max_abs_z']:.2f}) -> "
             f"{'pass' if t['tiles'] else 'FAIL'}"],
            ["test 3: image means", "pass" if t["image_mean"] else "FAIL"],
        ]
        if "sharpness" in t:
            rows.append(["test 4: sharpness (matched filter on the Laplacian)",
                         f"z {result['sharpness_z']:.2f}, p {result['sharpness_p']:.3g}, "
                         f"dof {result.get('sharpness_df') or 0:.0f} (template: "
                         f"{result.get('sharpness_template')}) -> "
                         f"{'pass' if t['sharpness'] else 'FAIL'}"])
        for c in ch:
            rows.append([f"mean {c}: Snell / Cycles",
                         f"{result['mean_a'][c]:.5g} ± {result['mean_a_se'][c]:.2g} / "
                         f"{result['mean_b'][c]:.5g} ± {result['mean_b_se'][c]:.2g}; ratio "
                         f"{result['mean_ratio'][c]:.5f} ± {result['mean_ratio_se'][c]:.2g}; "
                         f"z {result['mean_z'][c]:.2f}"])
        rows += [
            [f"relMSE (eps {result['relmse_eps']:g}, "
             f"top {result['relmse_dropped_fraction']:.1%} of terms dropped)",
             result["relmse"]],
            ["RMSE", result["rmse"]],
            ["RMSE explained by noise / excess (bias estimate)",
             f"{result['noise_rmse']:.4g} / {result['bias_rmse']:.4g}"],
            ["FLIP (HDR, Cycles as reference)", result["flip"]],
            ["Cycles time", f"{result['cycles']['time_s']:.2f} s "
                            f"({len(result['cycles']['seeds'])} seeds x "
                            f"{result['cycles']['spp_per_seed']} spp)"],
        ]
    snell = result["snell"]
    samples = (f"adaptive {snell['noise_threshold']:g}: {snell['mean_spp']:.0f} spp mean, "
               f"{snell['spp']} max, {100 * snell['saved_share']:.0f}% saved"
               if snell.get("noise_threshold") else f"{snell['spp']} spp")
    rows.append(["Snell time", f"{snell['time_s']:.2f} s ({samples}, "
                               f"{snell['nan_samples']} NaN/Inf samples)"])
    return table(rows, ["quantity", "value"])


def _settings_tables(result, forced=True):
    parts = []
    if result.get("not_comparable"):
        parts.append("<h3>Not comparable</h3><ul>" + "".join(
            f"<li>{html.escape(s)}</li>" for s in result["not_comparable"]) + "</ul>")
    if forced and result.get("cycles_settings"):
        parts.append("<h3>Settings forced on Cycles</h3>" +
                     table(result["cycles_settings"], ["setting", "value", "why"]))
    if result.get("snell_settings"):
        parts.append("<h3>Snell settings</h3>" +
                     table(result["snell_settings"], ["setting", "value", "note"]))
    return "\n".join(parts)


def _varying(rows):
    """The Cycles settings whose value differs between a study's settings."""
    values = {}
    for r in rows:
        for key, value, _ in r.get("cycles_settings") or []:
            values.setdefault(key, set()).add(str(value))
    return {key for key, seen in values.items() if len(seen) > 1}


def _own_forced(row, varying):
    """A study setting's own values of the Cycles settings that vary between settings."""
    own = [s for s in row.get("cycles_settings") or [] if s[0] in varying]
    return ("<h3>Cycles settings of this setting</h3>" + table(own, ["setting", "value", "why"])
            if own else "")


def _forced_once(rows):
    """The settings forced on Cycles, once for a study page; those that vary between the
    study's settings are shown with each setting's numbers instead."""
    first = next((r["cycles_settings"] for r in rows if r.get("cycles_settings")), None)
    if not first:
        return ""
    varying = _varying(rows)
    shown = [[key, value, why] if key not in varying else
             [key, "varies by setting", "shown with each setting below"]
             for key, value, why in first]
    return "<h2>Settings forced on Cycles</h2>" + table(shown, ["setting", "value", "why"])


def _figures(pngs, limits, prefix=""):
    caption = {"snell": "Snell", "cycles": "Cycles",
               "diff": "difference Snell - Cycles (channel mean)", "z": "z-score (largest channel)"}
    parts = []
    for name in ("snell", "cycles", "diff", "z"):
        if name not in pngs:
            continue
        legend = ""
        if name in limits:
            lim = limits[name]
            legend = (f"<br>{img(png_bytes(colour_bar(lim)), 'colour scale', 'bar')}<br>"
                      f"<span class='small'>blue {-lim:.3g} · white 0 · red +{lim:.3g}</span>")
        parts.append(f"<figure>{img(pngs[name], prefix + name)}<figcaption>{caption[name]}"
                     f"{legend}</figcaption></figure>")
    return "\n".join(parts)


def _differences(result):
    """The failing tiles (outlined on the z map), the objects they show and the exporter
    warnings that name those objects."""
    tiles = result.get("failing_tiles") or []
    if not tiles:
        return ""
    rows, named = [], set()
    for t in sorted(tiles, key=lambda t: -abs(t["z"]))[:20]:
        objects = t.get("objects") or []
        named.update(name for name, _ in objects)
        rows.append([f"rows {t['y0']}-{t['y0'] + t['size'] - 1}, "
                     f"columns {t['x0']}-{t['x0'] + t['size'] - 1}",
                     f"{t['z']:+.2f}",
                     ", ".join(f"{name} ({share:.0%})" for name, share in objects) or "n/a"])
    more = f"<p class='small'>and {len(tiles) - 20} more tiles</p>" if len(tiles) > 20 else ""
    related = [w for w in result.get("exporter_warnings") or []
               if any(repr(name) in w for name in named)]
    part = ("<h3>Where the images differ</h3><p class='small'>Tiles that fail the tile test "
            "(outlined on the z map; z > 0: Snell brighter), and the objects their pixels see "
            "first (share of the tile's camera rays).</p>" +
            table(rows, ["tile", "z", "objects"]) + more)
    if related:
        part += ("<p>Exporter warnings about these objects:</p><ul>" +
                 "".join(f"<li>{html.escape(w)}</li>" for w in related) + "</ul>")
    return part


def write_comparison(directory, result, title=None, figures=()):
    """report.html, metrics.json and the PNGs of one comparison into directory (all or nothing);
    figures: more (name, PNG bytes, caption) to show, such as the map of Snell's samples."""
    with atomic_directory(directory) as tmp:
        return _write_comparison(tmp, result, title, figures)


def _write_comparison(directory, result, title, figures):
    imgs, limits = comparison_images(result)
    pngs = {k: png_bytes(v) for k, v in imgs.items()}
    pngs.update({name: png for name, png, _ in figures})
    for name, data in pngs.items():
        with open(os.path.join(directory, f"{name}.png"), "wb") as f:
            f.write(data)
    title = title or f"Snell vs Cycles: {os.path.basename(result.get('scene', ''))}"
    v = result["verdict"]
    body = (f"<h1>{html.escape(title)}</h1>\n"
            f"<div class='verdict {_verdict_class(v)}'>{html.escape(v)}</div>\n"
            f"<p class='small'>Rule: {html.escape(result['rule'])}.</p>\n"
            f"<div>{_figures(pngs, limits)}"
            + "".join(f"<figure>{img(png, name)}<figcaption>{html.escape(caption)}</figcaption>"
                      f"</figure>" for name, png, caption in figures)
            + "</div>\n"
            "<p class='small'>Both images: linear result through "
            "Blender's Standard view transform, "
            f"exposure 0, shown at {DISPLAY_WIDTH} px wide (nearest neighbour).</p>\n"
            f"<h2>Numbers</h2>\n{_numbers_table(result)}\n{_settings_tables(result)}")
    body += _differences(result)
    if result.get("exporter_warnings"):
        body += "<h3>Exporter warnings</h3><ul>" + "".join(
            f"<li>{html.escape(w)}</li>" for w in result["exporter_warnings"]) + "</ul>"
    if result.get("cycles_caveats"):
        body += "<h3>Where Cycles is biased</h3><ul>" + "".join(
            f"<li>{html.escape(c)}</li>" for c in result["cycles_caveats"]) + "</ul>"
    if result.get("exporter_notes"):
        body += ("<p class='small'>Of these, the verdict does not count (Cycles renders their "
                 "cause the same way): " + "; ".join(html.escape(w)
                                                     for w in result["exporter_notes"])
                 + "</p>")
    with open(os.path.join(directory, "report.html"), "w") as f:
        f.write(page(title, body))
    data = metrics_json(result)
    _write_json(os.path.join(directory, "metrics.json"), data)
    return data


# ---------------------------------------------------------------------------------------------
# Studies


def contact_sheet(rows, cell=192):
    """uint8 image: one row per setting, [label | Snell | Cycles] (Cycles cell grey if absent)."""
    strips = []
    for row in rows:
        snell = upscale(to_srgb8(row["snell"]["image"]), cell)
        h, w = snell.shape[:2]
        if row.get("cycles"):
            cyc = upscale(to_srgb8(row["cycles"]["image"]), cell)
        else:
            cyc = np.full_like(snell, 60)
            note = text_label("no Cycles equivalent", w, 22, 13)
            cyc[h // 2 - 11:h // 2 + 11] = note
        sep = np.full((h, 4, 3), 255, np.uint8)
        images = np.concatenate([snell, sep, cyc], axis=1)
        label = text_label(f"{row['label']}: {row['verdict']}", images.shape[1], 22, 14)
        strips.append(np.concatenate([label, images,
                                      np.full((6, images.shape[1], 3), 255, np.uint8)]))
    width = max(s.shape[1] for s in strips)
    head = text_label("Snell | Cycles", width, 22, 14)
    return np.concatenate([head] + [_pad_to(s, s.shape[0], width) for s in strips])


def write_study(directory, name, rows, notes=()):
    """study report: report.html, contact_sheet.png, metrics.json and per-setting PNGs (all or
    nothing)."""
    with atomic_directory(directory) as tmp:
        return _write_study(tmp, name, rows, notes)


def _write_study(directory, name, rows, notes):
    sheet = png_bytes(contact_sheet(rows))
    with open(os.path.join(directory, "contact_sheet.png"), "wb") as f:
        f.write(sheet)
    sections, summary, data = [], [], {"study": name, "settings": []}
    varying = _varying(rows)
    for i, row in enumerate(rows):
        imgs, limits = comparison_images(row)
        pngs = {k: png_bytes(v) for k, v in imgs.items()}
        for k, png in pngs.items():
            with open(os.path.join(directory, f"{i:02d}_{k}.png"), "wb") as f:
                f.write(png)
        v = row["verdict"]
        sections.append(
            f"<h2>{html.escape(row['label'])} <span class='verdict {_verdict_class(v)}' "
            f"style='font-size:0.7em'>{html.escape(v)}</span></h2>\n"
            f"<div>{_figures(pngs, limits)}</div>\n"
            f"<details><summary>numbers and settings</summary>{_numbers_table(row)}"
            f"{_settings_tables(row, forced=False)}{_own_forced(row, varying)}"
            f"{_differences(row)}</details>")
        cyc = row.get("cycles")
        failed = ", ".join(row.get("failed_tests") or []) if cyc else "n/a"
        summary.append([row["label"], v, failed or "none", row.get("z_pass_fraction"),
                      row.get("relmse"), row.get("flip"),
                      f"{row['snell']['time_s']:.2f} s",
                      f"{cyc['time_s']:.2f} s" if cyc else "n/a"])
        entry = metrics_json(row)
        entry["setting"] = row.get("setting")
        data["settings"].append(entry)
    verdicts = [r["verdict"] for r in rows]
    comparable = [v for v in verdicts if v != "not comparable"]
    overall = ("inconsistent" if "inconsistent" in comparable else
               "consistent" if comparable else "not comparable")
    data["verdict"] = overall
    body = (f"<h1>Snell vs Cycles: {html.escape(name)} study</h1>\n"
            f"<div class='verdict {_verdict_class(overall)}'>{html.escape(overall)} "
            f"({sum(v == 'consistent' for v in verdicts)} of {len(verdicts)} "
            "settings consistent)</div>\n"
            + "".join(f"<p class='small'>{html.escape(n)}</p>" for n in notes) +
            f"<p class='small'>Rule per setting: {html.escape(metrics.RULE)}.</p>\n"
            + table(summary, ["setting", "verdict", "failed tests", "z-pass fraction", "relMSE",
                             "FLIP", "Snell time", "Cycles time"]) +
            _forced_once(rows) +
            f"<h2>Contact sheet</h2><figure><img style='width:auto' alt='contact sheet' "
            f"src='{data_uri(sheet)}'></figure>\n" + "\n".join(sections))
    with open(os.path.join(directory, "report.html"), "w") as f:
        f.write(page(f"Snell {name} study", body))
    data["notes"] = list(notes)
    _write_json(os.path.join(directory, "metrics.json"), _plain(data))
    return data


# ---------------------------------------------------------------------------------------------
# False alarms


def power_svg(curves) -> str:
    """Inline SVG: per error kind, the share of runs the verdict called inconsistent against
    the error's size, one line per sample count. curves: {kind: {spp: [(size, rate)]}}."""
    return rate_svg({kind: [(f"{spp} spp", pts) for spp, pts in sorted(lines.items())]
                     for kind, lines in curves.items()}, "error size")


def power_curves(rows, configs):
    """{kind: {spp: [(size, detection rate)]}} of the rows whose configuration is among
    `configs` (power runs of growing error size), for power_svg."""
    by_name = {c.name: c for c in configs}
    curves = {}
    for row in rows:
        c = by_name.get(row["config"])
        if c is None or not c.error or isinstance(c.error[1], str):
            continue
        kind, size = c.error
        size = abs(size - 1.0) if kind in ("roughness", "focus", "aperture", "lamps") else abs(size)
        curves.setdefault(kind, {}).setdefault(c.spp, []).append(
            (round(size, 6), row["verdict"] / row["runs"]))
    return {k: v for k, v in curves.items() if sum(len(p) for p in v.values()) >= 2}


def write_false_alarms(directory, rows, overall, configs, curves=()):
    """report.html and metrics.json of `snell false-alarms` (all or nothing): the whole
    verdict's and each test's failure rate over the null runs with their 95% intervals, the
    failures per configuration, and the configurations."""
    with atomic_directory(directory) as tmp:
        tests = [t for t in overall if t != "verdict"] + ["verdict"] if overall else []
        rates = [[t, f"{v[0]} / {v[1]}", f"{v[2]:.3f}", f"{v[3]:.3f} - {v[4]:.3f}"]
                 for t, v in ((t, overall[t]) for t in tests)]
        per = [[r["config"], r["runs"], *[r.get(t, "") for t in tests]] for r in rows]
        settings = [[c.name, c.scene, c.spp, f"{c.scale}%", c.cycles_seeds,
                     c.max_depth if c.max_depth is not None else "scene's",
                     ", ".join(f"{k} {v:g}" for k, v in c.camera) or "scene's",
                     "Cycles vs Cycles" if c.mode == "cycles" else "Snell vs Cycles",
                     "" if not c.error else f"{c.error[0]} {c.error[1]}"] for c in configs]
        curves = power_curves(rows, curves)
        svg = power_svg(curves) if curves else ""
        if svg:
            with open(os.path.join(tmp, "power.svg"), "w") as f:
                f.write(svg)
        body = ("<h1>Snell's validator: false alarms and power</h1>\n"
                "<p>Null runs render a correct configuration with independent seeds and apply "
                "the full verdict; a failure is a false alarm. Rates come with exact "
                "(Clopper-Pearson) 95% intervals. Power runs (a configuration with a deliberate "
                "error, named CONFIG:ERROR) count detections instead and are not in the "
                f"overall rates.</p>\n<p class='small'>Rule: {html.escape(metrics.RULE)}.</p>"
                "<h2>Overall (null runs)</h2>" +
                table(rates, ["test", "failures / runs", "rate", "95% interval"]) +
                "<h2>Failures per configuration</h2>" +
                table(per, ["configuration", "runs", *tests]) +
                ("<h2>Power: share of runs caught against the error's size</h2>"
                 "<p class='small'>Relative errors (roughness, focus) as the fraction off; IOR "
                 "as the difference. The pink line is 9 of 10.</p>" + svg if svg else "") +
                "<h2>Configurations</h2>" +
                table(settings, ["name", "scene", "spp", "resolution", "Cycles seeds",
                                  "max depth", "camera", "compared", "error"]))
        with open(os.path.join(tmp, "report.html"), "w") as f:
            f.write(page("Snell false alarms", body))
        data = {"overall": {t: dict(zip(("failures", "runs", "rate", "low", "high"), v))
                            for t, v in overall.items()},
                "configurations": rows, "rule": metrics.RULE}
        _write_json(os.path.join(tmp, "metrics.json"), _plain(data))
    return data


from . import metrics  # noqa: E402  (after the definitions: metrics has no back-reference)
