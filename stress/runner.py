"""`snell stress`: run the stress cases (stress/cases.py), judge them, write the report.

Each case's error is judged against a bound derived from its own samples: exact cases against
float rounding plus the samples the integrator counted as ended early, statistical cases against
z * standard error with z Sidak-corrected so that all statistical cases together fail by chance
with probability ALPHA, one-sided cases against their stated bound. DIR/stress.json has stable
keys; DIR/stress.html has the table and the worst case's image and error map.
"""
from __future__ import annotations

import html
import math
import os
import time
import zlib
from statistics import NormalDist

import numpy as np

from ..pages.html_page import data_uri, page
from ..pages.images import colour_bar, diverging, png_bytes, upscale
from . import extremes, glass, lens, lights
from .cases import AT_MOST, EXACT, STATISTICAL, UNSUPPORTED, Case
from ..tracer.image import to_srgb8
from ..tracer.provenance import provenance

ALPHA = 0.01
JSON_VERSION = 1
CASE_KEYS = ("id", "group", "measures", "failure_means", "check", "analytic", "measured",
             "standard_error", "error", "error_in_se", "bound", "tolerance", "allowance", "events",
             "nan_inf", "time_s", "status", "passed", "expected_failure", "note", "settings")


def all_cases(quick: bool = False) -> list[Case]:
    """Every case of the matrix, or the --quick subset."""
    cases = (glass.furnace_cases() + glass.slab_cases() + glass.nested_cases()
             + lens.lens_cases() + lights.light_cases()
             + glass.degenerate_cases() + extremes.extreme_cases(quick))
    return [c for c in cases if c.quick] if quick else cases


def z_critical(n_statistical: int, alpha: float = ALPHA) -> float:
    """Two-sided normal quantile for a Sidak-corrected family-wise error alpha over n tests."""
    # The standard library's normal quantile: `snell stress` needs no scipy.
    per_case = 1.0 - (1.0 - alpha) ** (1.0 / max(n_statistical, 1))
    return NormalDist().inv_cdf(1.0 - per_case / 2.0)


def case_seed(case_id: str) -> int:
    """A fixed seed per case, so that cases are independent samples and reruns are identical."""
    return zlib.crc32(case_id.encode("utf-8")) & 0x7FFFFFFF


def judge(case, outcome, z: float) -> dict:
    """The table row of one case: error, bound, status ('pass', 'FAIL', 'expected failure',
    'unexpected pass', 'not supported') and `severity`, the error over its bound."""
    row = {"id": case.id, "group": case.group, "measures": case.measures,
           "failure_means": case.failure_means, "check": case.check, "analytic": case.analytic,
           "expected_failure": case.expected_failure or None, "measured": None,
           "standard_error": None, "error": None, "error_in_se": None, "bound": None,
           "tolerance": None, "allowance": None, "events": None, "nan_inf": None,
           "note": "", "settings": {}}
    if case.check == UNSUPPORTED or outcome is None:
        row.update(status=UNSUPPORTED, passed=True, severity=0.0, note=case.failure_means)
        return row
    m, a = outcome.measured, case.analytic
    err = m - a
    row.update(measured=m, error=err, tolerance=outcome.tolerance, allowance=outcome.allowance,
               events=outcome.events, nan_inf=outcome.nan_count, note=outcome.note,
               settings=outcome.settings, standard_error=outcome.se)
    if case.check == EXACT:
        # The deficit must equal the counted early ends, to rounding.
        row["bound"] = outcome.tolerance + outcome.allowance
        miss = abs(err + outcome.allowance)
        ok = miss <= outcome.tolerance
        severity = (miss / outcome.tolerance if outcome.tolerance > 0
                    else (0.0 if miss == 0 else math.inf))
    elif case.check == STATISTICAL:
        se = outcome.se or 0.0
        row["bound"] = z * se
        row["error_in_se"] = err / se if se > 0 else (0.0 if err == 0 else math.inf)
        ok = abs(err) <= z * se
        severity = abs(row["error_in_se"]) / z
    else:    # AT_MOST
        row["bound"] = a + outcome.allowance
        ok = m <= row["bound"]
        severity = m / row["bound"] if row["bound"] > 0 else (0.0 if m <= 0 else math.inf)
    ok = ok and outcome.nan_count == 0 and math.isfinite(m)
    if not math.isfinite(m):
        severity = math.inf
    if case.expected_failure:
        status = "expected failure" if not ok else "unexpected pass"
        passed = not ok
    else:
        status, passed = ("pass" if ok else "FAIL"), ok
    row.update(status=status, passed=passed, severity=severity)
    return row


