"""The validator's subcommands, `snell compare`, `study`, `false-alarms` and `bench` (wired into
cli.py's COMMANDS).

Only arguments, checks and printed lines here: the renders run in compare.py, study.py,
false_alarms.py and bench.py (which need bpy), the statistics in metrics.py and
bench_curves.py, the pages in report.py and bench_report.py.
"""
from __future__ import annotations

import argparse
import os
import sys

from ..errors import (CliError, check_input_file, check_writable_directory, int_at_least,
                      number_at_least)
from ..tracer.settings import BY_NAME, DEFAULT_THREADS

# The render settings' ranges (tracer/settings.py), so that a value out of range is a usage error
# naming the option (exit 2), not a scene field's error after the scene was read. compare rounds
# --spp up to a multiple of its 16 batches: its most stays within the setting's.
MOST_SPP = BY_NAME["spp"].greatest - 15
MOST_SEED = BY_NAME["seed"].greatest
MOST_DEPTH = BY_NAME["max_depth"].greatest
MOST_THREADS = BY_NAME["threads"].greatest


def _common(p):
    p.add_argument("scene", metavar="SCENE.blend",
                   help="the Blender file to render in both renderers")
    p.add_argument("--report", required=True, metavar="DIR",
                   help="directory for report.html, metrics.json and the images (created)")
    p.add_argument("--spp", type=int_at_least(2, MOST_SPP),
                   help="samples per pixel for each renderer (default: the scene's); "
                        "Cycles renders --cycles-seeds seeds of spp / seeds samples")
    p.add_argument("--seed", type=int_at_least(0, MOST_SEED),
                   help="Snell seed; Cycles seeds derive from it")
    p.add_argument("--scale", type=int_at_least(1, 32767), metavar="PCT",
                   help="resolution percentage for both renderers (default: the file's)")
    p.add_argument("--cycles-seeds", type=int_at_least(2, 4096), default=8, metavar="K",
                   help="independent Cycles renders for the per-pixel variance (default 8)")
    p.add_argument("--threads", type=int_at_least(1, MOST_THREADS), default=DEFAULT_THREADS,
                   help="threads for each renderer "
                        f"(default: the machine's {DEFAULT_THREADS} cores)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")


def setup_compare(p):
    _common(p)
    p.add_argument("--max-depth", type=int_at_least(0, MOST_DEPTH), metavar="M",
                   help="emission plus up to M bounces = Cycles max_bounces M - 1 "
                        "(default: the scene's)")
    p.add_argument("--noise-threshold", type=number_at_least(0.0), default=0.0, metavar="T",
                   help="Snell samples adaptively at this threshold, --spp at most per pixel "
                        "(default 0: the same samples in every pixel); Cycles does not")


def setup_study(p):
    from .study import STUDIES  # bpy-free module
    p.add_argument("study", choices=sorted(STUDIES), help="which of the seed's studies")
    _common(p)


def _check(args):
    check_input_file(args.scene)
    check_writable_directory(args.report, "--report", report=True)


def _needs_bpy():
    try:
        import bpy  # noqa: F401
    except ModuleNotFoundError:
        raise CliError("snell compare/study need Blender's bpy module "
                       "(pip install 'snell[blender]')") from None


def cmd_compare(args) -> int:
    _check(args)
    _needs_bpy()
    from . import compare, report
    progress = compare.Progress(sys.stderr, enabled=not args.quiet)
    result = compare.compare_blend(args.scene, spp=args.spp, max_depth=args.max_depth,
                                   seed=args.seed, scale=args.scale, n_seeds=args.cycles_seeds,
                                   threads=args.threads, progress=progress,
                                   noise_threshold=args.noise_threshold)
    figures = []
    if "samples" in result["snell"]:
        from ..pages.sample_map import sample_map_png
        figures.append(("samples", sample_map_png(result["snell"]["samples"]),
                        "Snell's samples per pixel (adaptive sampling)"))
    data = report.write_comparison(args.report, result, figures=figures)
    html = os.path.join(args.report, "report.html")
    if result.get("cycles"):
        failed = data.get("failed_tests") or []
        alpha = data.get("alpha_channel")
        alpha = (f", alpha {alpha['verdict']} (mean {alpha['mean_snell']:.4f} vs "
                 f"{alpha['mean_cycles']:.4f})" if alpha else "")
        print(f"snell compare: {data['verdict']}{' (' + ', '.join(failed) + ')' if failed else ''}"
              f": z-pass {data['z_pass_fraction']:.4f}, relMSE {data['relmse']:.4g}, "
              f"FLIP {data['flip'] if data['flip'] is None else round(data['flip'], 4)}{alpha}, "
              f"Snell {data['snell']['time_s']:.1f}s, "
              f"Cycles {data['cycles']['time_s']:.1f}s -> {html}")
        for caveat in data.get("cycles_caveats") or []:
            print(f"snell compare: note: {caveat}")
    else:
        print(f"snell compare: {data['verdict']} ({'; '.join(data['not_comparable'])}) -> {html}")
    return 0


