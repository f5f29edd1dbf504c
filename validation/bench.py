"""`snell bench`: Snell and Cycles at a ladder of sample counts against a converged reference,
then both adaptive at the same noise thresholds ("as users render", _adaptive_comparison), and
with --denoise both denoised by Open Image Denoise (_denoised_comparison; not tested: the
validator never sees a denoised image, only this bench and its page, marked so, do).

For each scene: a reference (a long Cycles render as K seeds, cached on disk, see cache_key),
then for each renderer the ladder 1, 2, 4, ... spp until max_spp or until the next point is
predicted (twice this point's wall time) to pass the time cap. Each point
runs in its own child process (`python -m snell.validation.bench point SPEC OUT`) so that its peak
memory is its own: the child's VmHWM (peak RSS of its own address space; ru_maxrss is not used
because Linux carries the parent's high-water mark into it over fork and exec), which includes
Python, numpy and the bpy module (reported too, as the baseline of a child that only imports them)
and native memory (Embree's BVH, Cycles' scene). The times are measured inside the child, as the
user waits in an
open Blender: Snell = export of the .blend + scene build (Embree BVH) + render; Cycles = loading
the .blend + render (including its EXR write). Interpreter start-up and `import bpy` are excluded.
"""
from __future__ import annotations

import hashlib
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, replace

import numpy as np

from ..addon.console import stdout_silenced
from ..pages.sample_map import sample_map_png
from ..tracer.atomic import atomic_directory, atomic_path
from . import bench_scenes, cycles, metrics
from .bench_curves import (ADAPTIVE_RENDERERS, CAUSTIC_SHARE, FEWER_SAMPLES, TIME_SHARE_TARGET,
                           caustic_targets, denoised_time_target, efficiency_summary,
                           equal_error, equal_threshold, equal_time_pair, errors,
                           fewer_samples_target, flip_map,
                           gain_at_equal_time, light_share, median_run, nearest_threshold,
                           next_spp, reference_noise, sample_summary)
from .bench_report import (SCHEMA, denoised_figures_png, equal_time_png, share_map_png, svg_plot,
                           write_html, write_json)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_SCENES = [os.path.join(REPO, "scenes", "cornell_spheres.blend"),
                  os.path.join(REPO, "scenes", "cornell_dragon.blend")]
# Added to the default scenes by --denoise: a textured wall seen through a drinking glass, where
# a denoiser's guiding passes must follow the specular chain.
DENOISE_SCENES = [os.path.join(REPO, "scenes", "glass_wall.blend")]
SNELL_SEED = 7          # Snell's seed for every ladder point
CYCLES_SEED = 90001     # Cycles' seed for every ladder point (the reference uses seeds 1..K)


@dataclass
class Options:
    threads: int = 2
    max_depth: int = 8
    scale: int = 100          # resolution percentage for every render
    min_spp: int = 1          # bottom of the ladder
    max_spp: int = 1024
    time_cap_s: float = 60.0  # per ladder point (predicted)
    ref_seeds: int = 16
    ref_spp: int = 256        # per seed
    quick: bool = False
    repeat: int = 1           # runs per point; the run of median wall time is kept
    caustics: str = "on"      # Snell's light tracer: "on", "off", or "both" (a ladder of each)
    # "As users render": both renderers adaptive at these noise thresholds, each pixel capped at
    # adaptive_max_spp samples (empty: no such comparison).
    thresholds: tuple = (0.1, 0.03, 0.01, 0.003)
    adaptive_max_spp: int = 1024
    # The denoised comparison: a ladder of each renderer denoised by Open Image Denoise, guided
    # by albedo and normal, with this prefilter and quality (Cycles' defaults) for both.
    denoise: bool = False
    denoise_prefilter: str = "accurate"
    denoise_quality: str = "high"


QUICK = dict(scale=25, min_spp=4, max_spp=16, time_cap_s=20.0, ref_seeds=4, ref_spp=64, quick=True,
             thresholds=(0.1, 0.03), adaptive_max_spp=256)


def default_cache_dir() -> str:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "snell", "bench")


# ---------------------------------------------------------------------------------------------
# Child process: one ladder point


