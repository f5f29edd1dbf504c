"""Snell's render settings: one schema, and the frozen RenderSettings a Renderer renders with.

Each setting is one Setting entry in SETTINGS: its name, type, default, range or choices, one
line of documentation and its scope, which says where it appears:

- SCENE: saved in the scene file's "render" object, a Blender property and a command-line option;
- RUN: a Blender property and a command-line option, never saved (threads);
- VIEWPORT: a Blender property the viewport's Rendered mode reads;
- ESTIMATOR: other estimators of the same image, for the tests and the validator only.

The Blender properties (addon/properties.py), the exporter (addon/export/settings.py), the
command-line options (cli.py) and the table in docs/scene-format.md are all made from SETTINGS,
so adding a setting is one entry here (and the code that uses it).
"""
from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field

from .checks import SceneError, finite_number, int_in, short

SCENE, RUN, VIEWPORT, ESTIMATOR = "scene", "run", "viewport", "estimator"
# Integers that size arrays or loops stop here: one past would end the render with an overflow
# or an allocation failure instead of a named field.
MAX_INT = 2 ** 31 - 1
# Light paths traced per camera path where no pilot measures it (the viewport, whose first
# image must not wait for one; the light tracer's test mode beside a full path tracer): the value
# of least relMSE x time on cornell_spheres at 32 spp (tools/measure_caustics_split.py). Where
# the setting is 0, a pilot measures each scene's (light_budget.py).
LIGHT_PATHS_PER_CAMERA_PATH = 0.125
# What threads 0 means outside Blender: every logical core, as Cycles' automatic detection.
DEFAULT_THREADS = os.cpu_count() or 1


@dataclass(frozen=True)
class Setting:
    """One render setting: what it holds, where it appears and what it does."""
    name: str
    type: type                  # int, float, bool, or str: one of `choices`
    default: object
    doc: str                    # one line: the Blender tooltip, the option's help, the docs
    scope: str = SCENE
    least: float | None = None
    greatest: float | None = None
    least_excluded: bool = False
    choices: tuple = ()         # (value, what it means) pairs of a str setting
    label: str = ""             # Blender's property name (default: the name in words)
    metavar: str = ""           # the command-line option's value in its help (default: choices)
    ui: dict = field(default_factory=dict)   # Blender-only look: soft limits, step, subtype

    @property
    def option(self) -> str | None:
        """The command-line option, or None (VIEWPORT and ESTIMATOR settings have none)."""
        return "--" + self.name.replace("_", "-") if self.scope in (SCENE, RUN) else None

    @property
    def values(self) -> tuple:
        """The values of a choice setting."""
        return tuple(value for value, _ in self.choices)

    def check(self, value):
        """value, if this setting may hold it, else a SceneError naming render.<name>."""
        where = f"render.{self.name}"
        if self.type is bool:
            if not isinstance(value, bool):
                raise SceneError(f"{where}: expected true or false, got {short(value)}")
            return value
        if self.type is int:
            return int_in(value, where, self.least, self.greatest, "an integer")
        if self.type is float:
            return finite_number(value, where, self.least, self.least_excluded, self.greatest)
        if value not in self.values:
            raise SceneError(f"{where}: expected one of {', '.join(self.values)}, "
                             f"got {short(value)}")
        return value


# Open Image Denoise's options, as Cycles' Denoise panels name them (render and viewport).
INPUT_PASSES = (("color", "The image alone"),
                ("albedo", "The image and the Denoising Albedo pass"),
                ("albedo_normal", "The image, the Denoising Albedo and the Denoising Normal "
                                  "passes"))
PREFILTERS = (("none", "None: the passes are taken as noise-free"),
              ("fast", "Fast: the passes are denoised with the image"),
              ("accurate", "Accurate: the passes are denoised first, on their own"))
QUALITIES = (("high", "High: the best quality"),
             ("balanced", "Balanced: between quality and speed"),
             ("fast", "Fast: the fastest"))
FRESNEL_MODELS = ("exact", "schlick")    # the kernels' codes are positions in this tuple
SAMPLERS = ("stratified", "independent")

