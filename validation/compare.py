"""`snell compare`: render one .blend with Snell and with Cycles under matched settings, test.

compare_blend() does the work and returns a dict (the numbers of metrics.json plus images and
maps); the CLI wraps it and writes the report. Cycles renders K independent seeds with spp / K
samples each, so both renderers spend the same number of samples per pixel.
"""
from __future__ import annotations

import math
import sys
import time

import numpy as np

from ..addon.console import stdout_silenced
from ..tracer.settings import LIGHT_PATHS_PER_CAMERA_PATH
from . import cycles, metrics

DEFAULT_CYCLES_SEEDS = 8


class Progress:
    """One updating line per renderer on a terminal (plain lines otherwise)."""

    def __init__(self, stream=None, enabled=True):
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.tty = self.stream.isatty() if enabled else False
        self.width = 0

    def line(self, text, final=False):
        if not self.enabled:
            return
        if self.tty:
            self.stream.write("\r" + text.ljust(self.width) + ("\n" if final else ""))
            self.width = 0 if final else len(text)
        elif final:
            self.stream.write(text + "\n")
        self.stream.flush()

    def snell(self, label=""):
        start = time.monotonic()

        def cb(result, done, total):
            elapsed = time.monotonic() - start
            self.line(f"snell{label}: pass {done}/{total}, {result.spp} spp, {elapsed:.1f}s",
                      final=done == total)
            return True
        return cb

    def cycles(self, label=""):
        def cb(done, total, elapsed):
            self.line(f"cycles{label}: seed {done}/{total}, {elapsed:.1f}s", final=done == total)
        return cb


def load_snell_scene(blend_path):
    """(Scene, exporter warnings) for a .blend."""
    from ..addon.export import export_blend
    with stdout_silenced():
        return export_blend(blend_path)


# Snell's per-pixel variances come from this many independent batches (the images of as many
# passes, K - 1 degrees of freedom), not from per-sample sums of squares: the light tracer's splats
# have no per-sample variance, and where rare paths carry much of the light the per-sample
# variance underestimates the error (docs/validation.md).
BATCHES = 16


