"""Render a .blend in Cycles (CPU, through the bpy module) with settings forced to match Snell.

`forced_settings(...)` lists every setting the validator changes, with the reason; the report
prints that list. `render_seeds(...)` renders K independent seeds and returns the per-pixel mean
and the across-seed variance of that mean (an honest variance even though each Cycles render uses
a stratified quasi-random sequence: the seeds are independent scrambles of it).

Cycles has no per-pixel sample-variance pass in bpy 5.0.1 (only Sample Count and the denoising
passes), so K seeds is the cheapest honest estimate.
"""
from __future__ import annotations

import os
import re
import tempfile
import time
from dataclasses import dataclass, field

import numpy as np

from ..addon.console import stdout_silenced


# Both renderers' transparent bounce limit in a comparison (forced_settings; compare.py gives
# Snell the same).
TRANSPARENT_BOUNCES = 1024


class NoCyclesEquivalent(ValueError):
    """A Snell setting that Cycles cannot reproduce (e.g. max depth 0)."""


def forced_settings(max_depth: int, spp: int, seed: int, threads: int = 2, film=None,
                    bounces=None, caustics=None):
    """[(setting, value, reason)] applied to the scene before a Cycles render. film: the Snell
    scene's (pixel_filter, filter_width[, film_transparent]: scene_film), which Cycles then
    renders with; None keeps the file's own filter (the exported scene's when it follows the
    file's Cycles settings) and an opaque film. bounces: the Snell scene's (diffuse, glossy,
    transmission) limits (scene_bounces); None: each kind limited by the total alone.
    caustics: the Snell scene's (reflective, refractive) caustics switches (scene_caustics);
    None: both on."""
    transparent = is_transparent(film)
    if max_depth < 1:
        raise NoCyclesEquivalent(f"max depth {max_depth}: Cycles has no max_bounces equivalent "
                                 "(max_bounces = max depth - 1 >= 0)")
    b = max_depth - 1
    bounce = f"max depth {max_depth} = emission + {max_depth} bounces = Cycles max_bounces {b}"
    return [
        ("render.engine", "CYCLES", "the reference renderer"),
        ("cycles.device", "CPU", "reproducible, no GPU"),
        ("render.threads_mode", "FIXED", "shared machine"),
        ("render.threads", threads, "shared machine"),
        ("cycles.samples", spp + 1, "sample indices 0..spp; only 1..spp are rendered (below)"),
        ("cycles.seed", seed, "independent seed per render"),
        ("cycles.use_animated_seed", False, "the seed is the one given"),
        ("cycles.use_sample_subset", True, "render the subset of samples 1..spp: sample 0 of "
         "every render goes through the pixel centre, a 1/spp bias towards point sampling "
         "(measured: without this, Cycles images are detectably sharper than box-filtered)"),
        ("cycles.sample_offset", 1, "skip sample 0"),
        ("cycles.sample_subset_length", spp, "spp samples per pixel"),
        ("cycles.sampling_pattern", "TABULATED_SOBOL", "no blue-noise correlation between pixels"),
        *_film_settings(film),
        ("cycles.use_denoising", False, "unbiased, sample-count matched"),
        ("cycles.use_adaptive_sampling", False, "same samples in every pixel"),
        ("cycles.time_limit", 0.0, "sample-count matched"),
        ("cycles.sample_clamp_direct", 0.0, CLAMP_REASON),
        ("cycles.sample_clamp_indirect", 0.0, CLAMP_REASON),
        ("cycles.blur_glossy", 0.0, "no filter glossy (biased)"),
        *_caustics_settings(caustics),
        ("cycles.use_guiding", False, "plain path tracing"),
        ("cycles.light_sampling_threshold", 0.0, "no probabilistic shadow-ray termination"),
        ("cycles.max_bounces", b, bounce),
        *_bounce_settings(b, bounces),
        ("cycles.transparent_max_bounces", TRANSPARENT_BOUNCES, "Cycles counts each crossing "
         "of a light object as a transparent bounce (a workaround in shade_light.h); Snell's "
         "lamps have no such limit, so the limit is lifted for both"),
        ("cycles.volume_bounces", 0, "Snell has no volumes"),
        ("cycles.min_light_bounces", 0, "no forced bounces"),
        ("cycles.min_transparent_bounces", 0, "no forced bounces"),
        ("cycles.film_exposure", 1.0, "no exposure scaling (a linear scale of the image: "
         "Snell's renders for the comparison are at exposure 1 too)"),
        ("render.film_transparent", transparent, "the Snell scene's Film > Transparent"
         if transparent else "the world is visible"),
        ("render.use_motion_blur", False, "Snell has no motion blur"),
        ("render.use_border", False, "full frame"),
        ("render.use_compositing", False, "raw render result"),
        ("render.use_sequencer", False, "raw render result"),
        ("view_settings.view_transform", "Standard", "same display transform for both PNGs"),
        ("view_settings.look", "None", "same display transform"),
        ("view_settings.exposure", 0.0, "same display transform"),
        ("view_settings.gamma", 1.0, "same display transform"),
        ("objects.shadow_terminator_*_offset", 0.0, "Cycles moves shadow-ray origins of smooth "
         "low-poly meshes off the surface by default (geometry offset 0.1); Snell does not"),
        ("output", OUTPUT_RGBA if transparent else "OPEN_EXR 32-bit RGB",
         "scene-linear output, read back"),
    ]