SETTINGS = (
    Setting("spp", int, 64, "Samples per pixel; with a noise threshold, the most any pixel takes",
            least=1, greatest=MAX_INT, label="Samples", metavar="N", ui={"soft_max": 4096}),
    Setting("max_depth", int, 8, "Emission plus up to this many bounces (the seed project's "
            "max_ray_depth; Cycles: max_bounces = Max Depth - 1); 0 shows only emitters seen "
            "directly",
            least=0, greatest=MAX_INT, metavar="M", ui={"soft_max": 64}),
    Setting("transparent_max_bounces", int, 8, "Transparent surfaces a path or a shadow ray "
            "passes at most (Cycles' Transparent bounces): a camera path ends at the next one, "
            "a shadow ray is blocked; they do not count towards Max Depth",
            least=0, greatest=MAX_INT, metavar="N", label="Transparent Bounces",
            ui={"soft_max": 64}),
    # Cycles' Light Paths > Max Bounces of each kind and Clamping, with Cycles' meaning (a scene
    # file without them is limited by max_depth alone: 1024 is in practice no limit).
    Setting("diffuse_bounces", int, 1024, "Diffuse reflections a path takes at most before "
            "its last (Cycles' Max Bounces > Diffuse): after one more it ends at the next surface",
            least=0, greatest=MAX_INT, metavar="N", label="Diffuse", ui={"soft_max": 64}),
    Setting("glossy_bounces", int, 1024, "Glossy reflections, a mirror's and glass's included, "
            "a path takes at most before its last (Cycles' Max Bounces > Glossy)",
            least=0, greatest=MAX_INT, metavar="N", label="Glossy", ui={"soft_max": 64}),
    Setting("transmission_bounces", int, 1024, "Transmissions (refraction, translucency) a path "
            "takes at most before its last (Cycles' Max Bounces > Transmission)",
            least=0, greatest=MAX_INT, metavar="N", label="Transmission", ui={"soft_max": 64}),
    # Cycles' Light Paths > Caustics switches (path_limits.py), on as in a new Blender file.
    Setting("caustics_reflective", bool, True, "Reflective caustics (Cycles' Light Paths > "
            "Caustics > Reflective): off, a surface a diffuse bounce reaches drops its glossy "
            "reflection (a mirror there is black), as Cycles; the light tracer follows",
            label="Reflective Caustics"),
    Setting("caustics_refractive", bool, True, "Refractive caustics (Cycles' Light Paths > "
            "Caustics > Refractive): off, a surface a diffuse bounce reaches drops its "
            "refraction (glass there only reflects), as Cycles; the light tracer follows",
            label="Refractive Caustics"),
    Setting("sample_clamp_direct", float, 0.0, "Scale down each sample of direct light whose "
            "red + green + blue exceeds 3 x this (Cycles' Clamping > Direct Light): fewer "
            "fireflies, a darker image where they were; 0 is off", least=0.0, metavar="C",
            label="Direct Light", ui={"soft_max": 100.0, "precision": 2}),
    Setting("sample_clamp_indirect", float, 0.0, "The same for indirect light (Cycles' "
            "Clamping > Indirect Light, 10 by default in Blender); 0 is off", least=0.0,
            metavar="C", label="Indirect Light", ui={"soft_max": 100.0, "precision": 2}),
    Setting("seed", int, 0, "Random seed: the same seed and sample count give the same image, "
            "whatever the thread count", least=0, greatest=MAX_INT, metavar="S"),
    Setting("fresnel", str, "exact", "Fresnel model for glass",
            choices=(("exact", "The exact unpolarised dielectric Fresnel equations, as Cycles"),
                     ("schlick", "Schlick's approximation, as the seed project (not Cycles)"))),
    Setting("caustics", bool, True, "Trace light paths from the lamps through mirrors and glass "
            "to the surfaces they light (the path tracer's image with far less noise in "
            "caustics; the caustics of point and spot lamps of radius 0 and suns of angle 0, "
            "which no camera path finds, only with it); runs only in scenes with mirrors or "
            "glass, a diffuse surface and a lamp that lights them"),
    Setting("shadow_caustics", bool, True, "Render light through smooth glass onto rough "
            "surfaces (diffuse, Principled, node trees) by manifold next-event estimation "
            "(mnee.py) where the file sets Cycles' shadow caustics (a caustics light, casters and "
            "receivers): a pool's floor under its water; off: the light tracer and the path "
            "tracer render it"),
    Setting("light_vertices", bool, True, "Connect every diffuse vertex of a camera path to a "
            "point that light from a lamp reaches first (the same image, with far less noise "
            "where surfaces next to lamps light the scene); runs only with mesh lights or area "
            "lamps, and an adaptive render keeps them only if its first samples measure that "
            "they pay"),
    # Adaptive sampling as Cycles' Sampling panel has it: names, defaults and ranges. Both are
    # optional in the file: files written before adaptive sampling have neither.
    Setting("noise_threshold", float, 0.01, "Adaptive sampling: a pixel stops sampling once its "
            "noise is below this (Cycles' default 0.01); 0 turns adaptive sampling off",
            least=0.0, metavar="T",
            ui={"soft_min": 0.001, "soft_max": 1.0, "step": 0.1, "precision": 4}),
    Setting("min_spp", int, 0, "Samples every pixel takes before it may stop (rounded up to a "
            "multiple of 16, at least 32); 0 chooses from the noise threshold as Cycles does "
            "(64 at 0.01)", least=0, greatest=MAX_INT, label="Min Samples",
            metavar="N", ui={"soft_max": 4096}),
    Setting("time_limit", float, 0.0, "Stop adding samples after this many seconds of "
            "rendering (the pass under way finishes; Cycles' Time Limit); 0 has no limit",
            least=0.0, metavar="S",
            ui={"soft_max": 3600.0, "subtype": "TIME_ABSOLUTE", "unit": "TIME_ABSOLUTE"}),
    # Cycles' Film > Pixel Filter. A scene file without them (one made in code, or written
    # before filters) keeps the 1-pixel box it always rendered with; a Blender file's export
    # carries its own (Cycles' default: Blackman-Harris, 1.5 pixels).
    Setting("pixel_filter", str, "box", "Pixel filter, as Cycles' Film > Pixel Filter: each "
            "camera sample's position is drawn from it around its pixel's centre (Blender "
            "files: the file's, Cycles' default Blackman-Harris)",
            choices=(("box", "Uniform over filter_width pixels (1: the pixel itself)"),
                     ("gaussian", "Gaussian, standard deviation filter_width / 4, cut at "
                                  "1.5 filter_width"),
                     ("blackman_harris", "Blackman-Harris window over 2 filter_width pixels"))),
    Setting("filter_width", float, 1.0, "Pixel filter width in pixels (Cycles' Film > Pixel "
            "Filter > Width; Blender's default 1.5)", least=0.01, greatest=10.0, metavar="PX",
            ui={"subtype": "PIXEL", "precision": 2}),
    Setting("film_exposure", float, 1.0, "Film > Exposure: the image is the radiance times "
            "this (applied when the image is read, as Cycles' film does: adaptive sampling and "
            "the alpha are unchanged)", least=0.0, metavar="X",
            ui={"soft_max": 10.0, "precision": 3}),
    Setting("film_transparent", bool, False, "Film > Transparent: camera rays that reach the "
            "world see no world; the image's alpha is the share of each pixel not covered "
            "(premultiplied colour, as Cycles')"),
    Setting("film_transparent_glass", bool, False, "Film > Transparent > Transparent Glass: "
            "with a transparent film, the world seen through glass (transmissions of roughness "
            "up to film_transparent_roughness) is transparent too, as Cycles'",
            label="Transparent Glass"),
    Setting("film_transparent_roughness", float, 0.1, "Film > Transparent > Roughness "
            "Threshold: glass up to this roughness counts as clear for Transparent Glass "
            "(Cycles' default 0.1)", least=0.0, greatest=1.0, metavar="R",
            label="Roughness Threshold", ui={"precision": 3}),
    # Denoising as Cycles' Render > Denoise panel has it: names, values and defaults (but off by
    # default: Snell's images are the unbiased estimate unless asked).
    Setting("denoise", bool, False, "Denoise the final image with Open Image Denoise (the noisy "
            "image and the guiding passes are kept beside it)"),
    Setting("denoising_input_passes", str, "albedo_normal", "The passes that guide the "
            "denoiser", choices=INPUT_PASSES, label="Passes"),
    Setting("denoising_prefilter", str, "accurate", "How the guiding passes are prefiltered",
            choices=PREFILTERS, label="Prefilter"),
    Setting("denoising_quality", str, "high", "Open Image Denoise's quality",
            choices=QUALITIES, label="Quality"),
    Setting("denoising_passes", bool, False, "Render the Denoising Albedo and Denoising Normal "
            "passes (Blender's Denoising Data) even without denoising; denoising renders them "
            "when its input passes need them", label="Denoising Data"),
    Setting("threads", int, 0, "Render threads; 0: Blender's Performance > Threads in "
            "Blender, the machine's logical cores elsewhere", scope=RUN, least=0, greatest=4096,
            metavar="T", ui={"soft_max": 256}),
    # Cycles' Sampling > Viewport > Denoise, with its defaults (Albedo, Fast, Balanced, from
    # the first sample).
    Setting("viewport_denoise", bool, False, "Denoise the viewport's Rendered image with Open "
            "Image Denoise", scope=VIEWPORT, label="Viewport Denoise"),
    Setting("viewport_denoising_input_passes", str, "albedo", "The passes that guide the "
            "viewport's denoiser", scope=VIEWPORT, choices=INPUT_PASSES, label="Passes"),
    Setting("viewport_denoising_prefilter", str, "fast", "How the viewport's guiding passes "
            "are prefiltered", scope=VIEWPORT, choices=PREFILTERS, label="Prefilter"),
    Setting("viewport_denoising_quality", str, "balanced", "The viewport denoiser's quality",
            scope=VIEWPORT, choices=QUALITIES, label="Quality"),
    Setting("viewport_denoise_start_sample", int, 1, "Samples the viewport takes before it "
            "denoises", scope=VIEWPORT, least=1, greatest=MAX_INT, label="Start Sample",
            ui={"soft_max": 4096}),
    Setting("viewport_spp", int, 1024, "Samples per pixel the viewport's Rendered mode refines "
            "to; 0 refines until the view changes or the viewport closes", scope=VIEWPORT,
            least=0, greatest=MAX_INT, label="Viewport Samples", ui={"soft_max": 4096}),
    Setting("viewport_time_limit", float, 0.0, "Stop refining the viewport after this many "
            "seconds; 0 has no limit", scope=VIEWPORT, least=0.0,
            ui={"soft_max": 600.0, "subtype": "TIME_ABSOLUTE", "unit": "TIME_ABSOLUTE"}),
    Setting("batches", int, 0, "Render in this many passes of equal samples and keep each "
            "pass's image, for variances from independent batches (adaptive sampling off); 0: "
            "no batches", scope=ESTIMATOR, least=0, greatest=MAX_INT),
    Setting("sampler", str, "stratified", "Where the camera, lens, light and BSDF samples come "
            "from", scope=ESTIMATOR,
            choices=(("stratified", "Owen-scrambled Sobol points: faster convergence, but the "
                                    "variances from the sums over-estimate the error"),
                     ("independent", "A hash of each path's key: honest variances (the "
                                     "validator's)"))),
    Setting("next_event", bool, True, "Sample the lights at every bounce; off: BSDF sampling "
            "only, a second estimator of the same image", scope=ESTIMATOR),
    Setting("env_sampling", bool, True, "Sample an environment map's directions by its image; "
            "off: uniformly (unbiased, noisier)", scope=ESTIMATOR),
    Setting("pure_light_tracing", bool, False, "Run the light tracer beside a full path tracer "
            "(not splitting the paths): its light image is a second estimate of the image but "
            "for emitters seen directly or through specular vertices only", scope=ESTIMATOR),
    Setting("fresnel_split", bool, True, "At smooth glass, count the light the mirror "
            "reflection finds at its next hit whichever way the path goes (wavefront."
            "split_fresnel); off: only when the path reflects, as Cycles (the same image, "
            "noisier in glints)", scope=ESTIMATOR),
    Setting("light_paths_per_camera_path", float, 0.0, "Light paths the light tracer traces "
            "per camera path; 0: measured before the render by a pilot of each kind "
            "(tracer/light_budget.py)", scope=ESTIMATOR, least=0.0),
    Setting("light_passes", bool, False, "Render the light passes (Emission, Environment, "
            "Diffuse, Glossy and Transmission Direct, Indirect and Color) beside the image; "
            "Blender's View Layer switches and `snell render --passes` ask for them",
            scope=ESTIMATOR),
    Setting("light_groups", bool, False, "Render the light groups' passes (Combined_<group>: "
            "the light of each group's lamps, emissive objects and world) beside the image; "
            "Blender's View Layer > Light Groups and `snell render --passes` ask for them",
            scope=ESTIMATOR),
    Setting("photon_merging", str, "denoised", "Render caustics seen through mirrors and "
            "glass (light through glass onto a diffuse surface, seen through glass: a pool's "
            "floor under its water) by photon merging with a radius that shrinks pass by pass "
            "(photon_merging.py): consistent, not unbiased, so only where the image is biased "
            "anyway (denoised) unless asked, and never in the validator",
            choices=(("off", "The path tracer renders those paths (unbiased)"),
                     ("denoised", "Merged when the image is denoised, else as off"),
                     ("on", "Merged")), scope=ESTIMATOR),
    Setting("merge_radius", float, 0.0, "Photon merging's first radius in scene units; 0: "
            "a pixel footprint at the far side of the mirrors and glass", scope=ESTIMATOR,
            least=0.0),
    Setting("light_vertex_pilot", bool, True, "An adaptive render measures in its first "
            "samples whether light vertices pay; off: keep them throughout", scope=ESTIMATOR),
)
BY_NAME = {s.name: s for s in SETTINGS}
# The settings a render reads pass by pass, not when a Renderer is built (Renderer.with_sampling).
SAMPLING = ("spp", "batches", "noise_threshold", "min_spp", "time_limit")


