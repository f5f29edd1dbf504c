"""The validator's false alarms and power before and after a change of its statistics, over the
same cached runs (`snell false-alarms --power` renders them), as Markdown tables.

Run: python tools/measure_validator_change.py --cache out/false-alarms --old OLD_METRICS.py
OLD_METRICS.py is an earlier validation/metrics.py (git show REV:validation/metrics.py > FILE;
compare/metrics.py before issue 28); its compare(a, va, dfa, b, vb, dfb, halves=...) is applied
as that revision's validate.py did (the reference's seeds split in halves for its sharpness
test). The runs are rendered as the current validator renders them, so the "before" column
isolates the statistics.
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import sys

import numpy as np

from snell.validation import false_alarms as fa
from snell.validation import metrics


def old_compare(module, a, b):
    """The old module's statistics of one run, as its compare.compare_renders computed them."""
    k = len(b)
    halves = None
    if k >= 4:
        first, second = b[:k // 2], b[k // 2:]
        halves = (first.mean(axis=0), second.mean(axis=0),
                  second.var(axis=0, ddof=1) / len(second), len(second) - 1)
    return module.compare(a.mean(axis=0), a.var(axis=0, ddof=1) / len(a), len(a) - 1,
                          b.mean(axis=0), b.var(axis=0, ddof=1) / k, k - 1, halves=halves)


def load_module(path):
    spec = importlib.util.spec_from_file_location("old_metrics", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.flip = lambda *args: None        # not needed, and slow
    return module


def verdicts(configs, cache, runs, old):
    """{name: ([new results], [old results])} over the cached runs."""
    out = {}
    for c in configs:
        new, before = [], []
        for path in fa.run_paths(c, cache)[:runs]:
            a, b, light = fa.load_run(path)
            new.append(metrics.compare_estimates(*fa.estimates(a, b, light), error_metrics=False))
            before.append(old_compare(old, a, b))
        if new:
            out[c.name] = (new, before)
    return out


def fmt(rate):
    fails, n, r, lo, hi = rate
    return f"{fails}/{n} = {r:.3f} ({lo:.3f}-{hi:.3f})"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--cache", default="out/false-alarms")
    p.add_argument("--old", required=True, help="an earlier validation/metrics.py")
    p.add_argument("--runs", type=int, default=30)
    args = p.parse_args(argv)
    old = load_module(args.old)

    null = verdicts(fa.CONFIGS, args.cache, args.runs, old)
    print("## False alarms (null runs)\n")
    print(f"{sum(len(n) for n, _ in null.values())} runs over {len(null)} configurations.\n")
    print("| test | after | before |\n| --- | --- | --- |")
    new_all = [r for n, _ in null.values() for r in n]
    old_all = [r for _, o in null.values() for r in o]
    new_rates, old_rates = fa.failure_rates(new_all), fa.failure_rates(old_all)
    for test in new_rates:
        print(f"| {test} | {fmt(new_rates[test])} | {fmt(old_rates[test])} |")
    exact = [c.name for c in fa.CONFIGS if c.mode == fa.EXACT]
    for label, names in (("Snell against Cycles", [n for n in null if n not in exact]),
                         ("Cycles against Cycles (exact null)", [n for n in null if n in exact])):
        rn = fa.failure_rates([r for n in names for r in null[n][0]])
        ro = fa.failure_rates([r for n in names for r in null[n][1]])
        print(f"| verdict, {label} | {fmt(rn['verdict'])} | {fmt(ro['verdict'])} |")
    print("\n| configuration | runs | failed after (tests) | failed before (tests) |")
    print("| --- | --- | --- | --- |")
    for name, (new, before) in null.items():
        def tally(results):
            counts = {}
            for r in results:
                for t, ok in r["tests"].items():
                    counts[t] = counts.get(t, 0) + (not ok)
            fails = sum(r["verdict"] != "consistent" for r in results)
            return f"{fails} ({', '.join(f'{t} {n}' for t, n in counts.items() if n) or '-'})"
        print(f"| {name} | {len(new)} | {tally(new)} | {tally(before)} |")

    for title, configs in (("The deliberate errors of tests/validation/test_compare.py", fa.TEETH),
                           ("Power: errors of growing size", fa.CURVES)):
        rows = verdicts(configs, args.cache, args.runs, old)
        if rows:
            print(f"\n## {title}: runs caught\n")
            print("| error | runs | after | before |\n| --- | --- | --- | --- |")
            for name, (new, before) in rows.items():
                caught = [sum(r["verdict"] != "consistent" for r in rs) for rs in (new, before)]
                print(f"| {name} | {len(new)} | {caught[0]} | {caught[1]} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
