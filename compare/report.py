"""HTML reports and PNG contact sheets for `snell compare` and `snell study`. No bpy.

A report directory holds report.html (self-contained: every image is embedded as a data: URI),
the same images as PNG files beside it, metrics.json (stable keys) and, for studies,
contact_sheet.png. Images are shown through Blender's Standard view transform at exposure 0, the
same for both renderers; the difference and z-score maps use a blue-white-red scale with a legend.
"""
from __future__ import annotations

import base64
import datetime
import html
import json
import math
import os
import tempfile

import numpy as np

from ..tracer.atomic import atomic_directory
from ..tracer.image import to_srgb8

DISPLAY_WIDTH = 256  # CSS pixels per image (nearest-neighbour upscaling of small renders)
Z_RANGE = 6.0


# ---------------------------------------------------------------------------------------------
# Pixels


def diverging(values, limit):
    """Blue (-limit) - white (0) - red (+limit) as uint8 (H, W, 3)."""
    t = np.clip(np.nan_to_num(np.asarray(values, np.float64)) / max(limit, 1e-30), -1.0, 1.0)
    pos, neg = np.clip(t, 0, 1)[..., None], np.clip(-t, 0, 1)[..., None]
    white = np.ones(t.shape + (3,))
    red, blue = np.array([0.75, 0.05, 0.05]), np.array([0.05, 0.2, 0.8])
    rgb = white * (1 - pos - neg) + red * pos + blue * neg
    return np.rint(np.clip(rgb, 0, 1) * 255).astype(np.uint8)


def colour_bar(limit, width=256, height=14):
    ramp = np.linspace(-limit, limit, width)[None, :].repeat(height, axis=0)
    return diverging(ramp, limit)


def png_bytes(pixels8) -> bytes:
    """Encode a uint8 (H, W, 3) array as PNG through OpenImageIO."""
    import OpenImageIO as oiio
    pixels8 = np.ascontiguousarray(pixels8, np.uint8)
    h, w, c = pixels8.shape
    fd, tmp = tempfile.mkstemp(suffix=".png")
    os.close(fd)
    try:
        out = oiio.ImageOutput.create(tmp)
        out.open(tmp, oiio.ImageSpec(w, h, c, "uint8"))
        out.write_image(pixels8)
        out.close()
        with open(tmp, "rb") as f:
            return f.read()
    finally:
        os.remove(tmp)


def text_label(text, width, height=22, size=14):
    """A dark strip with white text (OpenImageIO's built-in font)."""
    import OpenImageIO as oiio
    buf = oiio.ImageBuf(oiio.ImageSpec(width, height, 3, "float"))
    oiio.ImageBufAlgo.fill(buf, (0.12, 0.12, 0.12))
    oiio.ImageBufAlgo.render_text(buf, 4, height - 6, text, size, "", (1, 1, 1))
    return np.rint(np.clip(buf.get_pixels(oiio.FLOAT), 0, 1) * 255).astype(np.uint8)


def upscale(pixels8, width):
    """Nearest-neighbour upscale to about `width` pixels wide (integer factor, at least 1)."""
    k = max(1, width // pixels8.shape[1])
    return pixels8.repeat(k, axis=0).repeat(k, axis=1)


def _pad_to(img, h, w):
    out = np.full((h, w, 3), 40, np.uint8)
    out[:img.shape[0], :img.shape[1]] = img
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
            "sharpness_z", "sharpness_p",
            "max_abs_z", "mean_a", "mean_b", "mean_a_se", "mean_b_se", "mean_z", "mean_ratio",
            "mean_ratio_se", "relmse", "relmse_eps", "relmse_dropped_fraction", "rmse",
            "bias_rmse", "noise_rmse", "flip", "label", "scene", "exporter_warnings",
            "cycles_settings", "snell_settings")
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
        json.dump(data, f, indent=2, sort_keys=True)
    os.replace(tmp, path)


# ---------------------------------------------------------------------------------------------
# HTML


CSS = """
body { font-family: sans-serif; margin: 1.5em; background: #fafafa; color: #222; }
.verdict { font-size: 1.6em; padding: 0.4em 0.8em; display: inline-block; border-radius: 6px; }
.consistent { background: #c8f0c8; } .inconsistent { background: #f5c2c2; }
.not-comparable { background: #e6e6e6; }
figure { display: inline-block; margin: 0.4em; vertical-align: top; text-align: center; }
figure img { width: %dpx; image-rendering: pixelated; border: 1px solid #999; }
img.bar { height: 14px; image-rendering: auto; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.9em; }
td, th { border: 1px solid #bbb; padding: 0.2em 0.6em; text-align: left; }
.small { font-size: 0.85em; color: #555; }
""" % DISPLAY_WIDTH

