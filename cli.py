"""The `snell` command line: render, export and inspect scenes.

Each subcommand is two functions, `_setup_<name>(parser)` adding its arguments and
`cmd_<name>(args) -> int` running it, plus one line in COMMANDS. A user error (missing file, bad
scene, wrong extension) is raised as CliError, SceneError or OSError and reported by main() as one
`snell: error: ...` line with exit status 1; anything else is a bug and keeps its traceback.
Ctrl-C exits with 130 and writes nothing partial (image writes are atomic and happen after the
render).

This module is the top of the command tree: it imports the command modules to dispatch to them,
and nothing in the package imports it; the helpers they share live in errors.py.
"""
from __future__ import annotations

import argparse
import contextlib
import importlib.abc
import importlib.machinery
import os
import signal
import sys
import time

from .errors import (EXIT_ERROR, EXIT_INTERRUPTED, EXIT_USAGE, CliError, check_input_file,
                     check_writable_directory, ctrl_c_held, int_at_least, number_at_least,
                     print_error, warn)


def _interrupted_while_starting(signum, frame):
    # Nothing is written yet: leave at once, as Ctrl-C later leaves (exit 130, one line).
    os.write(2, b"snell: interrupted\n")
    os._exit(EXIT_INTERRUPTED)


# Ctrl-C while the modules below load (NumPy, the tracer, the validator: a second or more)
# raised KeyboardInterrupt inside an import, a traceback and no exit 130. Only over Python's
# own handler (a background job's ignored Ctrl-C stays ignored), and only in the main thread.
_starting = signal.getsignal(signal.SIGINT) is signal.default_int_handler
with contextlib.suppress(ValueError):
    if _starting:
        signal.signal(signal.SIGINT, _interrupted_while_starting)

from .addon.console import stdout_silenced  # noqa: E402
from .faults import fault_stacks  # noqa: E402
from .tracer.progress import describe_adaptive, pixels_sampling, time_left  # noqa: E402
from .tracer.scene import (LIGHT_KINDS, MATERIAL_KINDS, SceneError, aperture_radius,  # noqa: E402
                           load, save)
from .tracer.settings import DEFAULT_THREADS, RUN, SCENE, of_scope  # noqa: E402
from .validation.commands import COMMANDS as VALIDATION_COMMANDS  # noqa: E402

with contextlib.suppress(ValueError):
    if _starting:
        signal.signal(signal.SIGINT, signal.default_int_handler)

SCENE_EXTENSIONS = (".blend", ".snell")


class _Parser(argparse.ArgumentParser):
    """Usage errors as one `snell: error: ...` line too (exit status 2, as argparse does)."""

    commands: dict = {}     # the top parser's subcommand parsers, by name

    def error(self, message):
        self.exit(EXIT_USAGE, f"snell: error: {message} (see {self.prog} --help)\n")

    def parse_args(self, args=None, namespace=None):
        """As argparse's, but an unknown option is the subcommand's error, pointing to its help."""
        parsed, extra = self.parse_known_args(args, namespace)
        if extra:
            parser = self.commands.get(getattr(parsed, "command", None), self)
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        return parsed


# ---------------------------------------------------------------------------------------------
# Shared helpers


def _extension(path: str) -> str:
    return os.path.splitext(path)[1].lower()


def check_scene_path(path: str) -> str:
    """A scene file's extension, .blend or .snell, once the file is there to read; CliError
    otherwise."""
    ext = _extension(path)
    if ext not in SCENE_EXTENSIONS:
        raise CliError(f"{path}: unknown scene extension {ext or '(none)'!r} "
                       "(expected .blend or .snell)")
    check_input_file(path, SCENE_EXTENSIONS)
    return ext


def load_scene(path: str):
    """A Scene from a .snell file, or exported on the fly from a .blend (warnings to stderr)."""
    ext = check_scene_path(path)
    if ext == ".snell":
        try:
            return load(path)
        except SceneError as exc:  # name the file too: the loader's message names the field
            if str(exc).startswith(path):
                raise
            raise SceneError(f"{path}: {exc}") from None
    try:
        from .addon.blendfile import blender_reason
        from .addon.export import export_blend
        with stdout_silenced():
            scene, warnings = export_blend(path)
    except ModuleNotFoundError as exc:
        if exc.name != "bpy":
            raise
        raise CliError(f"{path}: reading .blend files needs Blender's bpy module "
                       "(pip install 'snell[blender]')") from None
    except RuntimeError as exc:  # what bpy raises beyond opening the file (addon/blendfile.py)
        raise CliError(f"{path}: cannot export ({blender_reason(exc)})") from None
    for message in warnings:
        warn(message)
    return scene


