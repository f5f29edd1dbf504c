"""Bad and unusual inputs through every command: one clear line, the right status, nothing partial.

Each case runs `snell COMMAND ...` as a child process, as a user would, on one input of the
corpus (truncated and corrupted files, wrong dtypes and shapes, NaN and Inf, a file that is not a
.blend, an empty scene, no camera, an orthographic camera (rendered) and a panoramic one, unsupported nodes,
Blender's startup file, outputs that cannot be written) or with Ctrl-C at one stage, and checks:
- the exit status (0 for inputs Snell renders, 1 for errors, 2 for bad options, 130 for Ctrl-C);
- errors: exactly one `snell: error: ...` line, the last on stderr, naming the file, object or
  field (the case's fragments); no traceback anywhere;
- nothing partial: after a failure or Ctrl-C the output directory is empty (no image, report,
  scene file or temporary left).
The inputs are built once per module; images are 16x12. The table of every case (input,
command, message, status) is written to corpus_table.md in pytest's base temporary directory
and, with SNELL_CORPUS_TABLE=PATH, to PATH.

A command is one entry of COMMANDS: how to name its output for an input. `snell stress` reads no
input: it is held to the rules through its report path and options (OUTPUT_CASES).
"""
from __future__ import annotations

import importlib.util
import json
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from snell.tracer.scene import image_hash, save

from support.builders import tiny_scene

pytestmark = pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="needs bpy")

from support.paths import SUPPORT as HERE  # noqa: E402
FAST = ["--spp", "2", "--cycles-seeds", "2", "--quiet"]  # compare and study at their cheapest

# command -> argv after `snell COMMAND`, from the input and the output directory
COMMANDS = {
    "render": lambda src, out: ["render", src, "-o", os.path.join(out, "a.exr"), "--spp", "2"],
    "export": lambda src, out: ["export", src, "-o", os.path.join(out, "a.snell")],
    "info": lambda src, out: ["info", src],
    "compare": lambda src, out: ["compare", src, "--report", os.path.join(out, "report"), *FAST],
    "study": lambda src, out: ["study", "depth", src, "--report", os.path.join(out, "report"), *FAST],
    "bench": lambda src, out: ["bench", src, "--report", os.path.join(out, "report"), "--quick",
                               "--max-spp", "4", "--ref-spp", "2", "--ref-seeds", "2", "--quiet",
                               "--cache", os.path.join(os.path.dirname(out), "bench-cache")],
    "batch": lambda src, out: ["batch", src, "-o", os.path.join(out, "f_####.exr")],
}


ALL = tuple(COMMANDS)
BLEND_COMMANDS = ALL   # every command takes a .blend


# ---------------------------------------------------------------------------------------------
# The corpus


def _raw_snell(path, header=None, **arrays):
    """A .snell file written without validation (save() would refuse these)."""
    scene = tiny_scene()
    base = {"positions": scene.positions, "triangles": scene.triangles,
            "material_ids": scene.material_ids, "object_ids": scene.object_ids}
    base.update(arrays)
    blob = header if isinstance(header, bytes) else json.dumps(
        scene.header() if header is None else header).encode()
    with open(path, "wb") as f:
        np.savez(f, header=np.frombuffer(blob, np.uint8), **{k: v for k, v in base.items() if v is not None})