LOAD_CHECK = """
<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.length > 0 && imgs.every(function (i) { return i.complete && i.naturalWidth > 0; });
  document.body.setAttribute('data-images', ok ? 'decoded' : 'broken');
  document.body.setAttribute('data-image-count', String(imgs.length));
});
</script>
"""


def _data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _img(png, alt, cls=""):
    c = f' class="{cls}"' if cls else ""
    return f'<img{c} alt="{html.escape(alt)}" src="{_data_uri(png)}">'


def _verdict_class(v):
    return (v or "not comparable").replace(" ", "-")


def _fmt(x, digits=4):
    if x is None:
        return "n/a"
    if isinstance(x, float):
        if not math.isfinite(x):
            return str(x)
        return f"{x:.{digits}g}"
    return html.escape(str(x))


def _table(rows, header=None):
    out = ["<table>"]
    if header:
        out.append("<tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>")
    for row in rows:
        out.append("<tr>" + "".join(f"<td>{_fmt(c)}</td>" for c in row) + "</tr>")
    out.append("</table>")
    return "\n".join(out)


def _page(title, body):
    stamp = datetime.datetime.now().isoformat(timespec="seconds")
    return (f"<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
            f"<title>{html.escape(title)}</title><style>{CSS}</style></head>\n<body>\n{body}\n"
            f"<p class='small'>Generated by snell at {stamp}.</p>{LOAD_CHECK}</body></html>\n")


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
        imgs["z"] = diverging(result["maps"]["z"], Z_RANGE)
        limits["z"] = Z_RANGE
    return imgs, limits


def _numbers_table(result):
    ch = ("r", "g", "b")
    rows = [["verdict", result["verdict"]],
            ["statistical verdict", result.get("statistical_verdict")]]
    if result.get("cycles"):
        t = result["tests"]
        rows += [
            ["test 1: pixels passing (z-pass fraction)",
             f"{result['z_pass_fraction']:.5f} ({result['pixels_failed']} of {result['pixels']} fail"
             f"{'; ' + str(result['pixels_exact_failed']) + ' zero-variance mismatches' if result['pixels_exact_failed'] else ''})"
             f" -> {'pass' if t['pixels'] else 'FAIL'}"],
            ["per-pixel alpha (Sidak)", f"{result['alpha_pixel']:.3g} (|z| > {result['z_critical_normal']:.2f} for a normal)"],
            ["max |z| over pixels", result["max_abs_z"]],
            [f"test 2: {result['tile_size']}x{result['tile_size']} tiles failing",
             f"{result['tiles_failed']} of {result['tiles']} (max |z| {result['tile_max_abs_z']:.2f}) -> "
             f"{'pass' if t['tiles'] else 'FAIL'}"],
            ["test 3: image means", "pass" if t["image_mean"] else "FAIL"],
        ]
        if "sharpness" in t:
            rows.append(["test 4: sharpness (matched filter on the Laplacian)",
                         f"z {result['sharpness_z']:.2f}, p {result['sharpness_p']:.3g} -> "
                         f"{'pass' if t['sharpness'] else 'FAIL'}"])
        for c in ch:
            rows.append([f"mean {c}: Snell / Cycles",
                         f"{result['mean_a'][c]:.5g} ± {result['mean_a_se'][c]:.2g} / "
                         f"{result['mean_b'][c]:.5g} ± {result['mean_b_se'][c]:.2g}; ratio "
                         f"{result['mean_ratio'][c]:.5f} ± {result['mean_ratio_se'][c]:.2g}; z {result['mean_z'][c]:.2f}"])
        rows += [
            [f"relMSE (eps {result['relmse_eps']:g}, top {result['relmse_dropped_fraction']:.1%} of terms dropped)", result["relmse"]],
            ["RMSE", result["rmse"]],
            ["RMSE explained by noise / excess (bias estimate)", f"{result['noise_rmse']:.4g} / {result['bias_rmse']:.4g}"],
            ["FLIP (HDR, Cycles as reference)", result["flip"]],
            ["Cycles time", f"{result['cycles']['time_s']:.2f} s ({len(result['cycles']['seeds'])} seeds x "
                            f"{result['cycles']['spp_per_seed']} spp)"],
        ]
    snell = result["snell"]
    samples = (f"adaptive {snell['noise_threshold']:g}: {snell['mean_spp']:.0f} spp mean, "
               f"{snell['spp']} max, {100 * snell['saved_share']:.0f}% saved"
               if snell.get("noise_threshold") else f"{snell['spp']} spp")
    rows.append(["Snell time", f"{snell['time_s']:.2f} s ({samples}, "
                               f"{snell['nan_samples']} NaN/Inf samples)"])
    return _table(rows, ["quantity", "value"])