def _check_output(path: str, ext: str, option: str) -> None:
    """Fail before a long render, not after it."""
    if _extension(path) != ext:
        raise CliError(f"{option} {path}: expected a {ext} file name")
    check_writable_directory(path, option)


def _duration(seconds: float) -> str:
    if seconds != seconds or seconds == float("inf"):
        return "?"
    if seconds < 60:
        return f"{seconds:.1f}s"
    minutes, secs = divmod(int(round(seconds)), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"


class ProgressLine:
    """The integrator's progress callback: one updating line on a terminal."""

    def __init__(self, stream):
        self.stream = stream
        self.start = time.monotonic()
        self.width = 0

    def __call__(self, result, passes_done, passes_total):
        # Samples over the budget, not passes: with adaptive sampling the pass count is a guess.
        elapsed = time.monotonic() - self.start
        sampling = pixels_sampling(result)
        line = (f"snell: {result.spp}/{result.spp_budget} spp"
                f"{', ' + sampling if sampling else ''}, "
                f"elapsed {_duration(elapsed)}, ETA {_duration(time_left(result, elapsed))}")
        self.stream.write("\r" + line.ljust(self.width))
        self.stream.flush()
        self.width = len(line)
        return True

    def close(self):
        if self.width:
            self.stream.write("\n")
            self.stream.flush()


# ---------------------------------------------------------------------------------------------
# snell render


def _setup_render(p):
    p.add_argument("scene", help="a .blend (exported on the fly) or a .snell scene file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.exr",
                   help="linear float EXR to write")
    p.add_argument("--png", metavar="OUT.png",
                   help="also write an 8-bit PNG through the .blend's view transform, look, "
                        "exposure and gamma (a .snell file's: Standard)")
    p.add_argument("--passes", type=_passes, metavar="LIST", default=[],
                   help="also write these passes as layers of the EXR, named as Blender names "
                        f"them, comma-separated: {', '.join(PASSES)}, and Combined_GROUP for "
                        "each of the scene's light groups")
    _add_setting_options(p)
    _add_scale_option(p)
    _add_farm_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar and no summary")


# The View Layer passes `--passes` writes, as Blender names their EXR layers, and the ones
# Blender has that Snell does not render yet (left out with a warning, never written empty).
LIGHT_PASSES = ("Emission", "Environment", "Diffuse Direct", "Diffuse Indirect", "Diffuse Color",
                "Glossy Direct", "Glossy Indirect", "Glossy Color", "Transmission Direct",
                "Transmission Indirect", "Transmission Color")
PASSES = ("Depth", "Position", "Normal", "Object Index", "Debug Sample Count", "Denoising Albedo",
          "Denoising Normal", "Noisy Image") + LIGHT_PASSES
NOT_RENDERED_PASSES = ("Mist", "Vector", "UV", "Material Index", "Ambient Occlusion",
                       "Shadow Catcher", "Volume Direct", "Volume Indirect")


# A light group's pass: Combined_<group> (tracer/light_groups.py), the group's name as it is.
GROUP_PREFIX = "Combined_"


def _passes(text):
    """--passes checked when the options are parsed: Blender's pass names, any case, and the
    light groups' Combined_<group> (the scene's groups are checked once it is read)."""
    known = {name.lower(): name for name in PASSES + NOT_RENDERED_PASSES}
    names = [part.strip() for part in text.split(",") if part.strip()]
    for name in names:
        if name.lower() not in known and not _group_of(name):
            raise argparse.ArgumentTypeError(f"no pass {name!r} (Blender's passes Snell writes: "
                                             f"{', '.join(PASSES)}, {GROUP_PREFIX}<light group>)")
    return [known.get(name.lower()) or GROUP_PREFIX + _group_of(name) for name in names]


def _group_of(name: str) -> str:
    """The light group a pass name names (Combined_<group>, the prefix in any case), or ''."""
    return name[len(GROUP_PREFIX):] if name.lower().startswith(GROUP_PREFIX.lower()) else ""


def _light_groups_asked(args, scene) -> bool:
    """Whether the render makes the light groups' passes: --passes names one (each must be one
    of the scene's groups)."""
    asked = [_group_of(name) for name in args.passes if _group_of(name)]
    for group in asked:
        if group not in scene.light_groups:
            listed = ", ".join(repr(g) for g in scene.light_groups) or "none"
            raise CliError(f"{args.scene}: --passes: no light group {group!r} in the scene "
                           f"(its light groups: {listed})")
    return bool(asked)


def _add_farm_options(p):
    """--workers N and --cluster ADDRESS: render on Dask (farm/)."""
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int_at_least(1), metavar="N",
                       help="render on N local worker processes (Dask)")
    where.add_argument("--cluster", metavar="ADDRESS",
                       help="render on the Dask scheduler at ADDRESS, e.g. tcp://host:8786")