def _snell_point(spec):
    from ..tracer.integrator import Renderer
    from ..addon.export import export_blend
    start = time.perf_counter()
    scene, _ = export_blend(spec["blend"])
    export_s = time.perf_counter() - start
    scene = scene.with_render(spp=spec["spp"], max_depth=spec["max_depth"], seed=SNELL_SEED)
    if spec["scale"] != 100:
        scene = scene.with_camera(resolution_percentage=spec["scale"])
    t = time.perf_counter()
    # Ladder points sample every pixel equally (threshold 0, whatever the scene says); adaptive
    # points use Cycles' automatic minimum (min_spp 0), as Cycles does beside them. A denoised
    # point renders the Denoising Albedo and Normal passes and denoises as `snell render
    # --denoise` does, whatever the file's own Denoise settings.
    denoise = spec.get("denoise")
    # Both renderers as validation.cycles.forced_settings has Cycles render (AS_FORCED).
    # A caustic scene's strategy on or off (bench_scenes.py) over the bench's caustics switch.
    strategy = {"caustics": spec["caustics"], **(spec.get("snell") or {})}
    settings = scene.settings(threads=spec["threads"], **strategy, **cycles.AS_FORCED,
                              noise_threshold=spec["threshold"] or 0.0, min_spp=0,
                              time_limit=0.0, denoise=bool(denoise),
                              denoising_passes=bool(denoise),
                              **({"denoising_input_passes": "albedo_normal",
                                  "denoising_prefilter": denoise["prefilter"],
                                  "denoising_quality": denoise["quality"]} if denoise else {}))
    renderer = Renderer(scene, settings)
    build_s = time.perf_counter() - t
    result = renderer.render()
    image = noisy = result.mean()
    extra = {}
    if denoise:
        from ..tracer.denoise import denoise_result
        t = time.perf_counter()
        outcome = denoise_result(result, settings)
        if not outcome.denoised:      # never report a noisy image as a denoised one
            raise RuntimeError(f"denoising failed: {outcome.warning}")
        extra = {"denoise_s": time.perf_counter() - t, "oidn_s": outcome.seconds,
                 "nan_guides": outcome.nan_guides}
        image = outcome.image
    wall = time.perf_counter() - start
    light = result.light_image().astype(np.float32) if result.light_in_image else None
    return image, (noisy if denoise else None), light, result.samples(), {**extra,
        "saved_share": result.saved_share, "export_s": export_s, "build_s": build_s,
        "render_s": result.time_s, "wall_s": wall,
        "rays_per_second": result.rays_per_second, "rays": result.rays,
        "embree_share": result.embree_share,
        "embree_share_of_wall": result.embree_time_s / (wall * result.threads),
        "nan_samples": result.nan_count, "threads": result.threads,
        "light_paths": result.light_paths, "caustic_splats": result.stats.get("caustic_splats", 0),
        "skipped_stages": sorted(name for name, (runs, _) in result.stages.items() if not runs),
        "stages": {name: {"runs": runs, "why": why} for name, (runs, why) in result.stages.items()}}


def _cycles_point(spec):
    import bpy

    from ..tracer.image import read_exr
    from ..addon.blendfile import open_blend
    if spec["threshold"]:
        settings = cycles.adaptive_settings(spec["max_depth"], spec["threshold"], spec["spp"],
                                            CYCLES_SEED, spec["threads"])
    else:
        settings = cycles.forced_settings(spec["max_depth"], spec["spp"], CYCLES_SEED,
                                          spec["threads"])
    if spec.get("denoise"):
        settings = cycles_denoised(settings, spec["denoise"]["prefilter"],
                                   spec["denoise"]["quality"])
    # A caustic scene's Cycles as users would set it up (bench_scenes.py), applied last.
    settings = settings + [tuple(s) for s in spec.get("cycles") or ()]
    camera = {"resolution_percentage": spec["scale"]} if spec["scale"] != 100 else None
    with tempfile.TemporaryDirectory(prefix="snell-bench-") as workdir:
        out = os.path.join(workdir, "cycles.exr")
        start = time.perf_counter()
        open_blend(spec["blend"])
        scene = bpy.context.scene
        cycles._apply(scene, settings)
        cycles._apply_camera(scene, camera)
        scene.render.filepath = out
        load_s = time.perf_counter() - start
        stats = []

        def record(*args):                # Blender passes the stats line (and maybe more)
            stats.extend(a for a in args if isinstance(a, str))

        bpy.app.handlers.render_stats.append(record)
        t = time.perf_counter()
        try:
            bpy.ops.render.render(write_still=True)
        finally:
            bpy.app.handlers.render_stats.remove(record)
        render_s = time.perf_counter() - t
        wall = time.perf_counter() - start
        rgb = read_exr(out).astype(np.float32)
        counts = (cycles.read_sample_count(out, cycles.samples_rendered(stats, spec["spp"]))
                  if spec["threshold"] else None)
    return rgb, counts, {"load_s": load_s, "render_s": render_s, "wall_s": wall,
                         "threads": spec["threads"]}


def _child(spec_path, out_path):
    with open(spec_path) as f:
        spec = json.load(f)
    import bpy  # noqa: F401  (the baseline: what every point pays before it starts)

    from ..tracer import integrator
    # Loaded once per session in an open Blender: not part of what a render point costs.
    integrator.warm_up()
    light = counts = noisy = None
    if spec["kind"] == "baseline":
        image, stats = np.zeros((1, 1, 3), np.float32), {}
    elif spec["kind"] == "snell":
        image, noisy, light, counts, stats = _snell_point(spec)
    else:
        image, counts, stats = _cycles_point(spec)
    stats["peak_rss_mb"] = _own_peak_rss_mb()
    np.save(out_path + ".npy", image)
    for suffix, array in (("_light", light), ("_samples", counts), ("_noisy", noisy)):
        if array is not None:
            np.save(out_path + suffix + ".npy", array)
    with open(out_path + ".json", "w") as f:
        json.dump(stats, f)


