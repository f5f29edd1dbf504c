"""Inline SVG plots for the pages: one panel per title side by side, one polyline per series.
No bpy.

loglog_svg: both axes logarithmic, whole decades (the bench's error against wall time).
rate_svg: a rate from 0 to 1 against a size on a logarithmic axis (linear when a size is not
above 0), such as the share of runs a test catches against the size of an error.
"""
from __future__ import annotations

import html
import math

RATE_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd")


def _svg(parts, n_panels, panel_w, panel_h) -> str:
    total_w = panel_w * max(1, n_panels)
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{total_w}" height="{panel_h}" '
            f'viewBox="0 0 {total_w} {panel_h}" font-family="sans-serif" font-size="11">\n'
            + "\n".join(parts) + "\n</svg>\n")


def _decades(lo, hi):
    a, b = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    if a == b:
        b = a + 1
    return a, b


def loglog_svg(panels, x_label, y_label, panel_w=360, panel_h=280) -> str:
    """panels: [(title, [(label, colour, [(x, y)])])]. Points that are not above 0 are left out;
    a panel without points stays empty (its place is kept). Legend at the top right."""
    m = {"l": 58, "r": 12, "t": 26, "b": 40}
    parts = []
    for i, (title, series) in enumerate(panels):
        pts = [(label, colour, [(x, y) for x, y in points if x > 0 and y > 0])
               for label, colour, points in series]
        allp = [q for _, _, p in pts for q in p]
        if not allp:
            continue
        x0, x1 = _decades(min(p[0] for p in allp), max(p[0] for p in allp))
        y0, y1 = _decades(min(p[1] for p in allp), max(p[1] for p in allp))
        ox = i * panel_w
        w, h = panel_w - m["l"] - m["r"], panel_h - m["t"] - m["b"]

        def X(t):
            return ox + m["l"] + (math.log10(t) - x0) / (x1 - x0) * w

        def Y(e):
            return m["t"] + (1 - (math.log10(e) - y0) / (y1 - y0)) * h

        g = [f'<rect x="{ox + m["l"]}" y="{m["t"]}" width="{w}" height="{h}" '
             'fill="white" stroke="#888"/>',
             f'<text x="{ox + m["l"] + w / 2}" y="16" text-anchor="middle" font-weight="bold">'
             f'{html.escape(title)}</text>']
        for d in range(x0, x1 + 1):
            x = X(10.0 ** d)
            g.append(f'<line x1="{x:.1f}" y1="{m["t"]}" x2="{x:.1f}" '
                     f'y2="{m["t"] + h}" stroke="#ddd"/>')
            g.append(f'<text x="{x:.1f}" y="{m["t"] + h + 14}" '
                     f'text-anchor="middle">{10.0 ** d:g}</text>')
        for d in range(y0, y1 + 1):
            y = Y(10.0 ** d)
            g.append(f'<line x1="{ox + m["l"]}" y1="{y:.1f}" '
                     f'x2="{ox + m["l"] + w}" y2="{y:.1f}" stroke="#ddd"/>')
            g.append(f'<text x="{ox + m["l"] - 4}" y="{y + 4:.1f}" text-anchor="end">1e{d}</text>')
        g.append(f'<text x="{ox + m["l"] + w / 2}" y="{panel_h - 6}" text-anchor="middle">'
                 f'{html.escape(x_label)}</text>')
        g.append(f'<text transform="translate({ox + 13},{m["t"] + h / 2}) rotate(-90)" '
                 f'text-anchor="middle">{html.escape(y_label)}</text>')
        for k, (label, c, p) in enumerate(pts):
            line = " ".join(f"{X(t):.1f},{Y(e):.1f}" for t, e in p)
            g.append(f'<polyline points="{line}" fill="none" stroke="{c}" stroke-width="2"/>')
            g += [f'<circle cx="{X(t):.1f}" cy="{Y(e):.1f}" r="3" fill="{c}"/>' for t, e in p]
            ly = m["t"] + 14 + 16 * k
            g.append(f'<line x1="{ox + m["l"] + w - 150}" y1="{ly - 4}" '
                     f'x2="{ox + m["l"] + w - 132}" '
                     f'y2="{ly - 4}" stroke="{c}" stroke-width="2"/>')
            g.append(f'<text x="{ox + m["l"] + w - 128}" y="{ly}">{html.escape(label)}</text>')
        parts.append("\n".join(g))
    return _svg(parts, len(panels), panel_w, panel_h)


def rate_svg(panels, x_label, panel_w=300, panel_h=240) -> str:
    """panels: {title: [(label, [(size, rate)])]}, rates from 0 to 1; colours from RATE_COLOURS
    in series order, legend at the bottom right. Grid lines at 0, 0.5, 0.9 (pink) and 1."""
    m = {"l": 46, "r": 10, "t": 26, "b": 40}
    w, h = panel_w - m["l"] - m["r"], panel_h - m["t"] - m["b"]
    parts = []
    for i, (title, series) in enumerate(panels.items()):
        ox = i * panel_w
        sizes = sorted({x for _, pts in series for x, _ in pts})
        span = (sizes[0], sizes[-1]) if len(sizes) > 1 else (sizes[0] - 1, sizes[0] + 1)

        def X(v):
            return ox + m["l"] + (math.log(v / span[0]) / math.log(span[1] / span[0])) * w \
                if span[0] > 0 else ox + m["l"] + (v - span[0]) / (span[1] - span[0]) * w

        def Y(r):
            return m["t"] + (1 - r) * h

        g = [f'<rect x="{ox + m["l"]}" y="{m["t"]}" width="{w}" height="{h}" fill="white" '
             f'stroke="#888"/>',
             f'<text x="{ox + m["l"] + w / 2}" y="16" text-anchor="middle" font-weight="bold">'
             f'{html.escape(title)}</text>']
        for r in (0.0, 0.5, 0.9, 1.0):
            g.append(f'<line x1="{ox + m["l"]}" y1="{Y(r):.1f}" x2="{ox + m["l"] + w}" '
                     f'y2="{Y(r):.1f}" stroke="{"#f4a" if r == 0.9 else "#ddd"}"/>')
            g.append(f'<text x="{ox + m["l"] - 4}" y="{Y(r) + 4:.1f}" '
                     f'text-anchor="end">{r:g}</text>')
        for v in sizes:
            g.append(f'<text x="{X(v):.1f}" y="{m["t"] + h + 14}" '
                     f'text-anchor="middle">{v:g}</text>')
        g.append(f'<text x="{ox + m["l"] + w / 2}" y="{panel_h - 6}" text-anchor="middle">'
                 f'{html.escape(x_label)}</text>')
        for k, (label, pts) in enumerate(series):
            c = RATE_COLOURS[k % len(RATE_COLOURS)]
            pts = sorted(pts)
            g.append(f'<polyline points="{" ".join(f"{X(x):.1f},{Y(r):.1f}" for x, r in pts)}" '
                     f'fill="none" stroke="{c}" stroke-width="2"/>')
            g += [f'<circle cx="{X(x):.1f}" cy="{Y(r):.1f}" r="3" fill="{c}"/>' for x, r in pts]
            ly = m["t"] + h - 8 - 14 * k
            g.append(f'<text x="{ox + m["l"] + w - 6}" y="{ly}" text-anchor="end" fill="{c}">'
                     f'{html.escape(label)}</text>')
        parts.append("\n".join(g))
    return _svg(parts, len(panels), panel_w, panel_h)
