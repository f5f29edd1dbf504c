"""The file's Cycles settings: the ones Snell follows, and the ones it does not render.

A Blender user sets samples, noise threshold and bounces in Cycles' panels; a file renders with
them in Snell too unless its Snell settings say "Follow Cycles' Settings" off (then Snell's own
Sampling and Light Paths panels hold them). FOLLOWED says how each Cycles setting becomes a Snell
setting; NOT_RENDERED lists the Cycles settings Snell has no counterpart for, what Snell does
instead, and when the difference is worth a warning (docs/blender.md, "The file's Cycles
settings").
"""
from __future__ import annotations

from dataclasses import dataclass

# Where a render setting's value came from, as `snell info` says it.
FROM_CYCLES = "file's Cycles setting"
FROM_SNELL = "Snell override"            # Follow Cycles' Settings off: Snell's panel
FROM_SNELL_PANEL = "Snell setting"        # a setting Cycles has not (fresnel, caustics, ...)
FROM_DEFAULT = "default"


@dataclass(frozen=True)
class Followed:
    """A Snell setting read from Cycles' settings: its name, Cycles' label and the reading."""
    name: str
    label: str          # Cycles' panel and property, for `snell info`
    read: object        # (cycles, frame) -> the Snell value


def _noise_threshold(c, frame):
    if not c.use_adaptive_sampling:
        return 0.0
    # Cycles' 0 means automatic (its tooltip: 'based on number of AA samples'); the rule
    # max(0.001, 1 / samples) is Cycles' scene/integrator.cpp as recalled, not yet checked
    # against a Cycles render's sample counts.
    return float(f"{c.adaptive_threshold:.7g}") or max(0.001, 1.0 / max(1, c.samples))


def _seed(c, frame):
    # Animated seed: a different noise pattern on every frame, as Cycles'. Cycles hashes the
    # frame with the seed; Snell's sampler differs from Cycles' anyway, so any per-frame change
    # of the seed gives the same kind of image.
    if c.use_animated_seed:
        return (c.seed + 7919 * frame) % (2 ** 31 - 1)
    return c.seed


# Cycles' denoising input passes and Snell's values of denoising_input_passes.
INPUT_PASSES = {"RGB": "color", "RGB_ALBEDO": "albedo", "RGB_ALBEDO_NORMAL": "albedo_normal"}


def _denoising_data(c, frame):
    """Blender's View Layer > Passes > Data > Denoising Data, on any view layer."""
    scene = getattr(c, "id_data", None)
    layers = getattr(scene, "view_layers", ())
    return any(bool(getattr(getattr(layer, "cycles", None), "denoising_store_passes", False))
               for layer in layers)


FOLLOWED = (
    Followed("spp", "Sampling > Render > Max Samples", lambda c, f: int(c.samples)),
    Followed("noise_threshold", "Sampling > Render > Noise Threshold", _noise_threshold),
    Followed("min_spp", "Sampling > Render > Min Samples",
             lambda c, f: int(c.adaptive_min_samples)),
    Followed("time_limit", "Sampling > Render > Time Limit",
             lambda c, f: float(f"{c.time_limit:.7g}")),
    Followed("seed", "Sampling > Advanced > Seed", _seed),
    # Both count 0 as "until stopped".
    Followed("viewport_spp", "Sampling > Viewport > Max Samples",
             lambda c, f: int(c.preview_samples)),
    # Cycles' max_bounces N allows N + 1 scattering events; Snell's max depth counts emission
    # plus up to M bounces, so M = N + 1 (validation/cycles.py forces the same; checked there).
    Followed("max_depth", "Light Paths > Max Bounces > Total", lambda c, f: int(c.max_bounces) + 1),
    Followed("transparent_max_bounces", "Light Paths > Max Bounces > Transparent",
             lambda c, f: int(c.transparent_max_bounces)),
    # The limits of each kind and clamping keep Cycles' meaning in Snell (tracer/path_limits.py).
    Followed("diffuse_bounces", "Light Paths > Max Bounces > Diffuse",
             lambda c, f: int(c.diffuse_bounces)),
    Followed("glossy_bounces", "Light Paths > Max Bounces > Glossy",
             lambda c, f: int(c.glossy_bounces)),
    Followed("transmission_bounces", "Light Paths > Max Bounces > Transmission",
             lambda c, f: int(c.transmission_bounces)),
    # Snell drops the same lobes after a diffuse bounce, its light tracer the same paths
    # (tracer/path_limits.py).
    Followed("caustics_reflective", "Light Paths > Caustics > Reflective",
             lambda c, f: bool(c.caustics_reflective)),
    Followed("caustics_refractive", "Light Paths > Caustics > Refractive",
             lambda c, f: bool(c.caustics_refractive)),
    # Snell's light tracer's caustics are not clamped (NOT_RENDERED's "clamped caustics").
    Followed("sample_clamp_direct", "Light Paths > Clamping > Direct Light",
             lambda c, f: float(f"{c.sample_clamp_direct:.7g}")),
    Followed("sample_clamp_indirect", "Light Paths > Clamping > Indirect Light",
             lambda c, f: float(f"{c.sample_clamp_indirect:.7g}")),
    # Snell samples Cycles' filters as Cycles does (tracer/pixel_filter.py); its values are
    # Cycles' identifiers in lower case.
    Followed("pixel_filter", "Film > Pixel Filter > Type",
             lambda c, f: str(c.pixel_filter_type).lower()),
    Followed("filter_width", "Film > Pixel Filter > Width",
             lambda c, f: float(f"{c.filter_width:.7g}")),
    Followed("film_exposure", "Film > Exposure", lambda c, f: float(f"{c.film_exposure:.7g}")),
    # Blender's own render setting (scene.render), shown in Cycles' Film panel.
    Followed("film_transparent", "Film > Transparent",
             lambda c, f: bool(c.id_data.render.film_transparent)),
    Followed("film_transparent_glass", "Film > Transparent > Transparent Glass",
             lambda c, f: bool(c.film_transparent_glass)),
    Followed("film_transparent_roughness", "Film > Transparent > Roughness Threshold",
             lambda c, f: float(f"{c.film_transparent_roughness:.7g}")),
    # Snell denoises with Open Image Denoise whatever Cycles' denoiser (OptiX: NOT_RENDERED).
    Followed("denoise", "Sampling > Render > Denoise", lambda c, f: bool(c.use_denoising)),
    Followed("denoising_input_passes", "Sampling > Render > Denoise > Passes",
             lambda c, f: INPUT_PASSES.get(c.denoising_input_passes, "albedo_normal")),
    Followed("denoising_prefilter", "Sampling > Render > Denoise > Prefilter",
             lambda c, f: c.denoising_prefilter.lower()),
    Followed("denoising_quality", "Sampling > Render > Denoise > Quality",
             lambda c, f: c.denoising_quality.lower()),
    Followed("denoising_passes", "View Layer > Passes > Data > Denoising Data", _denoising_data),
    Followed("viewport_denoise", "Sampling > Viewport > Denoise",
             lambda c, f: bool(c.use_preview_denoising)),
    Followed("viewport_denoising_input_passes", "Sampling > Viewport > Denoise > Passes",
             lambda c, f: INPUT_PASSES.get(c.preview_denoising_input_passes, "albedo")),
    Followed("viewport_denoising_prefilter", "Sampling > Viewport > Denoise > Prefilter",
             lambda c, f: c.preview_denoising_prefilter.lower()),
    Followed("viewport_denoising_quality", "Sampling > Viewport > Denoise > Quality",
             lambda c, f: c.preview_denoising_quality.lower()),
    Followed("viewport_denoise_start_sample", "Sampling > Viewport > Denoise > Start Sample",
             lambda c, f: int(c.preview_denoising_start_sample)),
)