def _header(**changes):
    header = tiny_scene().header()
    for dotted, value in changes.items():
        node = header
        *parents, last = dotted.split("__")
        for key in parents:
            node = node[key]
        node[last] = value
    return header


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    """{input name: path}; every input built once."""
    d = tmp_path_factory.mktemp("corpus")
    subprocess.run([sys.executable, os.path.join(HERE, "corpus_blends.py"), str(d)], check=True,
                   capture_output=True, timeout=300)
    startup = (d / "startup.blend").read_bytes()
    (d / "truncated.blend").write_bytes(startup[:len(startup) // 2])
    corrupted = bytearray(startup)
    corrupted[len(corrupted) // 3:len(corrupted) // 3 + 4096] = b"\xff" * 4096
    (d / "corrupted.blend").write_bytes(bytes(corrupted))
    (d / "text.blend").write_text("this is a text file, not a .blend\n")
    (d / "zero_bytes.blend").write_bytes(b"")
    (d / "directory.blend").mkdir()
    save(tiny_scene(), str(d / "tiny.snell"))
    (d / "snell_renamed.blend").write_bytes((d / "tiny.snell").read_bytes())
    valid = (d / "tiny.snell").read_bytes()
    (d / "truncated.snell").write_bytes(valid[:len(valid) * 2 // 3])
    flipped = bytearray(valid)
    flipped[len(flipped) // 2:len(flipped) // 2 + 64] = b"\x00" * 64
    (d / "corrupted.snell").write_bytes(bytes(flipped))
    (d / "text.snell").write_text("not a zip archive\n")
    (d / "zero_bytes.snell").write_bytes(b"")
    (d / "scene.obj").write_text("v 0 0 0\n")
    scene = tiny_scene()
    nan_positions = scene.positions.copy()
    nan_positions[2, 1] = np.nan
    _raw_snell(d / "nan_positions.snell", positions=nan_positions)
    _raw_snell(d / "inf_camera_matrix.snell",
               header=_header(camera__matrix=[[float("inf")] * 4] * 4))
    _raw_snell(d / "float64_positions.snell", positions=scene.positions.astype(np.float64))
    _raw_snell(d / "triangles_4_columns.snell", triangles=np.zeros((2, 4), np.int32))
    _raw_snell(d / "broken_json.snell", header=b'{"format": "snell-scene", "version": 2,')
    _raw_snell(d / "header_not_object.snell", header=b"[1, 2, 3]")
    _raw_snell(d / "missing_triangles.snell", triangles=None)
    _raw_snell(d / "version_99.snell", header=_header(version=99))
    _raw_snell(d / "nan_spp.snell", header=_header(render__spp=float("nan")))
    _raw_snell(d / "huge_resolution.snell", header=_header(camera__resolution=[10 ** 6, 10 ** 6]))
    _raw_snell(d / "negative_material_id.snell", material_ids=np.array([0, -1], np.int32))
    _raw_snell(d / "unknown_material_kind.snell",
               header=_header(materials=[{"name": "Velvet", "kind": "velvet", "color": [1, 1, 1]}]))
    _raw_snell(d / "pickled_positions.snell", positions=np.array([object()] * 3, dtype=object))
    # Round two (issue 31): singular cameras, versions that only compare equal, headers that
    # disagree with their arrays, byte order, ranges, and inputs that are not regular files.
    _raw_snell(d / "zero_camera_matrix.snell", header=_header(camera__matrix=[[0.0] * 4] * 4))
    _raw_snell(d / "camera_scale_zero.snell",
               header=_header(camera__matrix=np.diag([1.0, 0.0, 1.0, 1.0]).tolist()))
    _raw_snell(d / "version_true.snell", header=_header(version=True))
    _raw_snell(d / "version_float.snell", header=_header(version=4.0))
    _raw_snell(d / "objects_empty.snell", header=_header(objects=[]))
    _raw_snell(d / "clip_reversed.snell", header=_header(camera__clip_start=200.0))
    _raw_snell(d / "big_endian.snell", positions=scene.positions.astype(">f4"))
    _raw_snell(d / "area_negative.snell", header=_header(lights=[{
        "name": "Area", "kind": "area", "shape": "rectangle", "matrix": np.eye(4).tolist(),
        "size": [-1.0, 1.0], "radiance": [1.0, 1.0, 1.0]}]))
    huge = scene.positions.copy()
    huge[0, 0] = 1e30
    _raw_snell(d / "huge_vertex.snell", positions=huge)
    _raw_snell(d / "huge_percentage.snell", header=_header(camera__resolution=[65536, 8],
                                                           camera__resolution_percentage=200))
    pixels = np.ones((4, 4, 3), np.float32)
    _raw_snell(d / "image_shape_mismatch.snell", image_0=pixels, header=_header(images=[{
        "name": "Tex", "source": "", "colorspace": "linear", "shape": [2, 8, 3],
        "sha256": image_hash(pixels)}]))
    os.mkfifo(d / "fifo.snell")
    os.symlink("/dev/null", d / "device_link.snell")
    empty = tiny_scene()
    empty.positions = np.zeros((0, 3), np.float32)
    empty.triangles = np.zeros((0, 3), np.int32)
    empty.material_ids = empty.object_ids = np.zeros(0, np.int32)
    empty.materials, empty.objects = [], []
    save(empty, str(d / "empty.snell"))
    p = {name[:-6] if name.endswith(".blend") else name.replace(".", "_"): str(d / name)
         for name in os.listdir(d)}
    p["missing"] = str(d / "missing.blend")
    return p


# (input, commands, expected status, fragments of the error line besides the input's file name)
# An input's file name is always required in the error line, except where None is given.
CASES = [
    ("startup", ("info", "export"), 0, ()),
    # 384x216 pixels: past 256x256, where the Welch test's dof once overflowed (object dtype)
    ("startup", ("compare",), 0, ()),
    ("empty_scene", ("render", "export", "info"), 0, ()),
    ("unsupported_nodes", ("render",), 0, ()),
    ("zero_scale", ("render",), 0, ()),
    ("tiny_snell", ("render", "info"), 0, ()),
    ("empty_snell", ("render", "info"), 0, ()),
    ("no_camera", BLEND_COMMANDS, 1, ("no camera",)),
    ("camera_ortho", ("render", "info"), 0, ()),
    ("camera_pano", ("render", "info", "compare", "batch", "bench"), 1, ("camera 'Camera'", "PANO")),
    ("nan_object", ("render", "export", "batch"), 1, ("object 'Cube'", "NaN")),
    ("nan_camera", ("render", "info"), 1, ("camera 'Camera'", "NaN")),
    ("nan_material", ("render", "export", "study"), 1,
     ("material 'Material': node 'Principled BSDF': input 'Base Color' is [nan, 0.5, 0.5]",)),
    ("inf_light", ("render", "info"), 1, ("light 'Light': Power is inf (not a finite number)",)),
    ("truncated", BLEND_COMMANDS, 1, ("cannot open",)),
    ("corrupted", ("info", "compare", "batch"), 1, ("cannot open",)),
    ("text", BLEND_COMMANDS, 1, ("cannot open",)),
    ("zero_bytes", ("info", "bench"), 1, ("cannot open",)),
    ("snell_renamed", ("info", "export"), 1, ("cannot open",)),
    ("directory", ("info", "render", "compare", "batch"), 1, ("is a directory",)),
    ("missing", BLEND_COMMANDS, 1, ("no such file",)),
    ("scene_obj", ("render", "info", "compare", "export"), 1, ("expected",)),
    ("tiny_snell", ("export", "compare", "batch"), 1, ("expected a .blend",)),
    ("truncated_snell", ("render", "info"), 1, ("not a Snell scene file",)),
    ("corrupted_snell", ("info",), 1, ("positions: cannot read the array", "CRC")),
    ("text_snell", ("render", "info"), 1, ("not a Snell scene file (not an .npz archive)",)),
    ("zero_bytes_snell", ("info",), 1, ("not a Snell scene file (an empty file)",)),
    ("nan_positions_snell", ("render", "info"), 1, ("positions: vertex 2", "NaN")),
    ("inf_camera_matrix_snell", ("render",), 1, ("camera.matrix", "NaN or Inf")),
    ("float64_positions_snell", ("info",), 1, ("positions: expected dtype float32",)),
    ("triangles_4_columns_snell", ("info",), 1, ("triangles: expected shape (n, 3)",)),
    ("broken_json_snell", ("info",), 1, ("header: not valid JSON",)),
    ("header_not_object_snell", ("info",), 1, ("header: expected a JSON object",)),
    ("missing_triangles_snell", ("info",), 1, ("triangles: missing array",)),
    ("version_99_snell", ("info",), 1, ("header.version", "99")),
    ("nan_spp_snell", ("render",), 1, ("render.spp",)),
    ("huge_resolution_snell", ("render",), 1, ("camera.resolution",)),
    ("negative_material_id_snell", ("render",), 1, ("material_ids",)),
    ("unknown_material_kind_snell", ("info",), 1, ("materials[0] ('Velvet').kind", "velvet")),
    ("pickled_positions_snell", ("info",), 1, ("positions: cannot read",)),
    # Round two (issue 31)
    ("camera_is_mesh", ("render", "info", "batch"), 1, ("camera 'Cube' is a mesh object",)),
    ("camera_zero_scale", ("render", "info"), 1, ("camera 'Camera'", "scale is zero")),
    ("clip_reversed", ("render", "export"), 1, ("camera 'Camera'", "Clip Start 50")),
    ("world_nan_strength", ("render", "export"), 1, ("world 'World'", "Strength")),
    ("world_huge", ("render",), 0, ()),           # Inf pixels: written 0 and counted, no warning
    ("zero_camera_matrix_snell", ("render", "info"), 1, ("camera.matrix", "singular")),
    ("camera_scale_zero_snell", ("render",), 1, ("camera.matrix", "singular")),
    ("version_true_snell", ("info",), 1, ("header.version", "True")),
    ("version_float_snell", ("info",), 1, ("header.version", "4.0")),
    ("objects_empty_snell", ("render", "info"), 1, ("object_ids", "objects lists 0")),
    ("clip_reversed_snell", ("render", "info"), 1, ("camera.clip_end", "clip_start")),
    ("big_endian_snell", ("info",), 1, ("positions", "got big-endian float32")),
    ("area_negative_snell", ("info",), 1, ("lights[0] ('Area').size", "negative")),
    ("huge_vertex_snell", ("render",), 1, ("positions: vertex 0 (object 'Quad')", "out of range")),
    ("huge_percentage_snell", ("info",), 1, ("camera.resolution_percentage", "131072x16")),
    ("image_shape_mismatch_snell", ("info",), 1, ("images[0] ('Tex').shape", "[4, 4, 3]")),
    ("fifo_snell", ("render", "info"), 1, ("is not a regular file",)),
    ("device_link_snell", ("info",), 1, ("is not a regular file",)),
]

# Inputs rendered with a warning: (input, command, fragments of one warning line, fragments no
# line may hold). A NaN vertex drops its triangles, as Cycles does, and says why.
WARNING_CASES = [
    ("nan_vertex", "render", ("object 'Cube'", "NaN or Inf vertex coordinate"), ("zero-area",)),
    ("inf_vertex", "export", ("object 'Cube'", "out of range"), ("zero-area", "normals")),
    ("huge_vertex", "export", ("object 'Cube'", "out of range"), ("zero-area",)),
    # Dropped, not rendered (issue 31, item 8): Cycles renders them, so the warning says so.
    ("dropped_objects", "export", ("object 'Cube'", "hair particle system 'Hair'"), ()),
    ("dropped_objects", "info", ("object 'Points'", "point cloud not rendered"), ()),
    ("dropped_objects", "render", ("object 'Curves'", "hair curves not rendered"), ()),
    ("missing_library", "export", ("library", "library_gone.blend", "is missing", "LinkedCube"), ()),
]

# Outputs that cannot be written: (name, command, argv maker, fragments). {out} is the output
# directory of the case, {src} the valid tiny.blend; all fail before any rendering.
UNWRITABLE = "/sys" if os.geteuid() == 0 else None   # root writes through permission bits
OUTPUT_CASES = [
    ("output directory missing", "render", lambda s, o: ["render", s, "-o", f"{o}/no/a.exr"], ("does not exist",)),
    ("output directory missing", "export", lambda s, o: ["export", s, "-o", f"{o}/no/a.snell"], ("does not exist",)),
    ("output directory missing", "compare", lambda s, o: ["compare", s, "--report", f"{o}/no/r", *FAST], ("does not exist",)),
    ("output directory missing", "study", lambda s, o: ["study", "focus", s, "--report", f"{o}/no/r", *FAST], ("does not exist",)),
    ("output directory missing", "bench", lambda s, o: ["bench", s, "--report", f"{o}/no/r"], ("does not exist",)),
    ("output directory missing", "batch", lambda s, o: ["batch", s, "-o", f"{o}/no/f_####.exr"], ("does not exist",)),
    ("output directory unwritable", "render", lambda s, o: ["render", s, "-o", f"{o}/ro/a.exr"], ("cannot write",)),
    ("output directory unwritable", "export", lambda s, o: ["export", s, "-o", f"{o}/ro/a.snell"], ("cannot write",)),
    ("output directory unwritable", "compare", lambda s, o: ["compare", s, "--report", f"{o}/ro/r", *FAST], ("cannot write",)),
    ("output directory unwritable", "bench", lambda s, o: ["bench", s, "--report", f"{o}/ro/r"], ("cannot write",)),
    ("output directory unwritable", "batch", lambda s, o: ["batch", s, "-o", f"{o}/ro/f_####.exr"], ("cannot write",)),
    ("output path is a directory", "render", lambda s, o: ["render", s, "-o", f"{o}/dir.exr"], ("is a directory",)),
    ("report path is a file", "compare", lambda s, o: ["compare", s, "--report", f"{o}/file.txt", *FAST], ("is a file",)),
    ("output parent is a file", "render", lambda s, o: ["render", s, "-o", f"{o}/file.txt/a.exr"], ("is not a directory",)),
    ("--spp 0", "render", lambda s, o: ["render", s, "-o", f"{o}/a.exr", "--spp", "0"], ("--spp",)),
    ("--spp 1", "compare", lambda s, o: ["compare", s, "--report", f"{o}/r", "--spp", "1"], ("--spp",)),
    ("--frames 5-1", "batch", lambda s, o: ["batch", s, "--frames", "5-1"], ("--frames",)),
    # Round two (issue 31): outputs that are not regular files, names too long for the file
    # system with the temporary name's extra characters, options beyond the settings' ranges.
    ("output is a FIFO", "render", lambda s, o: ["render", s, "-o", f"{o}/fifo.exr"], ("not a regular file",)),
    ("output links to /dev/null", "export", lambda s, o: ["export", s, "-o", f"{o}/null.snell"], ("not a regular file",)),
    ("png output links to /dev/null", "render", lambda s, o: ["render", s, "-o", f"{o}/a.exr", "--png", f"{o}/null.png"], ("--png", "not a regular file")),
    ("output name too long", "render", lambda s, o: ["render", s, "-o", f"{o}/{'a' * 246}.exr"], ("file name too long",)),
    ("output name too long", "export", lambda s, o: ["export", s, "-o", f"{o}/{'a' * 240}.snell"], ("file name too long",)),
    ("report name too long", "compare", lambda s, o: ["compare", s, "--report", f"{o}/{'r' * 250}", *FAST], ("file name too long",)),
    ("--spp 99999999999", "render", lambda s, o: ["render", s, "-o", f"{o}/a.exr", "--spp", "99999999999"], ("--spp",)),
    ("--min-spp 99999999999", "render", lambda s, o: ["render", s, "-o", f"{o}/a.exr", "--min-spp", "99999999999"], ("--min-spp",)),
    ("--seed 2147483648", "render", lambda s, o: ["render", s, "-o", f"{o}/a.exr", "--seed", "2147483648"], ("--seed",)),
    ("--spp 99999999999", "compare", lambda s, o: ["compare", s, "--report", f"{o}/r", "--spp", "99999999999"], ("--spp",)),
    ("--seed 2147483648", "study", lambda s, o: ["study", "depth", s, "--report", f"{o}/r", "--seed", "2147483648"], ("--seed",)),
    ("--max-spp 99999999999", "bench", lambda s, o: ["bench", s, "--report", f"{o}/r", "--max-spp", "99999999999"], ("--max-spp",)),
    ("several frames, no ####", "batch", lambda s, o: ["batch", s, "--frames", "1,2", "-o", f"{o}/same.exr"], ("####",)),
    ("output directory missing", "stress", lambda s, o: ["stress", "--report", f"{o}/no/r"], ("does not exist",)),
    ("output directory unwritable", "stress", lambda s, o: ["stress", "--report", f"{o}/ro/r"], ("cannot write",)),
    ("report path is a file", "stress", lambda s, o: ["stress", "--report", f"{o}/file.txt"], ("is a file",)),
    ("--threads 0", "stress", lambda s, o: ["stress", "--threads", "0"], ("--threads",)),
]

TABLE = []


def run_snell(argv, cwd=None):
    return subprocess.run([sys.executable, "-m", "snell.cli", *map(str, argv)], capture_output=True,
                          text=True, timeout=600, cwd=cwd)


def leftovers(directory):
    """Every file and directory under `directory` (hidden ones included)."""
    found = []
    for root, dirs, files in os.walk(directory):
        found += [os.path.relpath(os.path.join(root, n), directory) for n in dirs + files]
    return sorted(found)


PYTHON_WARNING = re.compile(r"\w*Warning: ")    # a raw warnings.warn line (RuntimeWarning, ...)


def check(proc, status, fragments, names=()):
    """The status, and for errors one `snell: error:` line naming what it must; the line."""
    assert "Traceback" not in proc.stderr and "Traceback" not in proc.stdout, proc.stderr
    assert not PYTHON_WARNING.search(proc.stderr), proc.stderr
    assert proc.returncode == status, proc.stderr
    lines = proc.stderr.strip().splitlines()
    if status == 0:
        assert not any(line.startswith("snell: error") for line in lines), proc.stderr
        return lines[-1] if lines else proc.stdout.strip().splitlines()[-1]
    if status == 130:
        assert lines == ["snell: interrupted"], proc.stderr
        return lines[0]
    errors = [line for line in lines if line.startswith("snell: error: ")]
    assert len(errors) == 1 and errors[0] == lines[-1], proc.stderr
    # batch keeps its documented per-frame lines before the error; the others print only it
    assert len(lines) == 1 or proc.args[3] == "batch", proc.stderr
    for fragment in (*fragments, *names):
        assert fragment in errors[0], (fragment, errors[0])
    return errors[0]


def _row(input_name, command, status, line):
    TABLE.append((input_name, command, line.replace("|", "\\|"), status))


@pytest.fixture
def out(tmp_path):
    path = tmp_path / "out"
    path.mkdir()
    return str(path)


# Slow (a minute: its shader program's variant of the stages compiles), to keep the default run
# short; the exporter's tests hold what it warns.
SLOW_INPUTS = {("unsupported_nodes", "render")}


@pytest.mark.parametrize("name,command,status,fragments", [
    pytest.param(name, command, status, fragments, id=f"{name}-{command}",
                 marks=[pytest.mark.slow] if (name, command) in SLOW_INPUTS else [])
    for name, commands, status, fragments in CASES for command in commands if command in COMMANDS])
def test_input(corpus, out, name, command, status, fragments):
    src = corpus[name]
    argv = COMMANDS[command](src, out)
    if name == "startup" and command == "compare":
        argv += ["--scale", "20"]
    proc = run_snell(argv)
    names = (os.path.basename(src),) if status == 1 else ()
    line = check(proc, status, fragments, names)
    _row(os.path.basename(src), command, proc.returncode, line)
    if status != 0:
        assert leftovers(out) == []
    elif command not in ("info",):
        assert leftovers(out), "no output written"


@pytest.mark.parametrize("name,command,argv,fragments", [
    pytest.param(*case, id=f"{case[0]}-{case[1]}") for case in OUTPUT_CASES])
def test_output(corpus, out, name, command, argv, fragments):
    args = argv(corpus["tiny"], out)
    if "unwritable" in name:
        if UNWRITABLE is None:
            os.mkdir(os.path.join(out, "ro"), 0o555)
        else:
            args = [a.replace(f"{out}/ro", UNWRITABLE) for a in args]
    os.mkdir(os.path.join(out, "dir.exr"))
    with open(os.path.join(out, "file.txt"), "w") as f:
        f.write("x")
    os.mkfifo(os.path.join(out, "fifo.exr"))
    for link in ("null.snell", "null.png"):
        os.symlink("/dev/null", os.path.join(out, link))
    before = leftovers(out)
    proc = run_snell(args)
    status = 2 if name.startswith("--") else 1
    line = check(proc, status, fragments)
    _row(name, command, proc.returncode, line)
    assert leftovers(out) == before


@pytest.mark.parametrize("name,command,fragments,forbidden", [
    pytest.param(*case, id=f"{case[0]}-{case[1]}") for case in WARNING_CASES])
def test_warning(corpus, out, name, command, fragments, forbidden):
    """Inputs Snell renders in part: exit 0, and a warning line that names the object and the
    real cause."""
    proc = run_snell(COMMANDS[command](corpus[name], out))
    line = check(proc, 0, ())
    warnings = [w for w in proc.stderr.splitlines() if w.startswith("snell: warning: ")]
    assert any(all(f in w for f in fragments) for w in warnings), proc.stderr
    assert not any(f in w for w in warnings for f in forbidden), proc.stderr
    _row(os.path.basename(corpus[name]), command, proc.returncode, line)
    assert command == "info" or leftovers(out)


def test_batch_output_without_frame_number_is_written_as_named(corpus, out):
    """`batch -o same.exr` of one frame writes same.exr (Blender alone would append the frame
    number: same.exr0001.exr)."""
    proc = run_snell(["batch", corpus["tiny"], "-o", os.path.join(out, "same.exr"), "--spp", "2",
                      "--noise-threshold", "0"])
    check(proc, 0, ())
    assert leftovers(out) == ["same.exr"]


def test_batch_prints_a_single_frame_failure_once(corpus, out):
    proc = run_snell(COMMANDS["batch"](corpus["camera_pano"], out))
    check(proc, 1, ("PANO",))
    assert proc.stderr.count("PANO") == 1, proc.stderr


# Ctrl-C: (command, input, stage); stages in tests/support/interrupt_hook.py.
INTERRUPTS = [
    ("render", "tiny", "export"), ("render", "tiny", "build"), ("render", "tiny", "render"),
    ("render", "tiny", "write"), ("render", "tiny_snell", "write"),
    ("export", "tiny", "export"), ("export", "tiny", "write"),
    ("info", "tiny", "export"),
    ("compare", "tiny", "export"), ("compare", "tiny", "render"), ("compare", "tiny", "cycles"),
    ("compare", "tiny", "write"),
    ("study", "tiny", "write"),
    ("batch", "tiny", "export"), ("batch", "tiny", "render"),
]


@pytest.mark.skipif(os.name != "posix", reason="sends SIGINT")
@pytest.mark.parametrize("command,name,stage", [
    pytest.param(*case, id="-".join(case)) for case in INTERRUPTS])
def test_ctrl_c(corpus, out, command, name, stage):
    argv = COMMANDS[command](corpus[name], out)
    if stage == "render" and command != "batch":  # 4 windows of 16x12 pixels: one to interrupt
        # (batch renders tiny.blend's own 2048 spp)
        argv[argv.index("--spp") + 1] = "8192"
    if stage == "render" and command in ("render", "batch"):
        # Every pixel all 2048 samples: adaptive sampling would end the flat image before Ctrl-C
        # (compare renders in batches, which sample every pixel alike anyway).
        argv += ["--noise-threshold", "0"]
    marker = os.path.join(os.path.dirname(out), "marker")
    proc = subprocess.Popen(
        [sys.executable, os.path.join(HERE, "interrupt_hook.py"), stage, marker, *argv],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        # A background job may inherit SIGINT ignored: restore Python's usual handler.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 120
    while not os.path.exists(marker) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert os.path.exists(marker), f"never reached stage {stage}: " + proc.communicate(timeout=60)[1]
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    result = subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)
    line = check(result, 130, ())
    _row(f"Ctrl-C at {stage} ({os.path.basename(corpus[name])})", command, proc.returncode, line)
    assert leftovers(out) == []


@pytest.fixture(scope="module", autouse=True)
def table(tmp_path_factory):
    """Write the corpus table (input, command, message, status) after the module's tests."""
    yield
    lines = ["| input | command | message | exit |", "| --- | --- | --- | --- |"]
    lines += [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in TABLE]
    text = "\n".join(lines) + "\n"
    (tmp_path_factory.getbasetemp() / "corpus_table.md").write_text(text)
    if os.environ.get("SNELL_CORPUS_TABLE"):
        with open(os.environ["SNELL_CORPUS_TABLE"], "w") as f:
            f.write(text)