ON_OFF = ("on", "off")


def _add_setting_options(p):
    """One option per render setting the command line takes (tracer/settings.py's SCENE and RUN
    settings), for `snell render` and `snell batch`."""
    for setting in of_scope(SCENE, RUN):
        p.add_argument(setting.option, dest=setting.name, metavar=setting.metavar or None,
                       help=_option_help(setting), **_option_values(setting))


def _add_scale_option(p):
    """--scale, Blender's Resolution % (not a render setting: the scene's camera holds it)."""
    p.add_argument("--scale", type=int_at_least(1, 10000), metavar="PCT",
                   help="resolution percentage, as Blender's Resolution %% (default: the scene's)")


def _option_values(setting) -> dict:
    """argparse's choices or type of a setting's option: on/off (alone: on, as `--denoise`), its
    choices, or its range."""
    if setting.type is bool:
        return {"choices": ON_OFF, "nargs": "?", "const": "on"}
    if setting.type is str:
        return {"choices": setting.values}
    at_least = int_at_least if setting.type is int else number_at_least
    return {"type": at_least(setting.least, setting.greatest)}


def _option_help(setting) -> str:
    """The setting's documentation line, and its default (the scene's, for saved settings)."""
    default = ON_OFF[not setting.default] if setting.type is bool else setting.default
    where = "the scene's, " if setting.scope == SCENE else ""
    return f"{setting.doc[0].lower()}{setting.doc[1:]} (default: {where}{default})"


def setting_overrides(args) -> dict:
    """The render settings given on the command line, by name (on/off as booleans)."""
    given = {}
    for setting in of_scope(SCENE, RUN):
        value = getattr(args, setting.name)
        if value is not None:
            given[setting.name] = value == "on" if setting.type is bool else value
    return given


def cmd_render(args) -> int:
    _check_output(args.output, ".exr", "-o")
    if args.png:
        _check_output(args.png, ".png", "--png")
    check_scene_path(args.scene)
    # The cluster starts (or is connected to) while the scene loads: a .blend's export takes
    # the client seconds, a LocalCluster's start and its workers' kernel loads as long.
    with _farm_opening(args, args.quiet) as farm:
        scene, settings = _render_settings(args, farm is not None)
        result = _render(args, scene, settings, farm)
    from .tracer import image
    if result.cancelled:
        raise KeyboardInterrupt
    # The alpha (Film > Transparent, a Holdout) and each pixel's samples as extra channels.
    channels = result.exr_channels()
    denoised = None
    if settings.denoise:
        from .tracer.denoise import denoise_result
        denoised = denoise_result(result, settings)
        rgb = denoised.image
        if denoised.warning:
            print(f"snell: warning: {args.scene}: {denoised.warning}", file=sys.stderr)
        channels.update(pass_channels(denoised))
    else:
        rgb = result.mean()
        if getattr(result, "has_features", False):
            channels.update(pass_channels(None, result))
    channels.update(_pass_layers(args, scene, settings, result, denoised))
    bad_pixels = image.write_exr(args.output, rgb, channels=channels)
    alpha = result.alpha() if getattr(result, "has_alpha", False) else None
    if args.png and _extension(args.scene) == ".blend":
        from .addon import display
        display.write_png(args.png, rgb, args.scene, alpha)
    elif args.png:
        image.write_png(args.png, rgb, alpha)
    if not args.quiet:
        print(_summary(args, rgb, result, bad_pixels, denoised))
    return 0


def _render_settings(args, farm: bool) -> tuple:
    """`snell render`'s scene (scaled) and its settings (the options and the passes asked for);
    checked for a cluster when `farm`."""
    scene = load_scene(args.scene)
    if args.scale is not None:
        scene = scene.with_camera(resolution_percentage=args.scale)
    settings = scene.settings(**setting_overrides(args))
    if {"Denoising Albedo", "Denoising Normal"} & set(args.passes):
        settings = settings.replace(denoising_passes=True)
    if set(LIGHT_PASSES) & set(args.passes):
        settings = settings.replace(light_passes=True)
    if _light_groups_asked(args, scene):
        settings = settings.replace(light_groups=True)
    if farm:
        from .farm.render import check_settings
        check_settings(settings, args.scene)
    return scene, settings