def _own_peak_rss_mb():
    """This process's peak resident set size in MB. On Linux VmHWM of its own address space:
    ru_maxrss would also carry the parent's high-water mark over fork and exec."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    import resource
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return kb / (1024.0 * 1024.0 if sys.platform == "darwin" else 1024.0)


class PointError(RuntimeError):
    pass


def run_point(kind, blend, spp, opts: Options, caustics=True, threshold=None, denoise=False,
              variant=None):
    """(image, light tracer's image or None, per-pixel samples or None, stats, noisy image or
    None) of one point in a child process; stats gain peak_rss_mb (the child's). threshold:
    adaptive sampling at that noise threshold with at most spp samples per pixel (None: spp in
    every pixel). denoise: the image denoised with opts' prefilter and quality (Snell's noisy
    image beside it). variant: {"snell": Snell's settings, "cycles": Cycles' (setting, value,
    reason)} of a caustic scene (bench_scenes.py), or None."""
    variant = variant or {}
    spec = {"kind": kind, "blend": os.path.abspath(blend) if blend else None, "spp": spp,
            "max_depth": opts.max_depth, "threads": opts.threads, "scale": opts.scale,
            "caustics": caustics, "threshold": threshold,
            "snell": variant.get("snell"), "cycles": variant.get("cycles"),
            "denoise": {"prefilter": opts.denoise_prefilter,
                        "quality": opts.denoise_quality} if denoise else None}
    with tempfile.TemporaryDirectory(prefix="snell-bench-") as tmp:
        spec_path, out = os.path.join(tmp, "spec.json"), os.path.join(tmp, "out")
        with open(spec_path, "w") as f:
            json.dump(spec, f)
        proc = subprocess.run([sys.executable, "-m", "snell.validation.bench", "point",
                               spec_path, out],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        err = proc.stderr
        if proc.returncode != 0 or not os.path.exists(out + ".json"):
            tail = err.decode(errors="replace").strip().splitlines()[-5:]
            raise PointError(f"{kind} {spp} spp on {blend}: child exited {proc.returncode}: "
                             + " / ".join(tail))
        image, light, counts, noisy = (np.load(out + suffix + ".npy")
                                       if os.path.exists(out + suffix + ".npy") else None
                                       for suffix in ("", "_light", "_samples", "_noisy"))
        with open(out + ".json") as f:
            stats = json.load(f)
    return image, light, counts, stats, noisy


def cycles_denoised(settings, prefilter: str, quality: str) -> list:
    """The settings with Cycles' own denoising on: Open Image Denoise on the CPU, guided by
    albedo and normal, with the prefilter and quality given (Snell's names, lower case)."""
    replaced = {"cycles.use_denoising": (True, "the denoised comparison: Cycles' own denoiser, "
                                         "its time in the render's")}
    out = [(k, *replaced[k]) if k in replaced else (k, v, why) for k, v, why in settings]
    return out + [
        ("cycles.denoiser", "OPENIMAGEDENOISE", "the denoiser Snell uses"),
        ("cycles.denoising_use_gpu", False, "on the CPU, as Snell"),
        ("cycles.denoising_input_passes", "RGB_ALBEDO_NORMAL", "guided by albedo and normal, "
         "as Snell"),
        ("cycles.denoising_prefilter", prefilter.upper(), "the same prefilter as Snell"),
        ("cycles.denoising_quality", quality.upper(), "the same quality as Snell"),
    ]


# ---------------------------------------------------------------------------------------------
# Reference, cached on disk


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


def reference(blend, opts: Options, cache_dir, log, setup=None):
    """(mean, info, variance of the mean) of the converged reference, from the cache when its
    key matches. setup: a
    caustic scene's (bench_scenes.BenchScene): its reference is Cycles' plain path tracer
    (shadow caustics and guiding off) or Snell's hybrid, of at least its least_ref_seeds
    seeds; None: Cycles as forced."""
    import bpy
    if setup is not None and setup.least_ref_seeds > opts.ref_seeds:
        opts = replace(opts, ref_seeds=setup.least_ref_seeds)
    seeds = cycles.seeds_for(opts.ref_seeds)
    forced = [(k, v) for k, v, _ in cycles.forced_settings(opts.max_depth, opts.ref_spp, 0, 1)
              if k not in ("cycles.seed", "render.threads")]
    settings = {"seeds": seeds, "spp_per_seed": opts.ref_spp, "max_depth": opts.max_depth,
                "resolution_percentage": opts.scale, "forced": forced}
    renderer = "snell" if setup is not None and setup.reference == "snell" else "cycles"
    added = bench_scenes.PLAIN_REFERENCE if setup is not None else []
    if renderer == "snell":      # Snell's hybrid, unbiased, keyed by the tracer's sources
        from ..tracer.jit import sources_hash
        settings = {"renderer": "snell", "batches": opts.ref_seeds, "spp_per_batch": opts.ref_spp,
                    "max_depth": opts.max_depth, "resolution_percentage": opts.scale,
                    "tracer": sources_hash(), "seed": SNELL_REFERENCE_SEED}
    elif added:                  # only then: the default scenes' cache keys stay as they were
        settings["added"] = [(k, v) for k, v, _ in added]
    version = bpy.app.version_string
    key = cache_key(blend, settings, version)
    hit = cache_load(cache_dir, key)
    if hit is not None:
        mean, var, meta = hit
        cached = True
        log(f"{os.path.basename(blend)}: reference from cache ({key})")
    else:
        log(f"{os.path.basename(blend)}: reference: {opts.ref_seeds} {renderer} "
            f"{'batches' if renderer == 'snell' else 'seeds'} x {opts.ref_spp} spp ...")
        if renderer == "snell":
            mean, var, render_s = snell_reference(blend, opts)
        else:
            camera = {"resolution_percentage": opts.scale} if opts.scale != 100 else None
            res = cycles.render_seeds(blend, spp=opts.ref_spp, max_depth=opts.max_depth,
                                      seeds=seeds, threads=opts.threads, camera=camera,
                                      added=added,
                                      progress=lambda d, n, t: log(f"  seed {d}/{n}, {t:.1f} s"))
            mean, var, render_s = res.mean, res.variance_of_mean, res.time_s
        meta = {"render_s": render_s, "threads": opts.threads, "blender": version,
                "settings": settings, "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
        cache_store(cache_dir, key, mean, var, meta)
        cached = False
    noise = reference_noise(mean, var)
    info = {"key": key, "cached": cached, "renderer": renderer,
            "why": setup.why_reference if setup is not None else "Cycles, as forced",
            "seeds": len(seeds), "spp_per_seed": opts.ref_spp,
            "spp": len(seeds) * opts.ref_spp, "render_s": meta["render_s"],
            "render_threads": meta["threads"], "blender": version,
            "noise_relmse": noise["relmse"], "noise_rmse": noise["rmse"]}
    return np.asarray(mean, np.float64), info, np.asarray(var, np.float64)


SNELL_REFERENCE_SEED = 424242   # Snell's reference (never a ladder point's seed)


def snell_reference(blend, opts: Options):
    """(mean, variance of the mean, seconds) of Snell's hybrid (caustics on, photon merging
    off, the file's shadow caustics: unbiased but for manifold next-event estimation's own
    bias) in opts.ref_seeds independent batches of opts.ref_spp samples, in this process: the
    reference of a caustic no Cycles path tracer renders."""
    from ..addon.export import export_blend
    from ..tracer.integrator import Renderer
    with stdout_silenced():
        scene, _ = export_blend(blend)
    scene = scene.with_render(spp=opts.ref_seeds * opts.ref_spp, max_depth=opts.max_depth,
                              seed=SNELL_REFERENCE_SEED)
    if opts.scale != 100:
        scene = scene.with_camera(resolution_percentage=opts.scale)
    settings = scene.settings(threads=opts.threads, caustics=True, photon_merging="off",
                              sampler="independent", batches=opts.ref_seeds, **cycles.AS_FORCED,
                              noise_threshold=0.0, min_spp=0, time_limit=0.0, denoise=False)
    result = Renderer(scene, settings).render()
    stack = np.stack(result.batch_images).astype(np.float64)
    return stack.mean(axis=0), stack.var(axis=0, ddof=1) / len(stack), result.time_s


# ---------------------------------------------------------------------------------------------
# The bench


def _point(kind, blend, spp, ref, opts, baseline_mb, log, caustics=True, threshold=None,
           denoise=False, variant=None):
    """(point, image, light tracer's image or None, per-pixel samples) of one measured point;
    ref the reference (metrics.Estimate)."""
    # Repeats of a point render the same image (same seed); only the timings differ.
    runs = [run_point(kind, blend, spp, opts, caustics, threshold, denoise, variant)
            for _ in range(opts.repeat)]
    image, light, counts, _, noisy = runs[0]
    stats = median_run([r[3] for r in runs])
    if image.shape != ref.mean.shape:
        raise PointError(f"{kind} image {image.shape} differs from the reference "
                         f"{ref.mean.shape}")
    h, w = ref.mean.shape[:2]
    if counts is None:  # a ladder point: spp in every pixel
        counts = np.full((h, w), spp, np.int32)
    # The child's stats last: Snell's saved_share is its own (RenderResult.saved_share).
    p = {"spp": spp, **errors(image, ref), **sample_summary(counts, spp), **stats}
    if noisy is not None:       # a denoised Snell point: its own noisy image's errors too
        p.update({f"noisy_{k}": v for k, v in errors(noisy, ref).items()})
    p["peak_rss_above_baseline_mb"] = p["peak_rss_mb"] - baseline_mb
    p["efficiency"] = p["relmse"] * p["wall_s"]
    p["samples_per_second"] = h * w * p["mean_spp"] / p["render_s"] if p["render_s"] > 0 else 0.0
    label = (variant or {}).get("label") or (kind if caustics or kind != "snell" else "snell-pt")
    label += "+dn" if denoise else ""
    at = f"T {threshold:<6g}" if threshold else f"{spp:5d} spp"
    log(f"  {label:8s} {at}  wall {p['wall_s']:7.2f} s  relMSE {p['relmse']:.4g}  "
        f"RMSE {p['rmse']:.4g}  FLIP {p['flip']:.4g}  mean {p['mean_spp']:.1f} spp  "
        f"peak {p['peak_rss_mb']:.0f} MB")
    return p, image, light, counts


def _ladder(kind, blend, ref, opts, baseline_mb, log, caustics=True, denoise=False,
            variant=None):
    """The ladder's points, with each point's image and light tracer's image (or None)."""
    points, images, spp = [], [], opts.min_spp
    while spp is not None:
        p, image, light, _ = _point(kind, blend, spp, ref, opts, baseline_mb, log, caustics,
                                    denoise=denoise, variant=variant)
        points.append(p)
        images.append((image, light))
        spp = next_spp(spp, p["wall_s"], max_spp=opts.max_spp, time_cap_s=opts.time_cap_s)
    return points, images


def _as_users_render(kind, blend, ref, opts, baseline_mb, log, caustics=True, variant=None):
    """The adaptive points at each of opts.thresholds (loosest first), and each one's per-pixel
    samples."""
    points, counts = [], []
    for threshold in sorted(opts.thresholds, reverse=True):
        p, _, _, c = _point(kind, blend, opts.adaptive_max_spp, ref, opts, baseline_mb, log,
                            caustics, threshold, variant=variant)
        points.append({"threshold": threshold, **p})
        counts.append(c)
    return points, counts


def _adaptive_comparison(blend, ref, opts, baseline_mb, log, variants=None):
    """(the scene's "adaptive" entry, {renderer: sample map PNG}): Snell and Cycles adaptive at
    opts.thresholds, their equal-threshold ratios, and the maps at the threshold nearest 0.01.
    variants: {renderer: variant} of a caustic scene (_variants)."""
    entry, pngs = {}, {}
    at = nearest_threshold(opts.thresholds)
    for kind in ADAPTIVE_RENDERERS:
        points, counts = _as_users_render(kind, blend, ref, opts, baseline_mb, log,
                                          caustics=opts.caustics != "off",
                                          variant=(variants or {}).get(kind))
        entry[kind] = {"points": points}
        i = [p["threshold"] for p in points].index(at)
        # One scale for both renderers' maps (the cap), so their colours compare.
        pngs[kind] = sample_map_png(counts[i], vmax=opts.adaptive_max_spp)
    entry["equal_threshold"] = equal_threshold(entry["snell"]["points"], entry["cycles"]["points"])
    entry["map_threshold"] = at
    return entry, pngs


def _caustic_region(light, ref):
    """The pixels where the light tracer's image `light` (None: it did not run) carries at least
    CAUSTIC_SHARE (bench_curves.py) of the reference, and their summary."""
    if light is None:
        return np.zeros(ref.shape[:2], bool), {"pixels": 0, "fraction": 0.0,
                                               "light_share_of_image": 0.0,
                                               "share_threshold": CAUSTIC_SHARE}
    mask = light_share(light, ref) >= CAUSTIC_SHARE
    return mask, {"pixels": int(mask.sum()), "fraction": float(mask.mean()),
                  "light_share_of_image": float(light.sum(dtype=np.float64)
                                                / max(ref.sum(), 1e-300)),
                  "share_threshold": CAUSTIC_SHARE}



def _denoised_comparison(scene, ladders, ref):
    """(the scene's "denoised" entry, its figures): targets (a) and (b) (bench_curves), the
    equal-time pair and their per-pixel FLIP maps."""
    (sd, sd_images), (cd, cd_images) = ladders["snell_denoised"], ladders["cycles_denoised"]
    i, j = equal_time_pair(sd, cd)
    snell_image, cycles_image = sd_images[i][0], cd_images[j][0]
    maps = {"snell": flip_map(ref, snell_image), "cycles": flip_map(ref, cycles_image)}
    entry = {
        "time_target": denoised_time_target(sd, cd),
        "fewer_samples_target": fewer_samples_target(sd, scene["snell"]["points"]),
        "equal_time": {"snell_spp": sd[i]["spp"], "snell_s": sd[i]["wall_s"],
                       "snell_flip": sd[i]["flip"], "cycles_spp": cd[j]["spp"],
                       "cycles_s": cd[j]["wall_s"], "cycles_flip": cd[j]["flip"]},
        "below_noisy": [{"spp": p["spp"], "relmse_ratio": p["relmse"] / p["noisy_relmse"],
                         "flip_ratio": p["flip"] / p["noisy_flip"]} for p in sd],
    }
    return entry, denoised_figures_png(ref, snell_image, cycles_image, maps, entry["equal_time"])


def definitions(opts: Options) -> dict:
    """What each figure of the bench's JSON means (its "definitions")."""
    return {**_error_definitions(), **_run_definitions(opts), **_caustic_definitions(),
            **_adaptive_definitions(opts), **_denoised_definitions(opts),
            "reference_noise": "the reference's own expected contribution to a plain relMSE "
                               "and to RMSE: mean of var / (R^2 + eps) and sqrt(mean var), var = "
                               "its across-seed variance of the mean; the bench's relMSE takes "
                               "it out, its RMSE includes it"}


def _error_definitions() -> dict:
    """What the error figures and the time to equal error mean."""
    return {
        "relmse": f"mean over pixels and channels of ((I - R)^2 - var) / (N^2 + eps), eps = "
                  f"{metrics.RELMSE_EPS:g}, after dropping the largest "
                  f"{metrics.RELMSE_DROP:.1%} of the per-value terms (fireflies), and at least "
                  "the standard error of that mean; R = the scene's reference, var its "
                  "variance of the mean (so R's noise is not counted as the image's error), N "
                  "the Gaussian (sigma 1 px) mean of the pixel's neighbours in R, itself left "
                  "out (dividing by R^2 would weight each pixel by its own reference noise and "
                  "favour images darker than the reference: metrics.relmse_against_estimate)",
        "rmse": "sqrt(mean over pixels and channels of (I - R)^2), nothing dropped",
        "flip": "mean HDR-FLIP of I against R (flip-evaluator, linear values clamped at 0)",
        "efficiency": "relMSE x wall time (constant for an unbiased renderer; lower wins)",
        "time_to_equal_error": "target = the larger of the two renderers' smallest relMSE on the "
                               "ladder; each renderer's time at the target by piecewise-linear "
                               "interpolation of log time against log relMSE between the ladder "
                               "points around its first crossing; ratio = Snell / Cycles. "
                               "fit_ratio: "
                               "the same from least-squares lines of slope -1 (log relMSE = a - "
                               "log time), i.e. the ratio of the geometric means of relMSE x time; "
                               "snell_slope, cycles_slope: free least-squares slopes (-1 for an "
                               "unbiased renderer once fixed costs such as export no longer "
                               "dominate)",
    }


def _run_definitions(opts: Options) -> dict:
    """What a point's run figures (time, rays, memory, stages) mean."""
    return {
        "wall_s": "Snell: export of the .blend + scene build (Embree BVH) + render; Cycles: "
                  "loading the .blend + render (EXR write included); both with the same threads, "
                  "each point in a fresh child process, timed inside it (interpreter start and "
                  "import bpy excluded); "
                  f"each point run {opts.repeat} time(s), keeping the run of median wall time "
                  "(wall_s_runs lists them all; peak_rss_mb is the largest)",
        "embree_share": "Snell only: Embree query time / (render time x threads); "
                        "embree_share_of_wall divides by the point's whole wall time instead",
        "rays_per_second": "Snell only: camera, bounce and shadow rays per second of render time "
                           "(Cycles reports no ray count; samples_per_second, pixels x mean_spp "
                           "per second of render time, is given for both)",
        "peak_rss_mb": "the point's child process peak resident set size (Linux VmHWM; ru_maxrss "
                       "elsewhere): "
                       "Python, numpy, the bpy module and native memory (Embree, Cycles); "
                       "peak_rss_above_baseline_mb subtracts a child that only imports them",
        "skipped_stages": "Snell only: the optional stages the scene does not need "
                          "and Snell does not "
                          "run (lens sampling without depth of field, dielectric sampling without "
                          "glass, next-event estimation without lamps or world light, the world "
                          "when it is black, light tracing without mirror or glass and a lamp, "
                          "light vertices where an adaptive render measured that they do not pay)",
        "stages": "Snell only: every optional stage, whether it ran and why (the render's own "
                  "account: RenderResult.stages)",
    }


def _caustic_definitions() -> dict:
    """What the caustic region's figures and issue 34's targets mean."""
    return {
        "caustic_relmse": f"relMSE over the caustic region only: the pixels where the light "
                          f"tracer's image (at the largest Snell point) is at least "
                          f"{CAUSTIC_SHARE:g} of the reference",
        "caustic_gain_at_equal_time": "for each Snell point, the path tracer alone's caustic "
                                      "relMSE at the same wall time (log-log interpolation "
                                      "between its ladder points) over Snell's; median over points",
        "caustic_targets": "issue 34's targets on its caustic scenes (snell bench "
                           "--caustic-scenes, bench_scenes.py), for Snell with the new strategy "
                           "and Snell without it, each against Cycles as users would set it up "
                           "(its shadow caustics on where a lamp lights the glass, path guiding "
                           "where it helped): the caustic region's relMSE at equal time, Snell / "
                           "Cycles = 1 / caustic_gain_at_equal_time's rule with Cycles as the "
                           "other ladder, at most 0.2; the whole image's time to equal error "
                           "(time_to_equal_error's rule), at most 0.5. The reference is Cycles' "
                           "plain path tracer (shadow caustics and guiding off), or Snell's "
                           "hybrid (caustics on, merging off; unbiased) where Cycles' path "
                           "tracer renders no caustic (a delta lamp's). Photon merging is "
                           "consistent, not unbiased: the merged ladders' error includes its "
                           "bias. Images: Cycles' last point beside each Snell ladder's point "
                           "nearest its wall time",
    }


def _adaptive_definitions(opts: Options) -> dict:
    """What the adaptive comparison's figures mean."""
    return {
        "as_users_render": "both renderers sample adaptively as a user renders with a noise "
                           f"threshold: thresholds {', '.join(f'{t:g}' for t in opts.thresholds)}; "
                           f"max samples {opts.adaptive_max_spp} is the per-pixel cap for both "
                           "(Cycles' samples, Snell's spp; a point's spp is that cap), automatic "
                           "min samples for both (Cycles' adaptive_min_samples 0, Snell's min_spp "
                           "0: max(4, ceil(16 / threshold^0.3))), same threads and max depth, "
                           "timed as the ladder points and measured against the same reference. "
                           "Cycles renders every sample (no sample subset: with one Cycles scales "
                           "the threshold by sqrt(subset / samples)), so its sample 0 goes through "
                           "the pixel centre; its sample counts come from its Debug Sample Count "
                           "pass (an extra pass in its EXR)",
        "mean_spp": "samples per pixel averaged over the image (pixel_spp_min, pixel_spp_max: "
                    "the fewest and most of any pixel)",
        "saved_share": "1 - the samples taken / (the cap x pixels): the share of the budget "
                       "adaptive sampling did not spend (Snell: RenderResult.saved_share)",
        "equal_threshold": "per threshold: target = Cycles' relMSE there; Snell's time to it by "
                           "piecewise-linear interpolation of log time against log relMSE along "
                           "Snell's points, loosest threshold first (the ladder's rule: if Snell's "
                           "loosest point is already as low, its time, not extrapolated); ratio = "
                           "that time / Cycles' wall time. When Snell's curve never gets that low "
                           "(along = cycles), the target is Snell's relMSE and Cycles' time to it "
                           "is interpolated along Cycles' curve. time_ratio, relmse_ratio, "
                           "mean_spp_ratio: Snell / Cycles at the same threshold",
    }


def _denoised_definitions(opts: Options) -> dict:
    """What the denoised comparison's figures mean."""
    return {
        "denoised": "not tested (a denoised image is biased and its pixels are not independent: "
                    "compare and study never see one). Each renderer denoised by Open Image "
                    "Denoise guided by its Denoising Albedo and Normal, prefilter "
                    f"{opts.denoise_prefilter}, quality {opts.denoise_quality}, on the CPU with "
                    "the render's threads; Snell: `snell render --denoise` in the point's child "
                    "(the passes rendered, then OIDN through tracer/denoise.py; wall_s includes "
                    "both, denoise_s the denoising), Cycles: its own use_denoising with the "
                    "OPENIMAGEDENOISE denoiser (its denoising inside its render time). Errors "
                    "against the same undenoised reference; noisy_*: a Snell point's own "
                    "image before denoising",
        "time_target": f"target (a): denoised Snell reaches Cycles + OIDN's denoised error in at "
                       f"most {TIME_SHARE_TARGET:g} of Cycles' time, on relMSE and on FLIP: "
                       "time_to_equal_error's rule along the two denoised ladders (interpolation "
                       "only, no slope fits: denoised curves flatten); at_cycles_points: at "
                       "each Cycles point, Snell's time to its error over its time",
        "fewer_samples_target": f"target (b): Snell denoised at 1/{FEWER_SAMPLES} of the samples "
                                "has a lower FLIP than Snell undenoised: each denoised point at "
                                f"n spp against the undenoised ladder's FLIP at {FEWER_SAMPLES} n "
                                "spp, linear in log FLIP against log spp between its ladder "
                                "points (never extrapolated; points without both neighbours "
                                "are left out); met when every evaluated ratio is below 1",
        "equal_time": "the denoised images shown side by side: Cycles + OIDN's last ladder point "
                      "and the Snell + OIDN point nearest its wall time (log time), with "
                      "per-pixel FLIP maps against the reference",
    }

def _variants(setup) -> dict:
    """A caustic scene's ladders and how each renders (run_point's variant): Snell with the
    new strategy, Snell without it, Cycles as users would set it up; None: the default bench."""
    if setup is None:
        return {}
    return {"snell": {"snell": setup.snell, "label": "snell"},
            "snell_without": {"snell": setup.without, "label": "snell-wo"},
            "cycles": {"cycles": setup.cycles_settings(), "label": "cycles"}}


def _ladders(name, blend, ref, opts, baseline_mb, log, variants) -> dict:
    """{ladder key: (points, [(image, light tracer's image or None)])} of one scene."""
    on = opts.caustics != "off"
    log(f"{name}: ladder")
    ladders = {"snell": _ladder("snell", blend, ref, opts, baseline_mb, log, caustics=on,
                                variant=variants.get("snell"))}
    if "snell_without" in variants:
        ladders["snell_without"] = _ladder("snell", blend, ref, opts, baseline_mb, log,
                                           caustics=on, variant=variants["snell_without"])
    elif opts.caustics == "both":
        ladders["snell_path_tracer"] = _ladder("snell", blend, ref, opts, baseline_mb, log,
                                               caustics=False)
    ladders["cycles"] = _ladder("cycles", blend, ref, opts, baseline_mb, log,
                                variant=variants.get("cycles"))
    if opts.denoise:
        log(f"{name}: denoised ladders (not tested: the validator never sees them)")
        ladders["snell_denoised"] = _ladder("snell", blend, ref, opts, baseline_mb, log,
                                            caustics=on, denoise=True,
                                            variant=variants.get("snell"))
        ladders["cycles_denoised"] = _ladder("cycles", blend, ref, opts, baseline_mb, log,
                                             denoise=True, variant=variants.get("cycles"))
    return ladders


def _caustic_entry(scene, ladders, ref, setup):
    """(a caustic scene's "caustic_targets" entry, its equal-time strip PNG): issue 34's
    targets (bench_curves.caustic_targets) and Cycles' last point beside the point of each
    Snell ladder nearest its wall time."""
    entry = {"setup": setup.describe(), **caustic_targets(scene)}
    cycles_points = scene["cycles"]["points"]
    picks = {key: equal_time_pair(scene[key]["points"], cycles_points)[0]
             for key in ("snell", "snell_without")}
    picks["cycles"] = len(cycles_points) - 1
    entry["equal_time"] = {key: {k: scene[key]["points"][i].get(k) for k in
                                 ("spp", "wall_s", "relmse", "caustic_relmse")}
                           for key, i in picks.items()}
    labels = {"snell": "Snell", "snell_without": "Snell without", "cycles": "Cycles"}
    tiles = [("reference", ref)] + [
        (f"{labels[key]}: {entry['equal_time'][key]['spp']} spp, "
         f"{entry['equal_time'][key]['wall_s']:.1f} s", ladders[key][1][i][0])
        for key, i in picks.items()]
    return entry, equal_time_png(tiles)


def _bench_scene(blend, setup, opts, cache_dir, baseline_mb, log):
    """(the scene's JSON entry, its figures: share map, sample maps, denoised and equal-time
    PNGs) of one scene; setup: a caustic scene's (bench_scenes.BenchScene) or None."""
    name = os.path.splitext(os.path.basename(blend))[0]
    ref, ref_info, ref_var = reference(blend, opts, cache_dir, log, setup)
    variants = _variants(setup)
    # The points' errors take the reference's own noise out (bench_curves.errors).
    estimate = metrics.Estimate(ref, ref_var, ref_info["seeds"] - 1)
    ladders = _ladders(name, blend, estimate, opts, baseline_mb, log, variants)
    # The light tracer's image at the largest point of the Snell ladder (None if it did not
    # run): it defines the caustic region and the share map.
    light = ladders["snell"][1][-1][1]
    mask, region = _caustic_region(light, ref)
    if mask.any():
        # The reference's own noise in the region: a floor under every point's caustic relMSE.
        region["reference_noise_relmse"] = reference_noise(ref[mask], ref_var[mask])["relmse"]
        for points, images in ladders.values():
            for p, (image, _) in zip(points, images):
                p["caustic_relmse"] = metrics.relmse_against_estimate(image, ref, ref_var,
                                                                      mask)
    scene = {"name": name, "blend": os.path.abspath(blend),
             "height": int(ref.shape[0]), "width": int(ref.shape[1]),
             "reference": ref_info, "caustic_region": region}
    for key, (points, _) in ladders.items():
        scene[key] = {"points": points, "efficiency": efficiency_summary(points)}
    scene["time_to_equal_error"] = equal_error(scene["snell"]["points"],
                                               scene["cycles"]["points"])
    figures = {"map": share_map_png(light, ref) if light is not None else None}
    if "snell_path_tracer" in scene:
        scene["path_tracer_time_to_equal_error"] = equal_error(
            scene["snell_path_tracer"]["points"], scene["cycles"]["points"])
        if mask.any():
            scene["caustic_gain_at_equal_time"] = gain_at_equal_time(
                scene["snell"]["points"], scene["snell_path_tracer"]["points"],
                "caustic_relmse")
    if setup is not None:
        scene["caustic_targets"], figures["equal_time"] = _caustic_entry(scene, ladders, ref,
                                                                          setup)
    if opts.denoise:
        scene["denoised"], figures["denoised"] = _denoised_comparison(scene, ladders, ref)
    if opts.thresholds:
        log(f"{name}: as users render (adaptive)")
        scene["adaptive"], figures["sample_maps"] = _adaptive_comparison(
            blend, estimate, opts, baseline_mb, log, variants)
    return scene, figures


def run(scenes, report_dir, opts: Options, cache_dir=None, log=None, setups=None) -> dict:
    """Run the bench, write bench.json, bench.html and bench.svg into report_dir, return the
    data. setups: {scene path: bench_scenes.BenchScene} of the caustic scenes among them."""
    log = log or (lambda s: None)
    cache_dir = cache_dir or default_cache_dir()
    setups = setups or {}
    start = time.perf_counter()
    # Each scene is exported once first: a file Blender cannot open or Snell cannot render
    # fails here, with its name, rather than in a child process minutes into the run.
    from ..addon.export import export_blend
    for blend in scenes:
        with stdout_silenced():
            export_blend(blend)
    _, _, _, base, _ = run_point("baseline", None, 0, opts)
    baseline_mb = base["peak_rss_mb"]
    out_scenes, figures = [], {}
    for blend in scenes:
        scene, figures[os.path.splitext(os.path.basename(blend))[0]] = _bench_scene(
            blend, setups.get(blend), opts, cache_dir, baseline_mb, log)
        out_scenes.append(scene)
    import bpy
    data = {
        "schema": SCHEMA,
        "quick": opts.quick,
        "settings": {**asdict(opts), "resolution_percentage": opts.scale, "cache_dir": cache_dir,
                     "snell_seed": SNELL_SEED, "cycles_seed": CYCLES_SEED},
        "definitions": definitions(opts),
        "environment": {"blender": bpy.app.version_string, "python": platform.python_version(),
                        "numpy": np.__version__, "machine": platform.machine(),
                        "cpu_count": os.cpu_count(), "baseline_rss_mb": baseline_mb},
        "scenes": out_scenes,
        "total_s": time.perf_counter() - start,
    }
    svg = svg_plot(out_scenes)
    pick = {k: {name: f[k] for name, f in figures.items() if f.get(k) is not None}
            for k in ("map", "sample_maps", "denoised", "equal_time")}
    with atomic_directory(report_dir) as tmp:
        with open(os.path.join(tmp, "bench.svg"), "w") as f:
            f.write(svg)
        write_json(os.path.join(tmp, "bench.json"), data)
        write_html(os.path.join(tmp, "bench.html"), data, svg, pick["map"], pick["sample_maps"],
                   pick["denoised"], pick["equal_time"])
        for name, figure in pick["denoised"].items():
            with open(os.path.join(tmp, f"denoised_{name}.png"), "wb") as f:
                f.write(figure["strip"])
        for name, png in pick["equal_time"].items():
            with open(os.path.join(tmp, f"equal_time_{name}.png"), "wb") as f:
                f.write(png)
    return data


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "point":
        _child(sys.argv[2], sys.argv[3])
    else:
        sys.exit("usage: python -m snell.validation.bench point SPEC.json OUT")