def cmd_study(args) -> int:
    _check(args)
    _needs_bpy()
    from . import compare, report, study
    progress = compare.Progress(sys.stderr, enabled=not args.quiet)
    rows = study.run_study(args.study, args.scene, spp=args.spp, seed=args.seed, scale=args.scale,
                           n_seeds=args.cycles_seeds, threads=args.threads, progress=progress)
    data = report.write_study(args.report, args.study, rows, study.NOTES[args.study])
    for row in data["settings"]:
        failed = row.get("failed_tests") or []
        print(f"snell study {args.study}: {row['label']}: {row['verdict']}"
              + (f" ({', '.join(failed)})" if failed else ""))
    print(f"snell study {args.study}: {data['verdict']} -> "
          f"{os.path.join(args.report, 'report.html')}")
    return 0


COMMANDS = [
    ("compare", "render a .blend in Snell and Cycles, test their agreement, write an HTML report",
     setup_compare, cmd_compare),
    ("study", "the seed's depth, focus or aperture study, Snell and Cycles side by side",
     setup_study, cmd_study),
]


def setup_false_alarms(p):
    from .false_alarms import BY_NAME, CONFIGS  # bpy-free module
    p.add_argument("--report", required=True, metavar="DIR",
                   help="directory for report.html and metrics.json (created)")
    p.add_argument("--runs", type=int_at_least(1), default=30,
                   help="independent runs per configuration (default 30)")
    p.add_argument("--config", action="append", choices=sorted(BY_NAME), metavar="NAME",
                   help="a configuration (repeat for more; default: every null configuration: "
                        + ", ".join(c.name for c in CONFIGS) + "); NAME:ERROR ones are power runs")
    p.add_argument("--power", action="store_true",
                   help="also the power runs (deliberate errors): their detection rates")
    p.add_argument("--cache", metavar="DIR", default=os.path.join("out", "false-alarms"),
                   help="where runs are kept, to evaluate again without rendering "
                        "(default out/false-alarms)")
    p.add_argument("--cached", action="store_true",
                   help="render nothing: evaluate the runs already in the cache (up to --runs)")
    p.add_argument("--threads", type=int_at_least(1, MOST_THREADS), default=DEFAULT_THREADS,
                   help="threads for each renderer "
                        f"(default: the machine's {DEFAULT_THREADS} cores)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")


def cmd_false_alarms(args) -> int:
    check_writable_directory(args.report, "--report", report=True)
    try:
        os.makedirs(args.cache, exist_ok=True)
    except OSError as exc:
        raise CliError(f"--cache {args.cache}: cannot create it ({exc.strerror})") from None
    _needs_bpy()
    from . import false_alarms as fa
    from . import report
    from .compare import Progress
    configs = ([fa.BY_NAME[n] for n in args.config] if args.config else
               list(fa.CONFIGS) + (list(fa.POWER) if args.power else []))
    progress = Progress(sys.stderr, enabled=not args.quiet)
    results = fa.evaluate(configs, args.cache, args.runs, args.threads,
                          lambda name, done, total: progress.line(
                              f"false alarms: {name}: run {done}/{total}", final=done == total),
                          render=not args.cached)
    rows, overall = fa.summary(results)
    report.write_false_alarms(args.report, rows, overall, configs, fa.CURVES)
    for test, (fails, n, rate, lo, hi) in overall.items():
        print(f"snell false-alarms: {test}: {fails}/{n} = {rate:.3f} (95% {lo:.3f}-{hi:.3f})")
    print(f"snell false-alarms: -> {os.path.join(args.report, 'report.html')}")
    return 0


COMMANDS.append(("false-alarms", "how often the verdict calls correct renders inconsistent: "
                 "null runs over seeds, rates with 95%% intervals", setup_false_alarms,
                 cmd_false_alarms))


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