def _render(args, scene, settings, farm):
    """The render, on the cluster (farm: farm/render.py's Opening) or in this process, with the
    progress line on a terminal."""
    if farm is None:
        _compile_kernels(args.quiet)
    bar = ProgressLine(sys.stderr) if not args.quiet and sys.stderr.isatty() else None
    try:
        if farm is not None:
            return farm.wait()(scene, settings, args.scene, progress=bar)
        from .tracer.integrator import render
        return render(scene, settings, progress=bar)
    finally:
        if bar:
            bar.close()


def _compile_kernels(quiet: bool) -> None:
    """Compile the kernels on their first run, saying so unless quiet (local Dask workers load
    what this compiles from the disk cache)."""
    from .tracer.integrator import kernels_compiled, warm_up
    if not kernels_compiled():
        if not quiet:
            print("snell: compiling kernels (first run only)", file=sys.stderr, flush=True)
        warm_up()


# Blender's names of the passes a denoised render writes beside its image (its EXR layers).
NOISY, ALBEDO, NORMAL = "Noisy Image", "Denoising Albedo", "Denoising Normal"


def pass_channels(denoised, result=None) -> dict:
    """{"<layer>.R": (H, W) values, ...} of the passes written beside the image: the noisy image
    (when the image is denoised) and the Denoising Albedo and Normal passes (when rendered), as
    Blender names them."""
    from .tracer import image
    layers = {}
    if denoised is not None:
        layers[NOISY] = denoised.noisy
        albedo, normal = denoised.albedo, denoised.normal
    else:
        albedo, normal = result.denoising_albedo(), result.denoising_normal()
    if albedo is not None:
        layers[ALBEDO], layers[NORMAL] = albedo, normal
    channels = {}
    for layer, values in layers.items():
        clean, _ = image.sanitize(values)
        for k, c in enumerate("RGB"):
            channels[f"{layer}.{c}"] = clean[..., k]
    return channels


def _pass_layers(args, scene, settings, result, denoised) -> dict:
    """{"<pass>.<channel>": (H, W) values} of the --passes that pass_channels does not write
    (the denoising layers: the render makes them when they are asked for); a pass Snell cannot
    make is left out with a warning."""
    lit = getattr(result, "has_light_passes", False)
    for name in args.passes:
        missing = (name in (ALBEDO, NORMAL) and not getattr(result, "has_features", False)
                   or name in LIGHT_PASSES and not lit)
        if name in NOT_RENDERED_PASSES or (name == NOISY and denoised is None) or missing:
            why = ("without --denoise" if name == NOISY else
                   "on a cluster yet" if missing else "by Snell yet")
            print(f"snell: warning: {args.scene}: pass {name!r} is not rendered {why}: left out",
                  file=sys.stderr)
    layers = {}
    if "Debug Sample Count" in args.passes:
        layers["Debug Sample Count.X"] = result.samples()
    light = [name for name in args.passes if name in LIGHT_PASSES]
    if light and lit:
        from .tracer import image
        values = result.light_pass_images()
        for name in light:
            clean, _ = image.sanitize(values[name])
            for k, channel in enumerate("RGB"):
                layers[f"{name}.{channel}"] = clean[..., k]
    if getattr(result, "has_light_groups", False):
        from .tracer import image
        values = result.light_group_images()
        for name in args.passes:
            if name in values:
                clean, _ = image.sanitize(values[name])
                for k, channel in enumerate("RGB"):
                    layers[f"{name}.{channel}"] = clean[..., k]
    from .tracer.data_passes import CHANNELS, data_passes
    wanted = args.passes
    data = [name for name in wanted if name in CHANNELS]
    if data:
        from .tracer.integrator import Renderer
        for name, values in data_passes(Renderer(scene, settings), data).items():
            for k, channel in enumerate(CHANNELS[name]):
                layers[f"{name}.{channel}"] = values[..., k]
    return layers