def run(cases=None, quick=False, threads=2, log=None, family_size=None) -> dict:
    """Run the cases (default: the full matrix or the --quick subset) and judge them.

    family_size: how many statistical cases the Sidak correction spans (default: those run).
    Returns the report data (stable keys) with the worst case's images under "_worst".
    """
    cases = cases if cases is not None else all_cases(quick)
    n_stat = family_size or sum(1 for c in cases if c.check == STATISTICAL)
    z = z_critical(n_stat)
    rows, worst, worst_images = [], None, None
    start = time.perf_counter()
    for i, case in enumerate(cases):
        t0 = time.perf_counter()
        try:
            outcome = case.run(threads, case_seed(case.id)) if case.run is not None else None
        except Exception as exc:   # a crash is a finding: it goes into the table, not a traceback
            outcome = None
            row = judge(case, None, z)
            row.update(status="FAIL", passed=False, severity=math.inf,
                       note=f"raised {type(exc).__name__}: {' '.join(str(exc).split())}")
        else:
            row = judge(case, outcome, z)
        row["time_s"] = time.perf_counter() - t0
        rows.append(row)
        if log:
            log(f"[{i + 1}/{len(cases)}] {row['status']:<16} {case.id} ({row['time_s']:.1f} s)")
        has_images = outcome is not None and outcome.image is not None
        if has_images and (worst is None or _rank(row) > _rank(worst)):
            worst = row
            worst_images = (outcome.image, outcome.error_map, outcome.error_label)
    failed = [r["id"] for r in rows if not r["passed"]]
    data = {
        "version": JSON_VERSION, "quick": bool(quick), "threads": int(threads), "alpha": ALPHA,
        "statistical_cases": n_stat, "z_critical": z,
        "rule": (f"exact: |measured - (analytic - allowance)| <= tolerance (float rounding; the "
                 f"allowance is the integrator's counted early ends / samples); statistical: "
                 f"|error| <= {z:.3f} SE (Sidak over {n_stat} cases, family-wise alpha {ALPHA}); "
                 f"at most: measured <= bound; any NaN/Inf sample fails"),
        "cases": [{k: r.get(k) for k in CASE_KEYS} for r in rows],
        "passed": not failed, "failed": failed, "total_s": time.perf_counter() - start,
        "worst": worst["id"] if worst else None,
    }
    data["_worst"] = worst_images
    return data


def _rank(row):
    """Failures first, then cases not known to fail, then by error over bound."""
    return (not row["passed"], not row["expected_failure"],
            row["severity"] if math.isfinite(row["severity"]) else 1e300)


# ---------------------------------------------------------------------------------------------
# Output


def _num(x, digits=4):
    if x is None:
        return ""
    if isinstance(x, (int, np.integer)) and not isinstance(x, bool):
        return str(int(x))
    x = float(x)
    if not math.isfinite(x):
        return str(x)
    if x == 0.0:
        return "0"
    return f"{x:.{digits}g}"


def table_rows(data) -> list[list[str]]:
    """Rows of the summary table (strings), in case order."""
    rows = []
    for c in data["cases"]:
        se = f" ± {_num(c['standard_error'], 2)}" if c["standard_error"] is not None else ""
        if c["check"] == EXACT and c["bound"] is not None:
            bound = f"−{_num(c['allowance'], 3)} ± {_num(c['tolerance'], 2)}" \
                if c["allowance"] else f"± {_num(c['tolerance'], 2)}"
        elif c["check"] == AT_MOST and c["bound"] is not None:
            bound = f"≤ {_num(c['bound'])}"
        else:
            bound = f"± {_num(c['bound'], 3)}" if c["bound"] is not None else ""
        rows.append([c["id"], c["measures"], _num(c["analytic"], 6), _num(c["measured"], 6) + se,
                     _num(c["error"], 3), _num(c["error_in_se"], 3), bound, _num(c["nan_inf"]),
                     f"{c['time_s']:.1f}", c["status"]])
    return rows


HEADER = ["case", "measures", "analytic", "measured ± SE", "error", "error / SE", "bound",
          "NaN/Inf", "time s", "result"]