OUTPUT_RGBA = "OPEN_EXR 32-bit RGBA"
# Both renderers are compared unclamped (validation.compare gives Snell the same).
CLAMP_REASON = ("no clamping: a clamp biases each renderer by the values of its own samples, "
                "which differ between two correct renderers")
KIND_LIMITS = ("diffuse_bounces", "glossy_bounces", "transmission_bounces")


def _bounce_settings(total: int, bounces) -> list:
    """The per-kind limit entries of forced_settings: the Snell scene's where they are below
    the total, which alone limits the others (a count of one kind never exceeds the total)."""
    limits = bounces or (total,) * len(KIND_LIMITS)
    return [(f"cycles.{name}", min(int(limit), total),
             "the Snell scene's limit" if limit < total else "limited by max_bounces alone")
            for name, limit in zip(KIND_LIMITS, limits)]


# Snell's settings for a render compared with one under forced_settings(bounces=None): unclamped,
# and each kind limited by the total alone.
AS_FORCED = {"sample_clamp_direct": 0.0, "sample_clamp_indirect": 0.0,
             **{name: 1024 for name in KIND_LIMITS}}


def scene_bounces(scene):
    """A Snell scene's (diffuse, glossy, transmission) bounce limits for forced_settings, or
    None when none is below its total (max depth - 1) and so none changes the image."""
    limits = tuple(int(scene.render.get(name, 1024)) for name in KIND_LIMITS)
    total = int(scene.render["max_depth"]) - 1
    return limits if any(limit < total for limit in limits) else None


def _caustics_settings(caustics) -> list:
    """The caustics switches' entries of forced_settings."""
    reflective, refractive = caustics or (True, True)
    why = ("the Snell scene's switch (Snell drops the same lobes after a diffuse bounce)"
           if caustics else "on, as the Snell scene's")
    return [("cycles.caustics_reflective", bool(reflective), why),
            ("cycles.caustics_refractive", bool(refractive), why)]


def scene_caustics(scene):
    """A Snell scene's (reflective, refractive) caustics switches for forced_settings, or None
    when both are on (Cycles' default)."""
    pair = (bool(scene.render.get("caustics_reflective", True)),
            bool(scene.render.get("caustics_refractive", True)))
    return None if all(pair) else pair


def is_transparent(film) -> bool:
    """Whether a forced_settings film renders Film > Transparent."""
    return film is not None and len(film) > 2 and bool(film[2])