def _summary(args, rgb, result, bad_pixels, denoised=None) -> str:
    wall = result.time_s
    rays = f"{result.rays / wall / 1e6:.2f} Mrays/s" if wall > 0 else "? Mrays/s"
    # The same definition as the bench's: Embree query time over (wall time x threads).
    embree = f"Embree {100.0 * result.embree_share:.0f}% of thread time" if wall > 0 else "Embree ?"
    nans = f"{result.nan_count} NaN/Inf samples"
    if bad_pixels:
        nans += f", {bad_pixels} NaN/Inf pixels written as 0"
    written = args.output + (f" + {args.png}" if args.png else "")
    stages = getattr(result, "stages", None) or {}
    source = f" {stages['light tracing'][1]}" if stages.get("light tracing", (False,))[0] else ""
    budget = getattr(result, "light_budget", None)
    share = f"; {budget.ratio:.3g} per camera path, by the pilot" if budget is not None else ""
    light = (f", {result.light_paths} light paths{source} ({result.stats.get('caustic_splats', 0)} "
             f"reached the camera{share})" if result.light_paths else ", no light tracing")
    skipped = ""
    if getattr(result, "stages", None):
        from .tracer.integrator import describe_stages
        skipped = f"; skipped: {describe_stages(result.stages)[1]}"
    samples = describe_adaptive(result) or f"{result.spp} spp"
    if getattr(result, "time_limited", False):
        samples += " (time limit reached)"
    workers = getattr(result, "workers", 0)     # Dask workers (farm/); 0: this process
    on = f" on {_plural(workers, 'worker')}" if workers else ""
    if getattr(result, "has_features", False) and result.feature_nan_count:
        nans += f", {result.feature_nan_count} NaN/Inf denoising-pass samples left out"
    if getattr(result, "has_alpha", False) and result.alpha_nan_count:
        nans += f", {result.alpha_nan_count} NaN/Inf alpha samples left out"
    denoising = ""
    if denoised is not None:
        denoising = (f", denoised in {_duration(denoised.seconds)}" if denoised.denoised
                     else ", not denoised")
    compiled = getattr(result, "compile_s", 0.0)
    if compiled >= 0.05:
        on += f" (and {_duration(compiled)} compiling kernels first)"
    return (f"snell: {written}: {rgb.shape[1]}x{rgb.shape[0]}, {samples} in {_duration(wall)}{on} "
            f"({rays}, {embree}){light}{denoising}, {nans}{skipped}")


# ---------------------------------------------------------------------------------------------
# snell export


def _setup_export(p):
    p.add_argument("scene", metavar="SCENE.blend", help="the Blender file to export")
    p.add_argument("-o", "--output", required=True, metavar="FILE.snell",
                   help="scene file to write")


def cmd_export(args) -> int:
    if _extension(args.scene) != ".blend":
        raise CliError(f"{args.scene}: expected a .blend file")
    _check_output(args.output, ".snell", "-o")
    scene = load_scene(args.scene)
    save(scene, args.output)
    print(f"snell: {args.output}: {len(scene.triangles)} triangles, "
          f"{len(scene.materials)} materials, {len(scene.lights)} lights")
    return 0


# ---------------------------------------------------------------------------------------------
# snell info


def _setup_info(p):
    p.add_argument("scene", help="a .blend (exported on the fly) or a .snell scene file")