def terminal_table(data) -> str:
    """The table for a terminal: fixed-width columns, no 'measures' text."""
    keep = [0, 2, 3, 4, 5, 6, 7, 8, 9]
    rows = [[HEADER[i] for i in keep]] + [[r[i] for i in keep] for r in table_rows(data)]
    widths = [max(len(r[i]) for r in rows) for i in range(len(keep))]
    widths[0] = min(widths[0], 60)
    lines = []
    for r in rows:
        cells = [r[0][:60].ljust(widths[0])] + [r[i].rjust(widths[i]) for i in range(1, len(keep))]
        lines.append("  ".join(cells))
    return "\n".join(lines)


def markdown_table(data) -> str:
    """The table as Markdown (README), with what a failure would mean ('as above' when repeated)."""
    head = ["case", "measures", "analytic", "measured ± SE", "error / SE", "bound", "NaN/Inf",
            "result", "a failure would mean"]
    out = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    previous = (None, None)
    for c, r in zip(data["cases"], table_rows(data)):
        result = r[9] + (f": {c['expected_failure']}" if c["expected_failure"] else "")
        measures = "as above" if c["measures"] == previous[0] else c["measures"]
        failure = "as above" if c["failure_means"] == previous[1] else c["failure_means"]
        previous = (c["measures"], c["failure_means"])
        cells = [r[0], measures, r[2], r[3], r[5], r[6], r[7], result, failure]
        out.append("| " + " | ".join(x.replace("|", "/") for x in cells) + " |")
    return "\n".join(out)


def write_json(path, data):
    """stress.json: the report data without images, NaN/Inf as null."""
    import json

    def plain(v):
        if isinstance(v, dict):
            return {k: plain(x) for k, x in v.items() if not k.startswith("_")}
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        if isinstance(v, (float, np.floating)):
            return float(v) if math.isfinite(v) else None
        if isinstance(v, np.integer):
            return int(v)
        return v
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(plain({**data, "provenance": provenance()}), f,
                  indent=2, sort_keys=True, allow_nan=False)
    os.replace(tmp, path)


def write_html(path, data):
    """stress.html: the rule, the table and the worst case's image and error map."""
    rows = table_rows(data)
    head = HEADER + ["a failure would mean", "note"]
    out = ["<table>", "<tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in head) + "</tr>"]
    for c, r in zip(data["cases"], rows):
        cls = {"pass": "consistent", "FAIL": "inconsistent"}.get(c["status"], "not-comparable")
        cells = r + [c["failure_means"], (c["note"] or "") +
                     (f"; expected failure: {c['expected_failure']}"
                      if c["expected_failure"] else "")]
        out.append(f"<tr class='{cls}'>" + "".join(f"<td>{html.escape(str(x))}</td>" for x in cells)
                   + "</tr>")
    out.append("</table>")
    verdict = "all cases pass" if data["passed"] else f"{len(data['failed'])} case(s) FAIL"
    body = (f"<h1>snell stress{' --quick' if data['quick'] else ''}</h1>\n"
            f"<div class='verdict {'consistent' if data['passed'] else 'inconsistent'}'>"
            f"{html.escape(verdict)}</div>\n<p class='small'>{html.escape(data['rule'])}.</p>\n"
            + "\n".join(out) + _worst_figures(data))
    with open(path, "w") as f:
        f.write(page("snell stress", body))


def _worst_figures(data):
    images = data.get("_worst")
    if not images or images[0] is None:
        return ""
    image, error, label = images
    parts = [f"<h2>Worst case: {html.escape(data['worst'])}</h2>",
             f"<figure><img alt='image' src='{data_uri(png_bytes(upscale(to_srgb8(image), 256)))}'>"
             f"<figcaption>image (Standard view)</figcaption></figure>"]
    if error is not None:
        lim = float(np.nanmax(np.abs(error))) if np.size(error) else 0.0
        lim = lim if lim > 0 and math.isfinite(lim) else 1e-6
        parts.append("<figure><img alt='error' src='"
                     f"{data_uri(png_bytes(upscale(diverging(error, lim), 256)))}'>"
                     f"<figcaption>{html.escape(label)}<br><img class='bar' alt='scale' "
                     f"src='{data_uri(png_bytes(colour_bar(lim)))}'><br>"
                     f"<span class='small'>blue {-lim:.3g} · white 0 · red +{lim:.3g}</span>"
                     f"</figcaption></figure>")
    return "\n".join(parts)


def write_report(directory, data):
    """DIR/stress.json and DIR/stress.html, both or neither."""
    from ..tracer.atomic import atomic_directory
    with atomic_directory(directory) as tmp:
        write_json(os.path.join(tmp, "stress.json"), data)
        write_html(os.path.join(tmp, "stress.html"), data)