def _film_settings(film) -> list:
    """The pixel filter entries of forced_settings (none for the file's own filter), and the
    Transparent Glass ones of a film with its threshold (scene_film)."""
    if film is None:
        return []
    kind, width = film[:2]
    out = [("cycles.pixel_filter_type", str(kind).upper(), "the Snell scene's pixel filter, "
            "which Snell samples as Cycles does"),
           ("cycles.filter_width", float(width), "the Snell scene's filter width")]
    if len(film) > 3:
        out += [("cycles.film_transparent_glass", True, "the Snell scene's Transparent Glass"),
                ("cycles.film_transparent_roughness", float(film[3]), "its roughness "
                 "threshold")]
    return out


def scene_film(scene) -> tuple:
    """A Snell scene's (pixel_filter, filter_width), True after them when its film is
    transparent, and then its Transparent Glass threshold when that is on, for forced_settings'
    film (an opaque film's pair keeps the stored references' keys)."""
    r = scene.render
    film = (r["pixel_filter"], float(r["filter_width"]))
    if not r.get("film_transparent"):
        return film
    if r.get("film_transparent_glass"):
        return film + (True, float(r.get("film_transparent_roughness", 0.1)))
    return film + (True,)


# The settings forced_settings uses to render exactly samples 1..spp, which adaptive_settings
# drops: a user renders all the samples, and with a subset Cycles scales the noise threshold by
# sqrt(subset / samples) (scene/integrator.cpp, get_adaptive_sampling).
_SUBSET_KEYS = ("cycles.use_sample_subset", "cycles.sample_offset", "cycles.sample_subset_length")
SAMPLE_COUNT_PASS = "Debug Sample Count"
MULTILAYER = "OPEN_EXR_MULTILAYER 32-bit, Combined and Debug Sample Count"


def adaptive_settings(max_depth: int, threshold: float, max_spp: int, seed: int, threads: int = 2,
                      film=None, bounces=None, caustics=None):
    """[(setting, value, reason)] for Cycles' adaptive sampling as a user renders with it: the
    forced settings, but noise threshold `threshold`, automatic minimum samples, at most
    `max_spp` per pixel, all samples (no subset), and the per-pixel sample count pass (film,
    bounces and caustics: as forced_settings')."""
    if threshold <= 0:
        raise ValueError(f"noise threshold {threshold}: adaptive sampling needs one above 0")
    replaced = {
        "cycles.samples": (max_spp, "the per-pixel cap (Snell's spp), as a user sets it"),
        "cycles.use_adaptive_sampling": (True, "as users render: each pixel stops at the noise "
                                         "threshold (Snell samples adaptively by the same rule)"),
        "output": (MULTILAYER, "the render and each pixel's sample count, read back"),
    }
    out = []
    for key, value, why in forced_settings(max_depth, max_spp, seed, threads, film, bounces,
                                           caustics):
        if key in _SUBSET_KEYS:
            continue
        out.append((key, *replaced[key]) if key in replaced else (key, value, why))
    out += [
        ("cycles.use_sample_subset", False, "a user renders every sample (with a subset Cycles "
         "scales the threshold by sqrt(subset / samples)); sample 0 goes through the pixel "
         "centre, a weight of 1 / (pixel's samples) at most 1/32 at the automatic minimum"),
        ("cycles.adaptive_threshold", threshold, "the noise threshold (Snell's noise_threshold)"),
        ("cycles.adaptive_min_samples", 0, "0 = Cycles' automatic minimum, "
         "max(4, ceil(16 / threshold^0.3)), Snell's too"),
        ("view_layers.cycles.pass_debug_sample_count", True, "each pixel's samples, for the "
         "mean samples per pixel and the sample map"),
    ]
    return out


def samples_rendered(stats: list, cap: int) -> int:
    """How many samples an adaptive Cycles render ran, from its render_stats lines
    ("... | Sample 80/1024"): the last sample count it reported above 0, else the cap."""
    done = [int(m.group(1)) for line in stats for m in [_SAMPLE_STAT.search(line)] if m]
    done = [n for n in done if n > 0]
    return min(done[-1], cap) if done else cap