def _plural(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _counts(items, order) -> str:
    kinds = [item["kind"] for item in items]
    parts = [f"{kinds.count(k)} {k}" for k in order if k in kinds]
    return f"{len(items)}: {', '.join(parts)}" if items else "none"


def describe_world(scene) -> str:
    """The world as `snell info` shows it: its colour, or its environment map."""
    env = scene.world.get("environment")
    if env is None:
        return str(list(scene.world["color"]))
    image = scene.images[env["image"]]
    h, w = image["pixels"].shape[:2]
    return (f"environment {image['name']!r} ({w}x{h}, {env['interpolation']}), "
            f"strength {env['strength']:g}")


def describe_materials(scene) -> list[str]:
    """`snell info`'s lines under "materials": each material with what of its nodes Snell
    evaluates and what it replaces, with what (the exporter's coverage: known for a .blend)."""
    lines = []
    coverage = scene.coverage or [{"name": m.get("name", "?"), "kind": m["kind"]}
                                  for m in scene.materials]
    for entry in coverage:
        lines.append(f"  {entry['name']!r}: {entry['kind']}")
        lines += [f"    evaluated  {text}" for text in entry.get("evaluated", ())]
        lines += [f"    replaced   {text}" for text in entry.get("replaced", ())]
    if scene.materials and not scene.coverage:
        lines.append("  (what each material's nodes became is known when reading a .blend)")
    return lines


def describe(scene) -> list[str]:
    """The lines `snell info` prints."""
    from .tracer.integrator import Renderer, describe_stages

    settings = scene.settings(threads=1)
    stages = Renderer(scene, settings).stages()    # the stages a render of it would run
    run, skipped = describe_stages(stages)
    cam, dof = scene.camera, scene.camera["dof"]
    pct = cam.get("resolution_percentage", 100)
    width, height = (int(r * pct / 100) for r in cam["resolution"])
    resolution = f"{width}x{height}" + (f" ({pct}% of "
                                        f"{cam['resolution'][0]}x{cam['resolution'][1]})"
                                        if pct != 100 else "")
    radius = aperture_radius(cam)
    focus = (f"aperture radius {radius * 1000:.3g} mm, focus {dof['focus_distance']:.4g} m"
             if radius > 0 else "no depth of field")
    features = [name.replace("_", " ") for name, used in scene.features().items() if used]
    objects = f", {_plural(len(scene.objects), 'object')}" if scene.objects else ""
    return [
        f"source     {scene.source or '?'}",
        f"geometry   {_plural(len(scene.triangles), 'triangle')}{objects}",
        f"materials  {_counts(scene.materials, MATERIAL_KINDS)}",
        *describe_materials(scene),
        f"lights     {_counts(scene.lights, LIGHT_KINDS)}",
        f"world      {describe_world(scene)}",
        f"camera     {cam.get('name', '?')!r}: {resolution}, "
        + (f"orthographic, scale {cam['ortho_scale']:g} m" if cam.get("type") == "ORTHO" else
           f"lens {cam['lens']:g} mm") + ", "
        f"sensor {cam['sensor_width']:g}x{cam['sensor_height']:g} mm "
        f"{cam.get('sensor_fit', 'AUTO')}, {focus}",
        f"render     {settings.spp} spp, max depth {settings.max_depth}, seed {settings.seed}, "
        f"fresnel {settings.fresnel}, pixel filter {settings.pixel_filter.replace('_', '-')} "
        f"{settings.filter_width:g} px",
        f"paths      {light_paths(settings)}",
        f"sampling   {adaptive_sampling(settings)}"
        + (f", time limit {settings.time_limit:g} s" if settings.time_limit else ""),
        f"sources    {setting_sources(scene.render)}",
        *not_rendered_lines(scene.render),
        f"caustics   {light_tracing(stages)}",
        f"runs       {run}",
        f"skips      {skipped}",
        f"features   {', '.join(features) or 'none'}",
    ]


def light_paths(settings) -> str:
    """The bounce limits of each kind, the clamps and the caustics switches, as Cycles' Light
    Paths panel has them."""
    kinds = ", ".join(f"{name} {getattr(settings, name + '_bounces')}"
                      for name in ("diffuse", "glossy", "transmission"))
    clamps = ", ".join(f"{name} {value:g}" if value > 0 else f"{name} off"
                       for name, value in (("direct", settings.sample_clamp_direct),
                                           ("indirect", settings.sample_clamp_indirect)))
    caustics = ", ".join(f"{name} {'on' if on else 'off'}"
                         for name, on in (("reflective", settings.caustics_reflective),
                                          ("refractive", settings.caustics_refractive)))
    return (f"bounces {kinds}, transparent {settings.transparent_max_bounces}; "
            f"clamp {clamps}; caustics {caustics}")


def setting_sources(render: dict) -> str:
    """Where each saved render setting came from (the exporter's render["sources"]): the file's
    Cycles setting, a Snell override, a Snell setting or the default, grouped by source."""
    sources = render.get("sources")
    if not isinstance(sources, dict) or not sources:
        return "the scene file's render settings"
    groups = {}
    for name in render:
        if isinstance(sources.get(name), str):
            groups.setdefault(sources[name], []).append(name)
    return "; ".join(f"{source}: {', '.join(names)}" for source, names in groups.items())


def not_rendered_lines(render: dict) -> list[str]:
    """`cycles` lines for the Cycles settings Snell does not render (the exporter's
    render["cycles_not_rendered"]): one each where the image differs (a warning where the user
    set that), then those where only the noise differs, then those set as Snell renders."""
    entries = render.get("cycles_not_rendered")
    if not isinstance(entries, list):
        return []
    entries = [e for e in entries if isinstance(e, dict) and
               all(isinstance(e.get(k), str) for k in ("label", "value", "snell", "status"))]
    lines = [f"cycles     {'warning: ' if e.get('warn') else ''}{e['label']} {e['value']}: not "
             f"rendered ({e['snell']})" for e in entries if e["status"] == "differs"]
    for status, what in (("noise", "not rendered, the same image with other noise"),
                         ("same", "rendered as set")):
        names = [f"{e['label'].rsplit(' > ', 1)[-1]} {e['value']}" for e in entries
                 if e["status"] == status]
        if names:
            lines.append(f"cycles     {what}: {', '.join(names)}")
    return lines


def adaptive_sampling(settings) -> str:
    """What a render's noise_threshold and min_spp do, in words."""
    from .tracer.adaptive import auto_min_spp, first_check

    threshold, least, spp = settings.noise_threshold, settings.min_spp, settings.spp
    if threshold <= 0:
        return f"every pixel {spp} spp (noise threshold 0: adaptive sampling off)"
    # The tracer rounds the minimum up to whole windows of both halves (tracer/adaptive.py).
    effective = first_check(least or auto_min_spp(threshold))
    minimum = f"{effective} spp" + ("" if least else " (automatic)")
    if effective >= spp:
        return (f"every pixel {spp} spp (noise threshold {threshold:g}, but its minimum "
                f"{minimum} is not below that)")
    return f"adaptive, noise threshold {threshold:g}: each pixel from {minimum} up to {spp} spp"


def light_tracing(stages) -> str:
    """Whether a render runs the caustics light tracer, and why not, from Renderer.stages()."""
    runs, why = stages["light tracing"]
    if not runs:
        return f"path tracer only ({why})"
    return f"light tracing {why} through mirrors and glass, path tracing for the rest"


def cmd_info(args) -> int:
    print("\n".join(describe(load_scene(args.scene))))
    return 0


# ---------------------------------------------------------------------------------------------
# snell batch


def _setup_batch(p):
    p.add_argument("scene", metavar="SCENE.blend", help="the Blender file to render")
    p.add_argument("--frames", metavar="FRAMES", type=_frames,
                   help="frames to render: 1, 1-10, 1-10x2 or 1,5,9 (default: the current frame)")
    p.add_argument("-o", "--output", metavar="OUT_####.exr",
                   help="output path, #### = frame number; .exr (linear float) or .png (view "
                        "transform) (default: the file's Output Properties)")
    _add_setting_options(p)
    _add_scale_option(p)
    _add_farm_options(p)


def _frames(text):
    """--frames checked when the options are parsed (a usage error, status 2)."""
    from .addon.batch import BatchError, parse_frames
    try:
        parse_frames(text)
    except BatchError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix(f"--frames {text!r}: ")) from None
    return text