def batch_spp(spp: int) -> int:
    """The samples per pixel that split into BATCHES equal batches: spp rounded up to a multiple
    of BATCHES (equal batches are equally weighted images, which the statistics assume)."""
    return max(BATCHES, -(-int(spp) // BATCHES) * BATCHES)


def snell_render(scene, spp, progress=None, threads=2, caustics=None, noise_threshold=0.0,
                 fresnel_split=False):
    """Snell with independent samples: the tests need honest per-pixel variances, which the
    default stratified sampler's correlated samples would over-estimate. In BATCHES equal
    batches (spp rounded up by batch_spp), or with noise_threshold > 0 adaptively (each pixel's
    variance from its own samples, the light tracer's from its passes:
    RenderResult.variance_and_dof).

    Fixed-sample renders leave light vertices out: they find light (a ceiling lit by a lamp 1 cm
    below it) that a path tracer, Cycles' included, finds only on rare paths, so Cycles' mean
    there is low in most runs at the sample counts compared, and correct renders failed
    (docs/validation.md). tests/render/test_light_vertices.py holds the image with light vertices to
    the image without them. The Fresnel split is off unless asked for, for the same reason: it
    counts the glints (a lamp mirrored in glass or water) that Cycles' samples meet rarely,
    so in a pixel where Cycles' batches met none its variance is near 0 and correct renders
    failed; tests/render/test_fresnel_split.py holds the split's image to the image without it,
    and tests/validation/test_fresnel_split_compare.py to Cycles at 32 times the samples."""
    from ..tracer.integrator import Renderer
    # No time limit (a file's Cycles Time Limit): the comparison is at matched sample counts.
    # Never denoised: a denoised image is biased and its pixels are not independent, so the
    # statistics hold the render's own estimate against Cycles' (and skip the guiding passes).
    settings = scene.settings(threads=threads, sampler="independent", spp=spp,
                              noise_threshold=noise_threshold, time_limit=0.0, denoise=False,
                              denoising_passes=False, film_exposure=1.0,
                              sample_clamp_direct=0.0, sample_clamp_indirect=0.0,
                              transparent_max_bounces=cycles.TRANSPARENT_BOUNCES,
                              light_paths_per_camera_path=LIGHT_PATHS_PER_CAMERA_PATH,
                              fresnel_split=fresnel_split,
                              **({} if caustics is None else {"caustics": caustics}))
    if noise_threshold <= 0.0:
        settings = settings.replace(light_vertices=False, spp=batch_spp(spp), batches=BATCHES)
    return Renderer(scene, settings).render(progress=progress)


def snell_estimate(result) -> metrics.Estimate:
    """A Snell render as the statistics' Estimate: from its batch images where it has them (with
    the light tracer's share), else from its per-pixel variances."""
    if result.batches >= 2 and result.batch_images and result.spp % result.batches == 0:
        light = np.stack(result.light_batch_images) if result.light_batch_images else None
        return metrics.Estimate.from_images(np.stack(result.batch_images), light)
    va, dfa = result.variance_and_dof()
    return metrics.Estimate(result.mean().astype(np.float64), va, dfa)


def cycles_render(blend_path, *, spp, max_depth, seed, n_seeds=DEFAULT_CYCLES_SEEDS, camera=None,
                  progress=None, threads=2, film=None, bounces=None, caustics=None):
    """Cycles' images of the file at spp samples in n_seeds seeds; film: the pixel filter
    (pixel_filter, filter_width) of the Snell scene compared (None: the file's own); bounces:
    its bounce limits of each kind (cycles.scene_bounces); caustics: its caustics switches
    (cycles.scene_caustics)."""
    per_seed = max(1, math.ceil(spp / n_seeds))
    return cycles.render_seeds(blend_path, spp=per_seed, max_depth=max_depth,
                               seeds=cycles.seeds_for(n_seeds, seed), camera=camera,
                               progress=progress, threads=threads, film=film,
                               bounces=bounces, caustics=caustics)


def compare_renders(snell_result, cyc, *, not_comparable=(), settings=(), label="",
                    scene=None, notes=(), threads=2):
    """Statistics of a Snell RenderResult against a CyclesResult; returns the report dict.

    scene: the Snell scene rendered, to name the objects under the tiles that fail (its object
    index is rendered only when some fail); notes: exporter warnings that do not change what
    Cycles renders."""
    a = snell_estimate(snell_result)
    b = metrics.Estimate.from_images(np.stack(cyc.images))
    stats = metrics.compare_estimates(a, b)
    alpha = alpha_comparison(snell_result, cyc)
    if alpha is not None:
        stats["alpha_channel"] = alpha
        if alpha["verdict"] == metrics.INCONSISTENT:
            stats["verdict"] = metrics.INCONSISTENT
            stats["failed_tests"] = stats["failed_tests"] + ["alpha"]
    stats["statistical_verdict"] = stats["verdict"]
    if not_comparable:
        stats["verdict"] = metrics.NOT_COMPARABLE
    stats["not_comparable"] = list(not_comparable)
    stats["exporter_notes"] = list(notes)
    stats["cycles_caveats"] = (cycles_caveats(scene, snell_result.stages) if scene is not None
                               else [])
    if scene is not None and stats["failing_tiles"]:
        from ..tracer.integrator import Renderer
        index = Renderer(scene, scene.settings(threads=threads, caustics=False,
                                               light_vertices=False)).object_index()
        names = [o["name"] for o in scene.objects]
        for tile in stats["failing_tiles"]:
            tile["objects"] = objects_in(index, names, tile)
    stats["snell"] = {"time_s": snell_result.time_s, "spp": snell_result.spp,
                      "nan_samples": snell_result.nan_count,
                      "image": snell_result.mean().astype(np.float64),
                      "noise_threshold": snell_result.noise_threshold,
                      "mean_spp": float(snell_result.samples().mean()),
                      "saved_share": snell_result.saved_share}
    if snell_result.sample_count is not None:
        stats["snell"]["samples"] = snell_result.sample_count
    stats["cycles"] = {"time_s": cyc.time_s, "spp": cyc.spp, "seeds": list(cyc.seeds),
                       "spp_per_seed": cyc.spp // len(cyc.seeds), "image": cyc.mean}
    stats["cycles_settings"] = [list(s) for s in cyc.settings]
    stats["snell_settings"] = [list(s) for s in settings]
    stats["label"] = label
    return stats


def cycles_caveats(scene, stages: dict) -> list[str]:
    """Where Cycles' own render of the scene is known to be biased (its shadow caustics from a
    round lamp, and a sun's, clamped), so that inconsistent tiles there may be Cycles'; stages:
    what Snell's render of it ran (Renderer.stages())."""
    flagged = [light for light in scene.lights if light.get("caustics_light")]
    round_lamps = [light["name"] for light in flagged
                   if light["kind"] in ("point", "spot") and light.get("radius", 0.0) > 0.0
                   and light.get("soft_falloff", True)]
    suns = [light["name"] for light in flagged if light["kind"] == "sun"]
    if not (round_lamps or suns) or not stages.get("shadow caustics", (False,))[0]:
        return []
    caveats = []
    if round_lamps:
        caveats.append(
            f"Cycles' shadow caustics overstate the light of {', '.join(map(repr, round_lamps))} "
            "through the casters: they take the lamp's disk as facing the receiver where its "
            "light leaves the last caster, by about the square of the lamp's radius over its "
            "distance (+0.75% at 0.1, +9% at 0.4); Snell renders the disk its path tracer sees "
            "(docs/validation.md)")
    if suns:
        caveats.append(
            f"Cycles' shadow caustics clamp the light of {', '.join(map(repr, suns))} where the "
            "casters focus it (their geometry term at 2), which Snell does not "
            "(docs/validation.md)")
    return caveats


def alpha_comparison(snell_result, cyc) -> dict | None:
    """The alpha channel's tests (metrics.compare_estimates, without the maps) of a render that
    made one (Film > Transparent, a Holdout) against Cycles' alpha, or None when either has
    none. The alpha is tested as a grey image: each channel the same."""
    if not getattr(snell_result, "has_alpha", False) or not cyc.alpha_images:
        return None
    variance, dof = snell_result.alpha_variance_and_dof()
    grey = np.ones(3)
    a = metrics.Estimate(snell_result.alpha().astype(np.float64)[..., None] * grey,
                         variance[..., None] * grey, dof)
    b = metrics.Estimate.from_images(np.stack(cyc.alpha_images)[..., None] * grey)
    out = metrics.compare_estimates(a, b, error_metrics=False)
    keep = ("verdict", "tests", "failed_tests", "pixels_failed", "tiles", "tiles_failed",
            "tile_max_abs_z", "sharpness_z")
    return {**{k: out[k] for k in keep}, "mean_snell": out["mean_a"]["r"],
            "mean_cycles": out["mean_b"]["r"], "mean_z": out["mean_z"]["r"],
            "nan_samples": snell_result.alpha_nan_count}


def objects_in(index, names, tile):
    """[(name, share of the tile's primary rays)] of the objects a tile shows, most first."""
    y, x, k = tile["y0"], tile["x0"], tile["size"]
    ids, counts = np.unique(index[y:y + k, x:x + k], return_counts=True)
    total = counts.sum()
    return [(names[i] if i >= 0 else "(world)", float(c / total))
            for c, i in sorted(zip(counts, ids), reverse=True)]


def snell_settings(scene):
    r, cam = scene.render, scene.camera
    from ..tracer.scene import aperture_radius
    pct = cam.get("resolution_percentage", 100)
    res = [int(x * pct / 100) for x in cam["resolution"]]
    return [
        ("resolution", f"{res[0]}x{res[1]}", "same as Cycles"),
        ("spp", r["spp"], "samples per pixel"),
        ("max_depth", r["max_depth"], "emission + max_depth bounces"),
        ("seed", r["seed"], ""),
        ("sampler", "independent, in 16 equal batches", "per-pixel and per-statistic variances "
         "from the batches' spread (spp rounded up to a multiple of 16)"),
        ("light vertices", "off", "they find light a path tracer finds only on rare paths; "
         "tests/render/test_light_vertices.py holds them to the image without them"),
        ("light paths per camera path", LIGHT_PATHS_PER_CAMERA_PATH, "fixed, not the pilot's: "
         "the per-pixel test needs the light tracer's splats in every batch that the fixed share "
         "gives; tests/render/test_light_budget.py holds the pilot's image to a fixed share's"),
        ("Fresnel split", "off", "it counts glints Cycles' samples meet rarely, so a pixel "
         "where Cycles' batches met none failed; tests/render/test_fresnel_split.py holds the "
         "split's image to the image without it"),
        ("fresnel", r["fresnel"], "exact is Cycles' rule"),
        ("aperture_radius_m", round(aperture_radius(cam), 6), "lens / (2 fstop) unless overridden"),
        ("focus_distance_m", cam["dof"]["focus_distance"], ""),
        ("pixel filter", f"{r['pixel_filter']} {r['filter_width']:g} px",
         "importance-sampled as Cycles does; Cycles renders with the same"),
    ]


def compare_blend(blend_path, *, spp=None, max_depth=None, seed=None, scale=None,
                  n_seeds=DEFAULT_CYCLES_SEEDS, threads=2, progress=None, snell_scene=None,
                  camera=None, noise_threshold=0.0):
    """Render blend_path with both renderers and compare.

    scale: resolution percentage for both. noise_threshold > 0: Snell samples adaptively
    (spp its most per pixel), Cycles renders its usual fixed samples.
    camera: {"focus_distance", "aperture_radius"}
    overrides for both. snell_scene: optional function Scene -> Scene applied to Snell only (to
    inject a deliberate error).
    """
    progress = progress or Progress(enabled=False)
    scene, warnings = load_snell_scene(blend_path)
    scene = scene.with_render(spp=spp, max_depth=max_depth, seed=seed)
    cam_over = dict(camera or {})
    if scale is not None:
        scene = scene.with_camera(resolution_percentage=int(scale))
        cam_over["resolution_percentage"] = int(scale)
    if "focus_distance" in cam_over or "aperture_radius" in cam_over:
        dof = {}
        if "focus_distance" in cam_over:
            dof["focus_distance"] = float(cam_over["focus_distance"])
        if "aperture_radius" in cam_over:
            dof["aperture_radius"] = float(cam_over["aperture_radius"])
            dof["use_dof"] = float(cam_over["aperture_radius"]) > 0
        scene = scene.with_camera(dof=dof)
    if snell_scene is not None:
        scene = snell_scene(scene)
    r = scene.render
    snell_result = snell_render(scene, r["spp"], progress.snell(), threads,
                                noise_threshold=noise_threshold)
    from ..addon.export import differs_from_cycles
    not_comparable = [f"exporter: {w}" for w in warnings if differs_from_cycles(w)]
    notes = [w for w in warnings if not differs_from_cycles(w)]
    try:
        cyc = cycles_render(blend_path, spp=r["spp"], max_depth=r["max_depth"], seed=r["seed"],
                            n_seeds=n_seeds, camera=cam_over, progress=progress.cycles(),
                            threads=threads, film=cycles.scene_film(scene),
                            bounces=cycles.scene_bounces(scene),
                            caustics=cycles.scene_caustics(scene))
    except cycles.NoCyclesEquivalent as exc:
        return snell_only(snell_result, scene, str(exc))
    out = compare_renders(snell_result, cyc, not_comparable=not_comparable,
                          settings=snell_settings(scene), scene=scene, notes=notes,
                          threads=threads)
    out["scene"] = str(blend_path)
    out["exporter_warnings"] = list(warnings)
    return out


def snell_only(snell_result, scene, reason):
    """The report dict of a setting with no Cycles equivalent."""
    return {"verdict": metrics.NOT_COMPARABLE, "statistical_verdict": None,
            "not_comparable": [reason], "rule": metrics.RULE,
            "snell": {"time_s": snell_result.time_s, "spp": snell_result.spp,
                      "nan_samples": snell_result.nan_count,
                      "image": snell_result.mean().astype(np.float64)},
            "cycles": None, "cycles_settings": [],
            "snell_settings": [list(s) for s in snell_settings(scene)],
            "maps": None}
