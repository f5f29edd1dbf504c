"""`snell bench` (wired into cli.py's COMMANDS): arguments, checks and the printed summary.

The renders run in addon/bench.py (which needs bpy), the numbers, JSON and pages in
compare/bench.py; this module sits above both so that neither imports the other's caller.
"""
from __future__ import annotations

import argparse
import os
import sys

from ..errors import CliError, check_input_file, check_writable_directory, int_at_least
from . import bench_curves


def thresholds(text):
    """A --thresholds value: comma-separated numbers above 0, or 'none' (no thresholds)."""
    if text.strip().lower() == "none":
        return ()
    try:
        values = tuple(float(t) for t in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected numbers like 0.1,0.01") from None
    if not all(0 < v < 1 for v in values):  # Cycles' adaptive_threshold is a positive share
        raise argparse.ArgumentTypeError(f"{text!r}: each threshold must be above 0 and below 1")
    return values


def setup_cli(p):
    """Add `snell bench`'s arguments."""
    p.add_argument("scenes", nargs="*", metavar="SCENE.blend",
                   help="scenes to bench (default: scenes/cornell_spheres.blend and "
                        "scenes/cornell_dragon.blend)")
    p.add_argument("--report", required=True, metavar="DIR",
                   help="directory for bench.json, bench.html and bench.svg (created)")
    p.add_argument("--quick", action="store_true",
                   help="smoke test: 25%% resolution, ladder 4, 8, 16 spp, reference 4 seeds x 64 spp, "
                        "thresholds 0.1 and 0.03 with at most 256 spp")
    p.add_argument("--threads", type=int_at_least(1), help="threads for each renderer (default 2)")
    p.add_argument("--max-depth", type=int_at_least(1), metavar="M", help="default 8")
    p.add_argument("--scale", type=int_at_least(1), metavar="PCT",
                   help="resolution percentage (default 100, --quick 25)")
    p.add_argument("--min-spp", type=int_at_least(1), help="bottom of the ladder (default 1, --quick 4)")
    p.add_argument("--max-spp", type=int_at_least(1), help="top of the ladder (default 1024, --quick 16)")
    p.add_argument("--time-cap", type=float, metavar="S",
                   help="stop a ladder before a point predicted to take longer (default 60, --quick 20)")
    p.add_argument("--ref-seeds", type=int_at_least(2), metavar="K",
                   help="Cycles seeds of the reference (default 16, --quick 4)")
    p.add_argument("--ref-spp", type=int_at_least(1), metavar="N",
                   help="samples per reference seed (default 256, --quick 64)")
    p.add_argument("--repeat", type=int_at_least(1), metavar="N",
                   help="time every point N times and keep the run of median wall time (default 1)")
    p.add_argument("--caustics", choices=("on", "off", "both"),
                   help="Snell's caustics light tracer: on (default), off, or both (a second "
                        "Snell ladder with the path tracer alone)")
    p.add_argument("--thresholds", type=thresholds, metavar="T,T,...",
                   help="noise thresholds of the 'as users render' comparison, both renderers "
                        "adaptive (default 0.1,0.03,0.01,0.003, --quick 0.1,0.03; 'none': skip it)")
    p.add_argument("--adaptive-max-spp", type=int_at_least(1), metavar="N",
                   help="per-pixel sample cap of both renderers in that comparison "
                        "(default 1024, --quick 256)")
    p.add_argument("--cache", metavar="DIR", help="reference cache (default ~/.cache/snell/bench)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")


def cmd(args) -> int:
    """Run `snell bench`; the exit status."""
    try:
        from . import bench
    except ModuleNotFoundError as exc:
        if exc.name != "bpy":
            raise
        raise CliError("snell bench needs Blender's bpy module (pip install 'snell[blender]')") from None
    scenes = args.scenes or bench.DEFAULT_SCENES
    for s in scenes:
        if s in bench.DEFAULT_SCENES and not os.path.exists(s):
            raise CliError(f"{s}: no such file (build it with scenes/build_all.py)")
        check_input_file(s)
    check_writable_directory(args.report, "--report", report=True)
    opts = bench.Options(**(bench.QUICK if args.quick else {}))
    for name, attr in (("threads", "threads"), ("max_depth", "max_depth"), ("scale", "scale"),
                       ("min_spp", "min_spp"), ("max_spp", "max_spp"), ("time_cap", "time_cap_s"), ("ref_seeds", "ref_seeds"),
                       ("ref_spp", "ref_spp"), ("repeat", "repeat"), ("caustics", "caustics"),
                       ("thresholds", "thresholds"), ("adaptive_max_spp", "adaptive_max_spp")):
        if getattr(args, name) is not None:
            setattr(opts, attr, getattr(args, name))
    log = (lambda s: None) if args.quiet else (lambda s: print(f"snell bench: {s}", file=sys.stderr, flush=True))
    try:
        data = bench.run(scenes, args.report, opts, cache_dir=args.cache, log=log)
    except bench.PointError as exc:
        raise CliError(str(exc)) from None
    print(bench_curves.markdown_table(data))
    for sc in data["scenes"]:
        eq = sc["time_to_equal_error"]
        print(f"snell bench: {sc['name']}: time to relMSE {eq['target_relmse']:.3g}: Snell / Cycles = "
              f"{bench_curves.fmt(eq['ratio'])} (fits {bench_curves.fmt(eq['fit_ratio'])})")
        if "path_tracer_time_to_equal_error" in sc:
            pt = sc["path_tracer_time_to_equal_error"]
            print(f"snell bench: {sc['name']}: path tracer only: time to relMSE "
                  f"{pt['target_relmse']:.3g}: Snell / Cycles = {bench_curves.fmt(pt['ratio'])}")
        if "caustic_gain_at_equal_time" in sc:
            print(f"snell bench: {sc['name']}: caustic region relMSE at equal time: path tracer "
                  f"only / hybrid = {bench_curves.fmt(sc['caustic_gain_at_equal_time']['median'])}")
        if "adaptive" in sc:
            at = sc["adaptive"]["map_threshold"]
            eq = next(e for e in sc["adaptive"]["equal_threshold"] if e["threshold"] == at)
            print(f"snell bench: {sc['name']}: adaptive at threshold {at:g}: Snell / Cycles at "
                  f"equal error = {bench_curves.fmt(eq['ratio'])} (time {bench_curves.fmt(eq['time_ratio'])}, "
                  f"relMSE {bench_curves.fmt(eq['relmse_ratio'])} at equal threshold)")
    print(f"snell bench: {data['total_s']:.1f} s -> {os.path.join(args.report, 'bench.html')}")
    return 0


CLI = ("bench", "Snell and Cycles at a ladder of sample counts: error against time, JSON and HTML",
       setup_cli, cmd)