def cmd_batch(args) -> int:
    """Render frames through the registered Snell engine in the bpy module (addon/batch.py)."""
    check_input_file(args.scene)
    if args.output:
        check_writable_directory(args.output, "-o")
    try:
        from .addon import batch
        with _farm_opening(args) as remote_render:
            return batch.run(args.scene, frames=args.frames, output=args.output,
                             settings=setting_overrides(args), scale=args.scale,
                             remote_render=remote_render)
    except ModuleNotFoundError as exc:
        if exc.name != "bpy":
            raise
        raise CliError("snell batch needs Blender's bpy module "
                       "(pip install 'snell[blender]')") from None
    except batch.BatchError as exc:
        raise CliError(str(exc)) from None


@contextlib.contextmanager
def _farm_opening(args, quiet: bool = False):
    """With --workers or --cluster: the Dask session, opening in the background from now on
    (farm/render.py's opening: wait() for it), its local workers' kernels compiled first;
    otherwise None."""
    if args.workers is None and args.cluster is None:
        yield None
        return
    from .farm.render import opening
    if args.cluster is None:
        _compile_kernels(quiet)
    if _extension(args.scene) == ".blend":
        _import_blender()
    with opening(args.cluster, args.workers, quiet) as started:
        yield started


def _import_blender() -> None:
    """Import bpy now, before a thread opens the cluster: Blender's start inside bpy's import,
    beside that thread's imports of extension modules, hung the process (1 run in 5: both
    threads in create_module). Without bpy, the scene's load says so later."""
    try:
        import bpy  # noqa: F401
    except ModuleNotFoundError as exc:
        if exc.name != "bpy":
            raise


# ---------------------------------------------------------------------------------------------
# snell stress


def _setup_stress(p):
    p.add_argument("--report", metavar="DIR",
                   help="write DIR/stress.json and DIR/stress.html (created)")
    p.add_argument("--quick", action="store_true",
                   help="the CI subset (under 2 minutes on 2 cores)")
    p.add_argument("--threads", type=int_at_least(1), default=DEFAULT_THREADS,
                   help=f"render threads (default: the machine's {DEFAULT_THREADS} cores)")