_SAMPLE_STAT = re.compile(r"Sample (\d+)/\d+")


def read_sample_count(path, samples: int) -> np.ndarray:
    """Each pixel's samples, int32 (H, W), from the Debug Sample Count pass of a multilayer EXR.

    Cycles stores the count over the samples it rendered (PathTrace's samples in the buffer),
    which is less than the samples setting when every pixel converged early: `samples` is that
    number (samples_rendered)."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise OSError(f"{path}: cannot read image ({oiio.geterror()})")
    try:
        part = 0
        while inp.seek_subimage(part, 0):
            spec = inp.spec()
            for channel, name in enumerate(spec.channelnames):
                if f".{SAMPLE_COUNT_PASS}." in f".{name}":
                    pixels = inp.read_image(part, 0, channel, channel + 1, "float")
                    share = np.asarray(pixels, np.float64).reshape(spec.height, spec.width)
                    return np.rint(share * samples).astype(np.int32)
            part += 1
    finally:
        inp.close()
    raise OSError(f"{path}: no {SAMPLE_COUNT_PASS} pass")


# A settings key that switches Cycles' shadow caustics (manifold next-event estimation) off on
# every object and lamp (value False; True keeps the file's flags): MNEE is biased, so a
# reference meant to converge renders without it.
SHADOW_CAUSTICS = "objects.cycles.is_caustics_*"


def _shadow_caustics(scene, value):
    """Keep the file's shadow-caustic flags (value True) or clear them all (False)."""
    if value:
        return
    for obj in scene.objects:
        obj.cycles.is_caustics_caster = obj.cycles.is_caustics_receiver = False
        if obj.type == "LIGHT":
            obj.data.cycles.is_caustics_light = False


def _apply(scene, settings):
    for key, value, _ in settings:
        if key == "output":
            continue
        if key == SHADOW_CAUSTICS:
            _shadow_caustics(scene, value)
            continue
        if key.startswith("view_layers.cycles."):
            for layer in scene.view_layers:
                setattr(layer.cycles, key.rsplit(".", 1)[1], value)
            continue
        if key.startswith("objects."):
            for obj in scene.objects:
                for attr in ("shadow_terminator_geometry_offset",
                             "shadow_terminator_shading_offset",
                             "shadow_terminator_normal_offset"):
                    if hasattr(obj, attr):
                        setattr(obj, attr, value)
            continue
        owner_name, attr = key.split(".", 1)
        owner = {"render": scene.render, "cycles": scene.cycles,
                 "view_settings": scene.view_settings}[owner_name]
        setattr(owner, attr, value)
    multilayer = any(k == "output" and v in (MULTILAYER, DENOISING_OUTPUT)
                     for k, v, _ in settings)
    img = scene.render.image_settings
    if hasattr(img, "media_type"):  # Blender 5: the multilayer format is a media type
        img.media_type = "MULTI_LAYER_IMAGE" if multilayer else "IMAGE"
    img.file_format = "OPEN_EXR_MULTILAYER" if multilayer else "OPEN_EXR"
    img.color_depth = "32"
    img.color_mode = "RGBA" if any(k == "output" and v == OUTPUT_RGBA
                                   for k, v, _ in settings) else "RGB"
    img.exr_codec = "ZIP"


def fstop_for_radius(lens_mm: float, radius_m: float) -> float:
    """Cycles' aperture radius is lens / (2 fstop)."""
    return lens_mm * 1e-3 / (2.0 * radius_m)