def setup_bench(p):
    """Add `snell bench`'s arguments."""
    p.add_argument("scenes", nargs="*", metavar="SCENE.blend",
                   help="scenes to bench (default: scenes/cornell_spheres.blend and "
                        "scenes/cornell_dragon.blend)")
    p.add_argument("--report", required=True, metavar="DIR",
                   help="directory for bench.json, bench.html and bench.svg (created)")
    p.add_argument("--quick", action="store_true",
                   help="smoke test: 25%% resolution, ladder 4, 8, 16 spp, "
                        "reference 4 seeds x 64 spp, thresholds 0.1 and 0.03 with at most 256 spp")
    p.add_argument("--threads", type=int_at_least(1, MOST_THREADS),
                   help="threads for each renderer (default 2)")
    p.add_argument("--max-depth", type=int_at_least(1, MOST_DEPTH), metavar="M", help="default 8")
    p.add_argument("--scale", type=int_at_least(1), metavar="PCT",
                   help="resolution percentage (default 100, --quick 25)")
    p.add_argument("--min-spp", type=int_at_least(1, MOST_SPP),
                   help="bottom of the ladder (default 1, --quick 4)")
    p.add_argument("--max-spp", type=int_at_least(1, MOST_SPP),
                   help="top of the ladder (default 1024, --quick 16)")
    p.add_argument("--time-cap", type=float, metavar="S",
                   help="stop a ladder before a point predicted to take longer "
                        "(default 60, --quick 20)")
    p.add_argument("--ref-seeds", type=int_at_least(2), metavar="K",
                   help="Cycles seeds of the reference (default 16, --quick 4)")
    p.add_argument("--ref-spp", type=int_at_least(1, MOST_SPP), metavar="N",
                   help="samples per reference seed (default 256, --quick 64)")
    p.add_argument("--repeat", type=int_at_least(1), metavar="N",
                   help="time every point N times and keep the run of median wall time (default 1)")
    p.add_argument("--caustics", choices=("on", "off", "both"),
                   help="Snell's caustics light tracer: on (default), off, or both (a second "
                        "Snell ladder with the path tracer alone)")
    p.add_argument("--thresholds", type=thresholds, metavar="T,T,...",
                   help="noise thresholds of the 'as users render' comparison, both renderers "
                        "adaptive (default 0.1,0.03,0.01,0.003, --quick 0.1,0.03; 'none': skip it)")
    p.add_argument("--adaptive-max-spp", type=int_at_least(1, MOST_SPP), metavar="N",
                   help="per-pixel sample cap of both renderers in that comparison "
                        "(default 1024, --quick 256)")
    p.add_argument("--denoise", action="store_true",
                   help="also a ladder of each renderer denoised by Open Image Denoise (albedo "
                        "and normal), held against the same reference (not tested: a denoised "
                        "image is biased); without SCENEs also scenes/glass_wall.blend")
    p.add_argument("--denoise-prefilter", choices=("none", "fast", "accurate"),
                   help="both renderers' denoising prefilter (default accurate, Cycles')")
    p.add_argument("--denoise-quality", choices=("high", "balanced", "fast"),
                   help="both renderers' denoising quality (default high, Cycles')")
    p.add_argument("--caustic-scenes", nargs="?", const="all", metavar="NAME,...",
                   help="bench issue 34's caustic scenes instead of the default ones (all, or "
                        "those named: sun_caustic, hdri_caustic, pool, tumbler_caustic; built "
                        "into the cache from scenes/*.py): Snell with and without the new "
                        "strategy, Cycles with its shadow caustics, and the targets")
    p.add_argument("--cache", metavar="DIR", help="reference cache (default ~/.cache/snell/bench)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")


def bench_scene_list(args, bench, log) -> tuple:
    """(the scenes `snell bench` runs, {path: BenchScene} of the caustic ones) for its args."""
    if args.caustic_scenes:
        if args.scenes:
            raise CliError("give SCENEs or --caustic-scenes, not both")
        from . import bench_scenes
        try:
            built = bench_scenes.build(args.cache or bench.default_cache_dir(), log,
                                       bench_scenes.select(args.caustic_scenes))
        except (RuntimeError, ValueError) as exc:
            raise CliError(str(exc)) from None
        return [path for path, _ in built], dict(built)
    scenes = args.scenes or bench.DEFAULT_SCENES + (bench.DENOISE_SCENES if args.denoise else [])
    for s in scenes:
        if s in bench.DEFAULT_SCENES + bench.DENOISE_SCENES and not os.path.exists(s):
            raise CliError(f"{s}: no such file (build it with scenes/build_all.py)")
        check_input_file(s)
    return scenes, {}