def cmd_stress(args) -> int:
    """Render scenes with exact answers and judge each against its bound (stress/runner.py)."""
    if args.report:
        check_writable_directory(args.report, "--report", report=True)
    from .stress import runner
    log = (lambda s: print(f"snell stress: {s}", file=sys.stderr,
                           flush=True)) if sys.stderr.isatty() else None
    data = runner.run(quick=args.quick, threads=args.threads, log=log)
    print(runner.terminal_table(data))
    if args.report:
        runner.write_report(args.report, data)
    verdict = "all pass" if data["passed"] else f"FAILED: {', '.join(data['failed'])}"
    print(f"snell stress: {len(data['cases'])} cases in {_duration(data['total_s'])}, {verdict}"
          + (f" -> {os.path.join(args.report, 'stress.html')}" if args.report else ""))
    return 0 if data["passed"] else 1


# ---------------------------------------------------------------------------------------------

COMMANDS = [
    # (name, one-line help, add arguments, run)
    ("render", "render a scene to a linear EXR (and an sRGB PNG)", _setup_render, cmd_render),
    ("export", "export a .blend to a .snell scene file", _setup_export, cmd_export),
    ("info", "summarise a scene: geometry, materials, lights, camera, features",
     _setup_info, cmd_info),
    ("batch", "render frames of a .blend through the Snell engine, one image per frame",
     _setup_batch, cmd_batch),
    ("stress", "render scenes with exact answers; table, JSON and HTML; exit 1 if a case fails",
     _setup_stress, cmd_stress),
]
COMMANDS += VALIDATION_COMMANDS  # compare, study, false-alarms, bench (validation/commands.py)


class _Version(argparse.Action):
    """--version: asks git for the commit only when given (not on every command)."""

    def __call__(self, parser, namespace, values, option_string=None):
        from .tracer.provenance import blender_version, snell_commit, snell_version
        commit, blender = snell_commit(), blender_version()
        print(f"snell {snell_version()}" + (f" (commit {commit})" if commit else "")
              + (f", Blender {blender} (bpy)" if blender else ", no Blender (bpy) installed"))
        parser.exit(0)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="snell", description="Snell: an Embree path tracer for Blender scenes.")
    parser.add_argument("--version", action=_Version, nargs=0,
                        help="print Snell's version (and its git commit in a checkout) and exit")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    parser.commands = {}
    for name, help_text, setup, run in COMMANDS:
        p = parser.commands[name] = sub.add_parser(name, help=help_text, description=help_text)
        setup(p)
        p.set_defaults(run=run)
    return parser


def main(argv=None) -> int:
    _open_standard_descriptors()
    if not any(isinstance(finder, _BlenderStartsWhole) for finder in sys.meta_path):
        sys.meta_path.insert(0, _BlenderStartsWhole())
    try:
        args = build_parser().parse_args(argv)
        with fault_stacks(args.command, getattr(args, "report", None)):
            return args.run(args) or 0
    except KeyboardInterrupt:
        print("snell: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except (CliError, SceneError, OSError) as exc:
        print_error(exc)
        return EXIT_ERROR


def _open_standard_descriptors() -> None:
    """Open /dev/null on a closed stdin, stdout or stderr: the next file opened would otherwise
    take its number, and Blender's console lines (written to descriptor 1) or a crash's stacks
    (to 2) would go into that file, an image being written for one."""
    for fd in (0, 1, 2):
        try:
            os.fstat(fd)
        except OSError:
            null = os.open(os.devnull, os.O_RDWR)
            if null != fd:      # the lowest free number: fd itself when the lower ones are open
                os.dup2(null, fd)
                os.close(null)


class _BlenderStartsWhole(importlib.abc.MetaPathFinder):
    """Finds bpy with its loader under ctrl_c_held: Blender's start-up (the first `import bpy`,
    1-3 s) does not survive a KeyboardInterrupt raised in the Python it runs, and the process
    died of SIGSEGV (PyModule_GetDict(NULL) in BPy_init_modules; found by
    tools/stress_abort.py's Ctrl-C at a random moment). Held, the Ctrl-C ends the command
    once bpy is imported."""

    def find_spec(self, name, path, target=None):
        """bpy's spec as the path finder finds it, with a loader holding Ctrl-C."""
        if name != "bpy":
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is not None and spec.loader is not None:
            spec.loader = _CtrlCHeldLoader(spec.loader)
        return spec


class _CtrlCHeldLoader:
    """A module loader whose module creation and execution run under ctrl_c_held."""

    def __init__(self, loader):
        self.loader = loader

    def create_module(self, spec):
        with ctrl_c_held():
            return self.loader.create_module(spec)

    def exec_module(self, module):
        with ctrl_c_held():
            return self.loader.exec_module(module)

    def __getattr__(self, name):
        return getattr(self.loader, name)


if __name__ == "__main__":
    sys.exit(main())