def _apply_camera(scene, camera):
    """camera: optional {"focus_distance": d, "aperture_radius": r (0 = pinhole),
    "resolution_percentage": p} overrides."""
    if not camera:
        return []
    cam = scene.camera.data
    dof = cam.dof
    done = []
    for key in ("lens", "shift_x", "shift_y"):
        if key in camera:
            setattr(cam, key, float(camera[key]))
            done.append((f"camera.{key}", float(camera[key]), "framing override (both renderers)"))
    if "resolution_percentage" in camera:
        scene.render.resolution_percentage = int(camera["resolution_percentage"])
        done.append(("render.resolution_percentage", int(camera["resolution_percentage"]),
                     "both renderers at the same reduced resolution"))
    if "aperture_radius" in camera:
        r = float(camera["aperture_radius"])
        dof.use_dof = r > 0
        if r > 0:
            dof.aperture_fstop = fstop_for_radius(cam.lens, r)
        done.append(("camera.dof.aperture_fstop", round(dof.aperture_fstop, 6),
                     f"aperture radius {r:g} m = lens {cam.lens:g} mm / (2 fstop)"))
    if "focus_distance" in camera:
        dof.focus_object = None
        dof.focus_distance = float(camera["focus_distance"])
        done.append(("camera.dof.focus_distance", float(camera["focus_distance"]),
                     "study setting"))
    return done


@dataclass
class CyclesResult:
    mean: np.ndarray             # (H, W, 3) float64, row 0 = top
    variance_of_mean: np.ndarray  # (H, W, 3) float64, across-seed estimate
    spp: int                     # total samples per pixel (seeds x spp per seed)
    seeds: list
    time_s: float                # render time of all seeds (file loading excluded)
    settings: list = field(default_factory=list)
    images: list = field(default_factory=list)  # per-seed images
    alpha_images: list = field(default_factory=list)  # per-seed alphas (H, W) of a transparent film


def _render_file(blend_path, settings, camera, out):
    """Open the file, apply the settings and camera overrides, render it into `out`: (render
    time, the camera overrides applied)."""
    import bpy

    from ..addon.blendfile import open_blend, render_still
    open_blend(blend_path)
    scene = bpy.context.scene
    _apply(scene, settings)
    extra = _apply_camera(scene, camera)
    scene.render.filepath = out
    start = time.perf_counter()
    render_still(blend_path)
    return time.perf_counter() - start, extra


def _render_one(blend_path, settings, camera, workdir):
    """(RGB, alpha or None (an opaque film), render time, camera overrides) of one render."""
    from ..tracer.image import read_channel, read_exr
    out = os.path.join(workdir, "cycles.exr")
    elapsed, extra = _render_file(blend_path, settings, camera, out)
    rgb = read_exr(out).astype(np.float64)
    alpha = (read_channel(out, "A").astype(np.float64)
             if any(k == "output" and v == OUTPUT_RGBA for k, v, _ in settings) else None)
    os.remove(out)
    return rgb, alpha, elapsed, extra


def render_seeds(blend_path, *, spp: int, max_depth: int, seeds=(1, 2, 3, 4), threads: int = 2,
                 camera=None, progress=None, quiet_blender=True, overrides=None,
                 film=None, bounces=None, caustics=None, added=()) -> CyclesResult:
    """Render the file once per seed with `spp` samples each; mean and variance of the mean.
    film, bounces and caustics: forced_settings'. added: (setting, value, reason) applied after the
    forced settings (e.g. SHADOW_CAUSTICS off).

    progress(done, total, elapsed_s) is called after each seed.
    """
    seeds = list(seeds)
    if len(seeds) < 2:
        raise ValueError("need at least two seeds for a variance")
    images, alphas, total, extra = [], [], 0.0, []
    with tempfile.TemporaryDirectory(prefix="snell-cycles-") as workdir:
        for k, seed in enumerate(seeds):
            settings = forced_settings(max_depth, spp, seed, threads, film, bounces, caustics)
            if overrides:  # experiments only: replace forced values
                settings = [(k, overrides.get(k, v), why) for k, v, why in settings]
            settings = settings + list(added)
            with stdout_silenced(quiet_blender):
                rgb, alpha, elapsed, extra = _render_one(blend_path, settings, camera, workdir)
            images.append(rgb)
            if alpha is not None:
                alphas.append(alpha)
            total += elapsed
            if progress is not None:
                progress(k + 1, len(seeds), total)
    stack = np.stack(images)
    mean = stack.mean(axis=0)
    var = stack.var(axis=0, ddof=1) / len(seeds)
    settings = forced_settings(max_depth, spp, seeds[0], threads, film, bounces, caustics)
    settings = [s for s in settings if s[0] != "cycles.seed"] + list(added)
    settings.append(("cycles.seed", ", ".join(map(str, seeds)),
                     f"{len(seeds)} independent renders; variance of the mean from their spread"))
    return CyclesResult(mean, var, spp * len(seeds), seeds, total, settings + extra, images,
                        alphas)