def of_scope(*scopes) -> tuple:
    """The settings of the given scopes, in schema order."""
    return tuple(s for s in SETTINGS if s.scope in scopes)


class _Settings:
    """RenderSettings' methods; its fields are made from SETTINGS below."""

    def __post_init__(self):
        for s in SETTINGS:     # numbers as their type: 0 given for a threshold is 0.0
            object.__setattr__(self, s.name, s.check(getattr(self, s.name)))

    @property
    def merges_photons(self) -> bool:
        """Whether photon merging is asked for: on, or on denoised images and this one is."""
        return self.photon_merging == "on" or (self.photon_merging == "denoised"
                                               and self.denoise)

    def replace(self, **overrides) -> "RenderSettings":
        """A copy with some settings changed, checked (an unknown name is a SceneError too)."""
        unknown = sorted(set(overrides) - set(BY_NAME))
        if unknown:
            raise SceneError(f"render.{unknown[0]}: not a render setting")
        return dataclasses.replace(self, **overrides)

    @classmethod
    def from_render(cls, render: dict, **overrides) -> "RenderSettings":
        """The settings of a scene file's "render" object (absent keys: their defaults), with
        overrides; keys that are not saved settings are left out, as an older Snell would."""
        if not isinstance(render, dict):
            raise SceneError(f"render: expected an object, got {short(render)}")
        saved = {s.name: render[s.name] for s in of_scope(SCENE) if s.name in render}
        return cls().replace(**{**saved, **overrides})

    def to_render(self) -> dict:
        """The scene file's "render" object: the SCENE settings."""
        return {s.name: getattr(self, s.name) for s in of_scope(SCENE)}

    @property
    def wants_features(self) -> bool:
        """Whether a render makes the Denoising Albedo and Normal passes."""
        return self.denoising_passes or (self.denoise and self.denoising_input_passes != "color")

    @property
    def render_threads(self) -> int:
        """The threads to render with (threads 0: DEFAULT_THREADS)."""
        return self.threads or DEFAULT_THREADS