def caustic_summary(sc) -> str:
    """One line of a caustic scene's targets (bench_curves.caustic_targets)."""
    from .bench_report import fmt
    ct = sc["caustic_targets"]
    s, w = ct["snell"], ct["snell_without"]
    return (f"snell bench: {sc['name']}: caustic relMSE at equal time, Snell / Cycles = "
            f"{fmt(s['caustic_relmse_ratio'])} (at most {ct['caustic_relmse_target']:g}: "
            f"{'met' if s['caustic_met'] else 'not met'}; without the new strategy "
            f"{fmt(w['caustic_relmse_ratio'])}); time to equal error {fmt(s['time_ratio'])} (at "
            f"most {ct['time_target']:g}: {'met' if s['time_met'] else 'not met'}; without "
            f"{fmt(w['time_ratio'])})" + (" [merging is biased: its error includes bias]"
                                          if ct["setup"]["biased"] else ""))


def cmd_bench(args) -> int:
    """Run `snell bench`; the exit status."""
    try:
        from . import bench
        from .bench_report import fmt, markdown_table
    except ModuleNotFoundError as exc:
        if exc.name != "bpy":
            raise
        raise CliError("snell bench needs Blender's bpy module "
                       "(pip install 'snell[blender]')") from None
    log = (lambda s: None) if args.quiet else (lambda s: print(f"snell bench: {s}", file=sys.stderr,
                                                               flush=True))
    check_writable_directory(args.report, "--report", report=True)
    scenes, setups = bench_scene_list(args, bench, log)
    opts = bench.Options(**(bench.QUICK if args.quick else {}))
    for name, attr in (("threads", "threads"), ("max_depth", "max_depth"), ("scale", "scale"),
                       ("min_spp", "min_spp"), ("max_spp", "max_spp"), ("time_cap", "time_cap_s"),
                       ("ref_seeds", "ref_seeds"),
                       ("ref_spp", "ref_spp"), ("repeat", "repeat"), ("caustics", "caustics"),
                       ("thresholds", "thresholds"), ("adaptive_max_spp", "adaptive_max_spp"),
                       ("denoise_prefilter", "denoise_prefilter"),
                       ("denoise_quality", "denoise_quality")):
        if getattr(args, name) is not None:
            setattr(opts, attr, getattr(args, name))
    opts.denoise = args.denoise
    try:
        data = bench.run(scenes, args.report, opts, cache_dir=args.cache, log=log, setups=setups)
    except bench.PointError as exc:
        raise CliError(str(exc)) from None
    print(markdown_table(data))
    for sc in data["scenes"]:
        eq = sc["time_to_equal_error"]
        print(f"snell bench: {sc['name']}: time to relMSE {eq['target_relmse']:.3g}: "
              f"Snell / Cycles = {fmt(eq['ratio'])} (fits {fmt(eq['fit_ratio'])})")
        if "path_tracer_time_to_equal_error" in sc:
            pt = sc["path_tracer_time_to_equal_error"]
            print(f"snell bench: {sc['name']}: path tracer only: time to relMSE "
                  f"{pt['target_relmse']:.3g}: Snell / Cycles = {fmt(pt['ratio'])}")
        if "caustic_gain_at_equal_time" in sc:
            print(f"snell bench: {sc['name']}: caustic region relMSE at equal time: path tracer "
                  f"only / hybrid = {fmt(sc['caustic_gain_at_equal_time']['median'])}")
        if "adaptive" in sc:
            at = sc["adaptive"]["map_threshold"]
            eq = next(e for e in sc["adaptive"]["equal_threshold"] if e["threshold"] == at)
            print(f"snell bench: {sc['name']}: adaptive at threshold {at:g}: Snell / Cycles at "
                  f"equal error = {fmt(eq['ratio'])} (time {fmt(eq['time_ratio'])}, "
                  f"relMSE {fmt(eq['relmse_ratio'])} at equal threshold)")
        if "caustic_targets" in sc:
            print(caustic_summary(sc))
        if "denoised" in sc:
            a, b = sc["denoised"]["time_target"], sc["denoised"]["fewer_samples_target"]
            print(f"snell bench: {sc['name']}: denoised (not tested): (a) time to Cycles + OIDN's "
                  f"error, Snell / Cycles = {fmt(a['relmse']['ratio'])} on relMSE, "
                  f"{fmt(a['flip']['ratio'])} on FLIP (target at most {a['share']:g}: "
                  f"{'met' if a['met'] else 'not met'}); (b) FLIP denoised at n / undenoised at "
                  f"{b['factor']} n: " + (", ".join(f"{r['spp']} spp {fmt(r['ratio'])}"
                                                    for r in b["points"]) or "no point")
                  + f" (below 1: {'met' if b['met'] else 'not met'})")
    print(f"snell bench: {data['total_s']:.1f} s -> {os.path.join(args.report, 'bench.html')}")
    return 0


COMMANDS.append(("bench", "Snell and Cycles at a ladder of sample counts: error against time, "
                 "JSON and HTML", setup_bench, cmd_bench))