@dataclass(frozen=True)
class NotRendered:
    """A Cycles setting Snell has no counterpart for: what Snell renders instead, whether a value
    renders as Snell does (same(value, cycles)), and whether a different value changes only the
    noise, not the image's expected value (noise_only)."""
    prop: str
    label: str
    snell: str
    same: object
    noise_only: bool = False


def _zero(value, c):
    return value == 0


def _always(value, c):
    return True


NOT_RENDERED = (
    NotRendered("volume_bounces", "Light Paths > Volume bounces", "Snell has no volumes",
                _always),
    # Followed on the path tracer's samples; a light tracer's samples are of another kind
    # (tracer/path_limits.py): clamping them at Cycles' limit would not clamp what Cycles does.
    NotRendered("sample_clamp_indirect", "Light Paths > Clamping > Indirect Light (caustics)",
                "the caustics of Snell's light tracer are not clamped: brighter than a clamped "
                "Cycles render's where Cycles' caustics are fireflies", _zero),
    NotRendered("blur_glossy", "Light Paths > Caustics > Filter Glossy", "no glossy filtering: "
                "sharper caustics", _zero),
    NotRendered("use_light_tree", "Sampling > Lights > Light Tree", "Snell's own light "
                "sampling", lambda v, c: False, noise_only=True),
    NotRendered("light_sampling_threshold", "Sampling > Lights > Light Threshold", "Snell's own "
                "light sampling", _zero, noise_only=True),
    NotRendered("use_guiding", "Sampling > Path Guiding", "no path guiding",
                lambda v, c: not v, noise_only=True),
    NotRendered("denoiser", "Sampling > Render > Denoise > Denoiser", "Snell denoises with "
                "Open Image Denoise on the CPU", lambda v, c: v == "OPENIMAGEDENOISE" or
                not c.use_denoising),
)


def not_rendered(cycles) -> list[dict]:
    """The Cycles settings Snell does not render, each {"label", "value", "snell", "status",
    "warn"}: status "same" (the value renders as Snell does), "noise" (only the noise differs) or
    "differs"; warn when it differs and is not Cycles' default (a difference the user set)."""
    out = []
    for entry in NOT_RENDERED:
        value = getattr(cycles, entry.prop, None)
        if value is None:
            continue        # an older or newer Cycles without it
        default = getattr(cycles.bl_rna.properties.get(entry.prop), "default", None)
        if isinstance(value, float):
            value = float(f"{value:.7g}")
            default = None if default is None else float(f"{default:.7g}")
        status = ("same" if entry.same(value, cycles) else
                  "noise" if entry.noise_only else "differs")
        out.append(_entry(entry.label, _shown(value), entry.snell, status, value != default))
    return out


def _entry(label, value, snell, status, non_default) -> dict:
    return {"label": label, "value": value, "snell": snell, "status": status,
            "warn": bool(status == "differs" and non_default)}


def followed(cycles, frame: int) -> dict:
    """{setting name: value} of the Cycles settings Snell follows, at this frame."""
    return {f.name: f.read(cycles, frame) for f in FOLLOWED}


def _shown(value) -> str:
    if isinstance(value, bool):
        return "on" if value else "off"
    if isinstance(value, str):
        return value.replace("_", "-").title()
    return f"{value:g}"