# Frozen, one field per setting with its default: a setting is added to SETTINGS only.
RenderSettings = dataclasses.make_dataclass(
    "RenderSettings", [(s.name, s.type, field(default=s.default)) for s in SETTINGS],
    bases=(_Settings,), frozen=True,
    namespace={"__doc__": "Every setting of a render, checked; build with from_render or "
                          "replace.", "__module__": __name__})

DEFAULT_RENDER = RenderSettings().to_render()


def markdown_table() -> str:
    """The settings as the Markdown table in docs/scene-format.md (tests/unit/test_settings.py
    holds the page to it)."""
    where = {SCENE: "scene file, Blender, command line", RUN: "Blender, command line",
             VIEWPORT: "Blender (viewport)", ESTIMATOR: "tests and validator"}
    rows = ["| setting | type | default | range | where | what it does |",
            "| --- | --- | --- | --- | --- | --- |"]
    for s in SETTINGS:
        rows.append(f"| `{s.name}` | {_type_name(s)} | `{_literal(s.default)}` | {_range(s)} "
                    f"| {where[s.scope]} | {s.doc} |")
    return "\n".join(rows) + "\n"


def _type_name(s: Setting) -> str:
    return {int: "integer", float: "number", bool: "boolean", str: "choice"}[s.type]


def _literal(value) -> str:
    """A default as the scene file's JSON writes it."""
    return str(value).lower() if isinstance(value, bool) else str(value)


def _range(s: Setting) -> str:
    if s.choices:
        return ", ".join(f"`{v}`" for v in s.values)
    if s.type is bool:
        return "`true`, `false`"
    low = f"> {s.least}" if s.least_excluded else f">= {s.least}"
    return low if s.greatest is None else f"{s.least} to {s.greatest}"