# Cycles' Denoising Data passes (View Layer > Passes > Data), read from a multilayer EXR.
DENOISING_PASSES = ("Denoising Albedo", "Denoising Normal")
DENOISING_OUTPUT = "OPEN_EXR_MULTILAYER 32-bit, Combined and the Denoising Data passes"


def read_pass(path, name: str) -> np.ndarray:
    """A pass's three channels (R, G, B or X, Y, Z, in the file's order; an RGBA pass's first
    three), float64 (H, W, 3), row 0 = top, from a multilayer EXR
    ("<view layer>.<pass>.<channel>")."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise OSError(f"{path}: cannot read image ({oiio.geterror()})")
    try:
        part = 0
        while inp.seek_subimage(part, 0):
            spec = inp.spec()
            found = [k for k, channel in enumerate(spec.channelnames)
                     if f".{name}." in f".{channel}"]
            if len(found) in (3, 4):
                pixels = [np.asarray(inp.read_image(part, 0, k, k + 1, "float"), np.float64)
                          for k in found[:3]]
                return np.stack(pixels, axis=-1).reshape(spec.height, spec.width, 3)
            part += 1
    finally:
        inp.close()
    raise OSError(f"{path}: no {name} pass")


def render_denoising_passes(blend_path, *, spp: int, max_depth: int, seeds=(1, 2, 3, 4),
                            threads: int = 2, camera=None, quiet_blender=True) -> dict:
    """{pass name: CyclesResult} of Cycles' Denoising Albedo and Denoising Normal passes, each
    rendered once per seed with `spp` samples and the validator's forced settings (no
    denoising: the passes are the path tracer's own estimates)."""
    seeds = list(seeds)
    if len(seeds) < 2:
        raise ValueError("need at least two seeds for a variance")
    images = {name: [] for name in DENOISING_PASSES}
    total, extra = 0.0, []
    with tempfile.TemporaryDirectory(prefix="snell-cycles-") as workdir:
        for seed in seeds:
            settings = forced_settings(max_depth, spp, seed, threads) + [
                ("view_layers.cycles.denoising_store_passes", True, "the Denoising Data passes"),
                ("output", DENOISING_OUTPUT, "the passes, read back")]
            out = os.path.join(workdir, "passes.exr")
            with stdout_silenced(quiet_blender):
                elapsed, extra = _render_file(blend_path, settings, camera, out)
            total += elapsed
            for name in DENOISING_PASSES:
                images[name].append(read_pass(out, name))
            os.remove(out)
    results = {}
    for name, stack in images.items():
        stack = np.stack(stack)
        results[name] = CyclesResult(stack.mean(axis=0), stack.var(axis=0, ddof=1) / len(seeds),
                                     spp * len(seeds), seeds, total,
                                     forced_settings(max_depth, spp, seeds[0], threads) + extra,
                                     list(stack))
    return results


def seeds_for(k: int, base: int = 0):
    """K distinct Cycles seeds derived from a base seed."""
    return [base * 1000 + i + 1 for i in range(k)]


__all__ = ["forced_settings", "scene_film", "adaptive_settings", "read_sample_count",
           "render_seeds", "CyclesResult", "NoCyclesEquivalent",
           "read_pass", "render_denoising_passes", "DENOISING_PASSES",
           "fstop_for_radius", "seeds_for"]