def _settings_tables(result):
    parts = []
    if result.get("not_comparable"):
        parts.append("<h3>Not comparable</h3><ul>" + "".join(
            f"<li>{html.escape(s)}</li>" for s in result["not_comparable"]) + "</ul>")
    if result.get("cycles_settings"):
        parts.append("<h3>Settings forced on Cycles</h3>" +
                     _table(result["cycles_settings"], ["setting", "value", "why"]))
    if result.get("snell_settings"):
        parts.append("<h3>Snell settings</h3>" + _table(result["snell_settings"], ["setting", "value", "note"]))
    return "\n".join(parts)


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
            legend = (f"<br>{_img(png_bytes(colour_bar(lim)), 'colour scale', 'bar')}<br>"
                      f"<span class='small'>blue {-lim:.3g} · white 0 · red +{lim:.3g}</span>")
        parts.append(f"<figure>{_img(pngs[name], prefix + name)}<figcaption>{caption[name]}"
                     f"{legend}</figcaption></figure>")
    return "\n".join(parts)


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
            + "".join(f"<figure>{_img(png, name)}<figcaption>{html.escape(caption)}</figcaption>"
                      f"</figure>" for name, png, caption in figures)
            + "</div>\n"
            f"<p class='small'>Both images: linear result through Blender's Standard view transform, "
            f"exposure 0, shown at {DISPLAY_WIDTH} px wide (nearest neighbour).</p>\n"
            f"<h2>Numbers</h2>\n{_numbers_table(result)}\n{_settings_tables(result)}")
    if result.get("exporter_warnings"):
        body += "<h3>Exporter warnings</h3><ul>" + "".join(
            f"<li>{html.escape(w)}</li>" for w in result["exporter_warnings"]) + "</ul>"
    with open(os.path.join(directory, "report.html"), "w") as f:
        f.write(_page(title, body))
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
        strips.append(np.concatenate([label, images, np.full((6, images.shape[1], 3), 255, np.uint8)]))
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
    sections, table, data = [], [], {"study": name, "settings": []}
    for i, row in enumerate(rows):
        imgs, limits = comparison_images(row)
        pngs = {k: png_bytes(v) for k, v in imgs.items()}
        for k, png in pngs.items():
            with open(os.path.join(directory, f"{i:02d}_{k}.png"), "wb") as f:
                f.write(png)
        v = row["verdict"]
        sections.append(
            f"<h2>{html.escape(row['label'])} <span class='verdict {_verdict_class(v)}' "
            f"style='font-size:0.7em'>{html.escape(v)}</span></h2>\n<div>{_figures(pngs, limits)}</div>\n"
            f"<details><summary>numbers and settings</summary>{_numbers_table(row)}"
            f"{_settings_tables(row)}</details>")
        cyc = row.get("cycles")
        table.append([row["label"], v, row.get("z_pass_fraction"), row.get("relmse"), row.get("flip"),
                      f"{row['snell']['time_s']:.2f} s", f"{cyc['time_s']:.2f} s" if cyc else "n/a"])
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
            f"({sum(v == 'consistent' for v in verdicts)} of {len(verdicts)} settings consistent)</div>\n"
            + "".join(f"<p class='small'>{html.escape(n)}</p>" for n in notes) +
            f"<p class='small'>Rule per setting: {html.escape(metrics.RULE)}.</p>\n"
            + _table(table, ["setting", "verdict", "z-pass fraction", "relMSE", "FLIP", "Snell time",
                             "Cycles time"]) +
            f"<h2>Contact sheet</h2><figure><img style='width:auto' alt='contact sheet' "
            f"src='{_data_uri(sheet)}'></figure>\n" + "\n".join(sections))
    with open(os.path.join(directory, "report.html"), "w") as f:
        f.write(_page(f"Snell {name} study", body))
    data["notes"] = list(notes)
    _write_json(os.path.join(directory, "metrics.json"), _plain(data))
    return data


from . import metrics  # noqa: E402  (after the definitions: metrics has no back-reference)
