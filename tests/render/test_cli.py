"""The `snell` command line: errors as one line, `info`, `render` (real and with a stub integrator)."""
import importlib.util
import json
import os
import subprocess
import sys
import types

import numpy as np
import pytest

from snell import cli
from snell.tracer import image
from snell.tracer.scene import DEFAULT_RENDER, load, save
from support.builders import EMISSION, tiny_scene

HAVE_INTEGRATOR = importlib.util.find_spec("snell.tracer.integrator") is not None
@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "tiny.snell"
    save(tiny_scene(), str(path))
    return path


def run(*args, cwd=None, env=None):
    return subprocess.run([sys.executable, "-m", "snell.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=600, cwd=cwd, env=env)


def assert_one_line_error(proc, *fragments):
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("snell: error: "), proc.stderr
    assert "Traceback" not in proc.stderr
    for fragment in fragments:
        assert fragment in lines[0]


# ---------------------------------------------------------------------------------------------
# Errors


def test_missing_file(tmp_path):
    missing = tmp_path / "nope.snell"
    for command in (["info", missing], ["render", missing, "-o", tmp_path / "a.exr"]):
        assert_one_line_error(run(*command), "nope.snell", "no such file")
    assert os.listdir(tmp_path) == []


def test_garbage_scene_file(tmp_path):
    garbage = tmp_path / "garbage.snell"
    garbage.write_bytes(b"this is not a zip archive")
    assert_one_line_error(run("info", garbage), "garbage.snell")
    assert_one_line_error(run("render", garbage, "-o", tmp_path / "a.exr"), "garbage.snell")
    assert os.listdir(tmp_path) == ["garbage.snell"]


def test_unknown_extension(tmp_path):
    other = tmp_path / "scene.obj"
    other.write_text("v 0 0 0\n")
    assert_one_line_error(run("info", other), "scene.obj", "extension")


def test_scene_without_camera(tmp_path):
    scene = tiny_scene()
    header = dict(scene.header(), camera=None)
    path = tmp_path / "nocam.snell"
    with open(path, "wb") as f:
        np.savez(f, header=np.frombuffer(json.dumps(header).encode(), np.uint8),
                 positions=scene.positions, triangles=scene.triangles,
                 material_ids=scene.material_ids, object_ids=scene.object_ids)
    assert_one_line_error(run("info", path), "camera")


needs_bpy = pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="needs bpy")


@needs_bpy
def test_blend_errors(tmp_path):
    garbage = tmp_path / "garbage.blend"
    garbage.write_bytes(b"BLENDER? no")
    proc = run("info", garbage)
    assert_one_line_error(proc, "garbage.blend")
    assert proc.stdout == ""  # Blender's own status lines do not leak into stdout
    empty = tmp_path / "empty.blend"
    subprocess.run([sys.executable, "-c", "import bpy, sys; "
                    "bpy.ops.wm.read_factory_settings(use_empty=True); "
                    "bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])", str(empty)],
                   check=True, capture_output=True, timeout=300)
    proc = run("render", empty, "-o", tmp_path / "a.exr")
    assert_one_line_error(proc, "no camera")
    assert proc.stdout == ""
    assert not (tmp_path / "a.exr").exists()


def test_bad_outputs_fail_before_rendering(scene_file, tmp_path):
    assert_one_line_error(run("render", scene_file, "-o", tmp_path / "a.png"), ".exr")
    assert_one_line_error(run("render", scene_file, "-o", tmp_path / "a.exr", "--png", tmp_path / "a.jpg"), ".png")
    assert_one_line_error(run("render", scene_file, "-o", tmp_path / "no" / "a.exr"), "does not exist")
    assert_one_line_error(run("export", scene_file, "-o", tmp_path / "b.snell"), ".blend")
    assert sorted(os.listdir(tmp_path)) == ["tiny.snell"]


@pytest.mark.parametrize("option, value, fragment", [
    ("--noise-threshold", "-0.1", "expected a number >= 0"),
    ("--noise-threshold", "nan", "expected a number >= 0"),
    ("--noise-threshold", "low", "expected a number >= 0"),
    ("--min-spp", "-1", "expected an integer >= 0"),
    ("--min-spp", "2.5", "expected an integer >= 0"),
])
@pytest.mark.parametrize("command", ["render", "batch"])
def test_bad_adaptive_options_are_usage_errors(scene_file, tmp_path, command, option, value, fragment):
    args = ["-o", tmp_path / "a.exr"] if command == "render" else []
    proc = run(command, scene_file, *args, option, value)
    assert proc.returncode == 2
    assert_one_line_error(proc, option, fragment, repr(value))


@pytest.mark.parametrize("command", ["render", "batch", "info", "export", "compare", "stress"])
def test_usage_errors_point_to_the_subcommands_help(command):
    proc = run(command, "--no-such-option")
    assert proc.returncode == 2
    assert_one_line_error(proc, f"(see snell {command} --help)")


def test_version(monkeypatch):
    proc = run("--version")
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    from snell.tracer.provenance import snell_commit, snell_version
    assert proc.stdout.startswith(f"snell {snell_version()}")
    commit = snell_commit()     # this checkout's, from git
    assert (f"(commit {commit.removesuffix('+dirty')}" in proc.stdout) if commit else "commit" not in proc.stdout
    assert "Blender 5." in proc.stdout


@pytest.mark.parametrize("option, value", [("--scale", "0"), ("--scale", "half")])
@pytest.mark.parametrize("command", ["render", "batch"])
def test_bad_scale_is_a_usage_error(scene_file, tmp_path, command, option, value):
    args = ["-o", tmp_path / "a.exr"] if command == "render" else []
    proc = run(command, scene_file, *args, option, value)
    assert proc.returncode == 2
    assert_one_line_error(proc, option, repr(value))


def test_usage_errors_are_one_line_too(scene_file, tmp_path):
    proc = run("render", scene_file, "-o", tmp_path / "a.exr", "--spp", "0")
    assert proc.returncode == 2
    assert_one_line_error(proc, "--spp")
    assert_one_line_error(run("render", scene_file, "-o", tmp_path / "a.exr", "--fresnel", "fast"), "--fresnel")
    assert_one_line_error(run(), "required")
    assert_one_line_error(run("frobnicate"), "frobnicate")


# ---------------------------------------------------------------------------------------------
# info


def test_info(scene_file):
    proc = run("info", scene_file)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert "2 triangles" in out
    assert "materials  1: 1 emission" in out
    assert "lights     none" in out
    assert "8x8" in out and "lens 50 mm" in out and "no depth of field" in out
    assert "features   emissive meshes" in out
    # 4 spp: the automatic minimum at the default threshold, 64, leaves nothing to adapt
    assert ("sampling   every pixel 4 spp (noise threshold 0.01, but its minimum 64 spp "
            "(automatic) is not below that)") in out
    assert proc.stderr == ""


def test_info_lists_materials_of_a_scene_file(scene_file):
    out = cli.describe(cli.load_scene(str(scene_file)))
    at = out.index("materials  1: 1 emission")
    assert out[at + 1:at + 3] == [
        "  'Lamp': emission",
        "  (what each material's nodes became is known when reading a .blend)"]


COVERAGE_BLEND = """
import bpy, sys
bpy.ops.wm.read_factory_settings(use_empty=True)
glass = bpy.data.materials.new("Coffee")
tree = glass.node_tree
tree.nodes.remove(tree.nodes["Principled BSDF"])
bsdf = tree.nodes.new("ShaderNodeBsdfGlass")
out = tree.nodes["Material Output"]
tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
tree.links.new(tree.nodes.new("ShaderNodeVolumeScatter").outputs[0], out.inputs["Volume"])
rough = bpy.data.materials.new("Rough")
noise = rough.node_tree.nodes.new("ShaderNodeTexNoise")
rough.node_tree.links.new(noise.outputs[0], rough.node_tree.nodes["Principled BSDF"].inputs["Roughness"])
for x, mat in ((0, glass), (3, rough), (6, None)):
    bpy.ops.mesh.primitive_cube_add(location=(x, 0, 0))
    if mat:
        bpy.context.active_object.data.materials.append(mat)
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
bpy.context.scene.collection.objects.link(cam)
cam.location = (3, -20, 0)
cam.rotation_euler = (1.5708, 0, 0)
bpy.context.scene.camera = cam
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[1])
"""


@needs_bpy
def test_info_lists_each_materials_coverage(tmp_path):
    """Each material: what of its nodes is evaluated, and what is replaced with what."""
    blend = tmp_path / "coverage.blend"
    subprocess.run([sys.executable, "-c", COVERAGE_BLEND, str(blend)], check=True,
                   capture_output=True)
    proc = run("info", blend)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    at = lines.index("materials  3: 1 glass, 1 principled, 1 program")
    assert lines[at + 1:at + 10] == [
        "  'Coffee': glass",
        "    evaluated  node 'Glass BSDF': glass surface",
        "    replaced   node 'Volume Scatter': scatters light: rendered without its scattering "
        "(homogeneous scattering is not rendered yet)",
        "  'Rough': program",
        "    evaluated  node 'Noise Texture': compiled into the material's shader program",
        "    evaluated  node 'Principled BSDF': compiled into the material's shader program",
        "  '(default surface)': principled",
        "    evaluated  Cycles' default surface: a Principled BSDF of base colour 0.8",
        "    replaced   no material: rendered with Cycles' default surface (a Principled BSDF "
        "of base colour 0.8), as Cycles renders it"]
    assert lines[at + 10].startswith("lights ")
    # The replaced entries are the exporter's warnings, one each.
    assert proc.stderr.count("snell: warning: ") == 2


@pytest.mark.parametrize("render, line", [
    ({"spp": 1024}, "adaptive, noise threshold 0.01: each pixel from 64 spp (automatic) up to 1024 spp"),
    # The tracer's minimum: whole windows of 16, at least one of each half.
    ({"spp": 1024, "noise_threshold": 0.1, "min_spp": 8},
     "adaptive, noise threshold 0.1: each pixel from 32 spp up to 1024 spp"),
    ({"spp": 1024, "noise_threshold": 0.03},
     "adaptive, noise threshold 0.03: each pixel from 48 spp (automatic) up to 1024 spp"),
    ({"spp": 1024, "noise_threshold": 0.0}, "every pixel 1024 spp (noise threshold 0: adaptive sampling off)"),
])
def test_info_states_adaptive_sampling(render, line):
    out = {text.split()[0]: text for text in cli.describe(tiny_scene(**render))}
    assert out["sampling"] == f"sampling   {line}"


def test_info_reports_depth_of_field(tmp_path):
    path = tmp_path / "dof.snell"
    save(tiny_scene().with_camera(dof={"use_dof": True, "focus_distance": 2.0, "fstop": 2.5}), str(path))
    out = cli.describe(cli.load_scene(str(path)))
    camera = next(line for line in out if line.startswith("camera"))
    assert "aperture radius 10 mm" in camera and "focus 2 m" in camera  # 50 mm / (2 * 2.5)
    assert "depth of field" in out[-1]


# ---------------------------------------------------------------------------------------------
# render with a stub integrator: the CLI's own behaviour, independent of the tracer


class StubResult:
    def __init__(self, scene, settings, cancelled=False):
        w, h = scene.camera["resolution"]
        self.image = np.zeros((h, w, 3), np.float32)
        self.image[0] = 1.0
        self.image[-1, -1] = np.nan
        self.spp, self.nan_count, self.rays = settings.spp, 3, 1000
        self.time_s, self.embree_time_s, self.cancelled = 0.5, 0.25, cancelled
        self.threads = 2
        self.embree_share = self.embree_time_s / (self.time_s * self.threads)
        self.light_paths, self.stats = 0, {}
        self.spp_budget, self.sample_count = self.spp, None

    def mean(self):
        return self.image

    def samples(self):
        return np.full(self.image.shape[:2], self.spp, np.int32)

    def exr_channels(self):
        return {"samples": self.samples()}


@pytest.fixture
def stub_integrator(monkeypatch):
    calls = []
    module = types.ModuleType("snell.tracer.integrator")

    def render(scene, settings, progress=None):
        calls.append({"scene": scene, "settings": settings})
        if module.behaviour == "interrupt":
            raise KeyboardInterrupt
        result = StubResult(scene, settings, cancelled=module.behaviour == "cancel")
        if progress:
            progress(result, 1, 1)
        return result

    module.render, module.behaviour, module.calls = render, "ok", calls
    module.kernels_compiled, module.warm_up = (lambda: True), (lambda: 0.0)
    monkeypatch.setitem(sys.modules, "snell.tracer.integrator", module)
    return module


def test_render_options_reach_the_integrator(scene_file, tmp_path, stub_integrator, capsys):
    out, png = tmp_path / "a.exr", tmp_path / "a.png"
    code = cli.main(["render", str(scene_file), "-o", str(out), "--png", str(png), "--spp", "9",
                     "--max-depth", "0", "--seed", "5", "--fresnel", "schlick", "--threads", "3",
                     "--noise-threshold", "0.05", "--min-spp", "3", "--light-vertices", "off",
                     "--denoising-passes", "--denoising-prefilter", "fast",
                     "--transparent-max-bounces", "4", "--film-exposure", "2",
                     "--film-transparent", "--diffuse-bounces", "2", "--glossy-bounces", "3",
                     "--transmission-bounces", "5", "--sample-clamp-direct", "1.5",
                     "--sample-clamp-indirect", "10", "--caustics-refractive", "off"])
    assert code == 0
    settings = stub_integrator.calls[0]["settings"]
    assert settings.threads == 3
    assert settings.to_render() == {"spp": 9, "max_depth": 0, "transparent_max_bounces": 4,
                                    "diffuse_bounces": 2, "glossy_bounces": 3,
                                    "transmission_bounces": 5, "caustics_reflective": True,
                                    "caustics_refractive": False, "sample_clamp_direct": 1.5,
                                    "sample_clamp_indirect": 10.0,
                                    "seed": 5, "fresnel": "schlick",
                                    "caustics": True, "shadow_caustics": True,
                                    "light_vertices": False,
                                    "noise_threshold": 0.05, "min_spp": 3, "time_limit": 0.0,
                                    "pixel_filter": "box", "filter_width": 1.0,
                                    "film_exposure": 2.0, "film_transparent": True,
                                    "film_transparent_glass": False,
                                    "film_transparent_roughness": 0.1,
                                    "denoise": False, "denoising_input_passes": "albedo_normal",
                                    "denoising_prefilter": "fast", "denoising_quality": "high",
                                    "denoising_passes": True}   # a bare on/off option is on
    rgb = image.read_exr(out)
    assert rgb[0].min() == 1.0 and rgb[1:].max() == 0.0  # top row first, NaN written as 0
    assert np.all(image.read_channel(out, "samples") == 9)
    summary = capsys.readouterr().out.strip().splitlines()
    assert len(summary) == 1
    assert "8x8" in summary[0] and "9 spp" in summary[0] and "0.00 Mrays/s" in summary[0]
    assert "Embree 25% of thread time" in summary[0] and "3 NaN/Inf samples" in summary[0] and "1 NaN/Inf pixels" in summary[0]


def test_render_defaults_come_from_the_scene(scene_file, tmp_path, stub_integrator, capsys):
    assert cli.main(["render", str(scene_file), "-o", str(tmp_path / "a.exr"), "--quiet"]) == 0
    # what the file holds, and the defaults of what it does not (caustics)
    settings = stub_integrator.calls[0]["settings"]
    assert settings.to_render() == {**DEFAULT_RENDER, **tiny_scene().render}
    assert settings.render_threads == (os.cpu_count() or 1)  # every core, as Cycles' auto-detect
    assert capsys.readouterr() == ("", "")


def test_render_scale_sets_the_resolution_percentage(scene_file, tmp_path, stub_integrator):
    out = tmp_path / "a.exr"
    assert cli.main(["render", str(scene_file), "-o", str(out), "--scale", "50", "--quiet"]) == 0
    scene = stub_integrator.calls[0]["scene"]
    assert scene.camera["resolution_percentage"] == 50
    # the scene's own otherwise
    assert cli.main(["render", str(scene_file), "-o", str(out), "--quiet"]) == 0
    assert stub_integrator.calls[1]["scene"].camera.get("resolution_percentage", 100) == 100


@pytest.mark.parametrize("behaviour", ["interrupt", "cancel"])
def test_interrupted_render_writes_nothing(scene_file, tmp_path, stub_integrator, capsys, behaviour):
    stub_integrator.behaviour = behaviour
    code = cli.main(["render", str(scene_file), "-o", str(tmp_path / "a.exr"),
                     "--png", str(tmp_path / "a.png")])
    assert code == 130
    assert sorted(os.listdir(tmp_path)) == ["tiny.snell"]
    assert capsys.readouterr().err.strip() == "snell: interrupted"


def progress_state(spp, budget=16, counts=None, active=1.0):
    """What ProgressLine reads of a RenderResult while it renders."""
    return types.SimpleNamespace(spp=spp, spp_budget=budget, sample_count=counts, active_share=active)


def test_progress_line():
    import io
    stream = io.StringIO()
    bar = cli.ProgressLine(stream)
    assert bar(progress_state(4), 1, 4) is True
    bar(progress_state(8), 2, 4)
    bar.close()
    text = stream.getvalue()
    assert text.count("\n") == 1 and text.endswith("\n")
    assert text.split("\r")[-1].startswith("snell: 8/16 spp, elapsed ") and "ETA" in text


def test_progress_line_of_adaptive_sampling():
    """Samples over the budget and the share of pixels still sampling, never passes (with
    adaptive sampling their count is a guess); the ETA assumes the sampling pixels run on."""
    from snell.tracer.progress import time_left
    import io
    stream = io.StringIO()
    counts = np.array([[128, 128], [64, 64]], np.int32)
    cli.ProgressLine(stream)(progress_state(128, 1024, counts, 0.5), 3, 17)
    assert "snell: 128/1024 spp, 50% of pixels sampling, elapsed" in stream.getvalue()
    assert "pass" not in stream.getvalue()
    # 96 samples a pixel took 10 s; half the pixels have 896 left: 896 / 2 / 96 x 10 s
    assert time_left(progress_state(128, 1024, counts, 0.5), 10.0) == pytest.approx(896 / 2 / 96 * 10)


# ---------------------------------------------------------------------------------------------
# render through the real integrator


def edge_scene(spp=256):
    """tiny_scene at 16x16 with the quad's lower edge slanted across pixel rows: only pixels near
    the edge are noisy (partly covered), the rest converge at the minimum."""
    scene = tiny_scene(spp=spp).with_camera(resolution=[16, 16])
    scene.positions = np.array([[-2, 0.1, -2], [2, 0.5, -2], [2, 2, -2], [-2, 2, -2]], np.float32)
    return scene


def test_render_samples_adaptively_and_writes_the_counts(tmp_path):
    """--noise-threshold and --min-spp end to end: the EXR's "samples" channel is the tracer's own
    counts (the same with 1 and 2 threads), at least the minimum, more at the edge; the summary
    says what was saved; --noise-threshold 0 samples every pixel --spp times."""
    from snell.tracer import integrator
    if not integrator.kernels_compiled():
        integrator.warm_up()
    path, out = tmp_path / "edge.snell", tmp_path / "edge.exr"
    save(edge_scene(), str(path))
    proc = run("render", path, "-o", out, "--noise-threshold", "0.01", "--min-spp", "16",
               "--threads", "1")
    assert proc.returncode == 0, proc.stderr
    counts = image.read_channel(out, "samples")
    scene = load(str(path))
    result = integrator.Renderer(scene, scene.settings(noise_threshold=0.01, min_spp=16)).render()
    assert np.array_equal(counts, result.samples())
    # The minimum rounded up to a window of each half: 32.
    assert counts.min() == 32 and counts.max() > 32 and result.saved_share > 0.5
    assert (f"adaptive 0.01: {counts.mean():.0f} spp mean, {counts.max():.0f} max, "
            f"{100 * result.saved_share:.0f}% of samples saved in ") in proc.stdout
    assert image.read_exr(out).shape == (16, 16, 3)

    proc = run("render", path, "-o", out, "--noise-threshold", "0", "--threads", "1")
    assert proc.returncode == 0, proc.stderr
    assert np.all(image.read_channel(out, "samples") == 256)
    assert "16x16, 256 spp in " in proc.stdout and "spp mean" not in proc.stdout


@pytest.mark.skipif(not HAVE_INTEGRATOR, reason="snell.tracer.integrator has not landed yet")
def test_render_tiny_scene(scene_file, tmp_path):
    from snell.tracer import integrator
    if not integrator.kernels_compiled():
        integrator.warm_up()             # else the render says it compiles them, on stderr
    out, png = tmp_path / "tiny.exr", tmp_path / "tiny.png"
    proc = run("render", scene_file, "-o", out, "--png", png, "--spp", "4", "--threads", "1")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""  # not a terminal: no progress bar
    summary = proc.stdout.strip().splitlines()
    assert len(summary) == 1 and "4 spp" in summary[0] and "Mrays/s" in summary[0]
    rgb = image.read_exr(out)
    assert rgb.shape == (8, 8, 3)
    # The quad fills the top half: the emitter is seen directly, the bottom sees the black world.
    assert np.allclose(rgb[:3], EMISSION, rtol=1e-4)
    assert np.all(rgb[5:] == 0.0)
    srgb = image.to_srgb8(rgb)
    import OpenImageIO as oiio
    written = oiio.ImageInput.open(str(png))
    try:
        pixels = written.read_image("uint8")
    finally:
        written.close()
    assert np.array_equal(pixels, srgb) and pixels[0, 0, 0] == 255 and pixels[-1, 0, 0] == 0


# A whole cold compile (2-3 minutes on 2 cores): on demand, so the default run stays under 20
# minutes (the extension test compiles cold too, inside Blender).
@pytest.mark.slow
def test_first_render_says_it_compiles_the_kernels(scene_file, tmp_path):
    """An empty kernel cache: the first render says it compiles (once), the next one does not."""
    env = dict(os.environ, SNELL_KERNEL_CACHE=str(tmp_path / "kernels"))
    out = tmp_path / "tiny.exr"
    first = run("render", scene_file, "-o", out, "--threads", "1", env=env)
    assert first.returncode == 0, first.stderr
    assert first.stderr == "snell: compiling kernels (first run only)\n"
    second = run("render", scene_file, "-o", out, "--threads", "1", env=env)
    assert second.returncode == 0 and second.stderr == ""
    assert os.listdir(tmp_path / "kernels")


@pytest.mark.skipif(not HAVE_INTEGRATOR, reason="snell.tracer.integrator has not landed yet")
@pytest.mark.skipif(os.name != "posix", reason="sends SIGINT")
def test_ctrl_c_during_a_real_render(scene_file, tmp_path):
    import signal
    import time
    proc = subprocess.Popen(
        [sys.executable, "-m", "snell.cli", "render", str(scene_file), "-o", str(tmp_path / "a.exr"),
         "--png", str(tmp_path / "a.png"), "--spp", "2000000",
         # every pixel all the samples: adaptive sampling would stop this flat image at 64
         "--noise-threshold", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        # A background job may inherit SIGINT ignored: restore Python's usual handler.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(2.0)  # imports done, rendering (the render itself would take about a minute)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert err == "snell: interrupted\n" and out == ""
    assert sorted(os.listdir(tmp_path)) == ["tiny.snell"]


def test_every_help_page_prints(capsys):
    """`snell --help` and each command's --help print and exit 0 (a bare % in a help text made
    argparse raise TypeError on the top-level page)."""
    names = [name for name, *_ in cli.COMMANDS]
    for argv in [["--help"]] + [[name, "--help"] for name in names]:
        with pytest.raises(SystemExit) as done:
            cli.build_parser().parse_args(argv)
        assert done.value.code == 0, argv
        assert "usage: snell" in capsys.readouterr().out
