"""Fuzzing the scene-file loader: a damaged .snell file gives SceneError naming what is wrong.

Hypothesis mutates a valid file (tests/support/builders.py's tiny_scene plus a lamp, a mirror, a glossy, a
rough glass and a principled material, normals and depth of field, so that every header section
and material field is present): raw bytes (overwritten, truncated, inserted), header JSON values
(replaced by other JSON values, NaN, Inf, huge integers, or deleted) and arrays (dtype, shape,
values, missing). tracer.scene.load must then either return a valid Scene or raise SceneError
whose message starts with the field or the file at fault; any other exception is a bug. The
profile is derandomized with a fixed example count, so the test is the same on every run.
"""
from __future__ import annotations

import copy
import json
import warnings
import zipfile

import numpy as np
import pytest

pytestmark = pytest.mark.filterwarnings("ignore:Casting complex values")

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from snell.tracer.camera import Camera  # noqa: E402
from snell.tracer.scene import Scene, SceneError, load, save  # noqa: E402

from support.builders import tiny_scene  # noqa: E402

settings.register_profile(
    "snell-fuzz", derandomize=True, max_examples=200, deadline=None, database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
FUZZ = settings.get_profile("snell-fuzz")

# The first word of every SceneError message is one of these fields (or the file's path).
FIELDS = ("header", "positions", "triangles", "material_ids", "object_ids", "normals", "materials",
          "lights", "camera", "world", "render", "objects", "source", "images", "texcoords")
ARRAYS = ("positions", "triangles", "material_ids", "object_ids", "normals", "image_0",
          "texcoord_0")


def rich_scene() -> Scene:
    scene = tiny_scene().with_camera(dof={"use_dof": True, "focus_distance": 2.0, "fstop": 2.0})
    scene.materials = scene.materials + [
        {"name": "Mirror", "kind": "mirror", "color": [0.9, 0.9, 0.9]},
        {"name": "Brushed", "kind": "glossy", "color": [0.9, 0.9, 0.9], "roughness": 0.3,
         "distribution": "beckmann"},
        {"name": "Frosted", "kind": "glass", "color": [1.0, 1.0, 1.0], "ior": 1.5,
         "roughness": 0.2, "distribution": "ggx"},
        {"name": "Principled", "kind": "principled", "color": [0.8, 0.8, 0.8], "metallic": 0.5,
         "roughness": 0.4, "ior": 1.45, "specular_ior_level": 0.5, "specular_tint": [1.0, 1.0, 1.0],
         "transmission": 0.2, "coat_weight": 0.1, "coat_roughness": 0.03, "coat_ior": 1.5,
         "coat_tint": [1.0, 1.0, 1.0], "emission_color": [1.0, 1.0, 1.0],
         "emission_strength": 1.0, "distribution": "ggx"}]
    scene.material_ids = np.array([0, 1], np.int32)
    scene.normals = np.tile(np.array([[0, 0, 1]], np.float32), (len(scene.positions), 1))
    scene.lights = [
        {"name": "Point", "kind": "point", "position": [0.0, 1.0, -1.0], "intensity": [1.0, 1.0, 1.0],
         "radius": 0.1, "soft_falloff": True},
        {"name": "Sun", "kind": "sun", "direction": [0.0, -1.0, 0.0], "irradiance": [1.0, 1.0, 1.0],
         "angle": 0.1},
        {"name": "Area", "kind": "area", "shape": "disk", "matrix": np.eye(4).tolist(),
         "size": [1.0, 1.0], "radiance": [1.0, 1.0, 1.0], "spread": 3.0},
        {"name": "Spot", "kind": "spot", "position": [0.0, 1.0, 0.0], "intensity": [1.0, 1.0, 1.0],
         "matrix": np.eye(4).tolist(), "spot_size": 1.0, "spot_blend": 0.2},
    ]
    # An environment map and a texture on the principled material, sharing one image.
    scene.images = [{"name": "sky", "source": "test", "colorspace": "linear",
                     "pixels": np.full((2, 4, 3), 0.5, np.float32)}]
    scene.texcoords = [{"kind": "uv", "name": "",
                        "coords": np.zeros((len(scene.triangles), 3, 3), np.float32)}]
    mapping = {"matrix": np.eye(3).tolist(), "offset": [0.0, 0.0, 0.0]}
    scene.world = {"color": [0.0, 0.0, 0.0], "environment": {
        "image": 0, "strength": 1.0, "interpolation": "linear", **mapping}}
    scene.materials[-1]["textures"] = {"roughness": {
        "image": 0, "texcoord": 0, "interpolation": "closest", "extension": "clip", **mapping}}
    return scene


@pytest.fixture(scope="module")
def valid(tmp_path_factory):
    """(path, bytes, header dict, arrays) of a valid scene file."""
    path = tmp_path_factory.mktemp("fuzz") / "valid.snell"
    save(rich_scene(), str(path))
    load(str(path))  # the starting point is valid
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(arrays.pop("header").tobytes())
    return str(path), path.read_bytes(), header, arrays


def check_load(path):
    """Load path; a SceneError must name a field or the file; anything else propagates. What it
    accepts must be a scene the renderer can set up without a Python warning (a raw NumPy
    RuntimeWarning reaches the user's terminal): its camera, a version that is an integer, and
    object ids within the objects it lists."""
    try:
        scene = load(path)
    except SceneError as exc:
        message = str(exc)
        assert message.startswith(FIELDS) or message.startswith(path), message
        assert "\n" not in message.strip() or message.startswith(path)
        return
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        camera = Camera(scene.camera)
    assert np.isfinite(camera.rotation).all() and abs(np.linalg.det(camera.rotation)) > 0.5
    assert camera.clip_end > camera.clip_start
    if len(scene.object_ids) and scene.objects:
        assert scene.object_ids.max() < len(scene.objects)


def write(path, header, arrays, raw_header=None):
    blob = raw_header if raw_header is not None else json.dumps(header).encode()
    out = {"header": np.frombuffer(blob, np.uint8), **{k: v for k, v in arrays.items() if v is not None}}
    with open(path, "wb") as f:
        np.savez(f, **out)


# ---------------------------------------------------------------------------------------------
# Byte mutations


@st.composite
def byte_edits(draw, size):
    edits = []
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["set", "truncate", "insert", "zero-run"]))
        pos = draw(st.integers(0, size - 1))
        if kind == "set":
            edits.append(("set", pos, draw(st.integers(0, 255))))
        elif kind == "truncate":
            edits.append(("truncate", pos, 0))
        elif kind == "insert":
            edits.append(("insert", pos, draw(st.binary(min_size=1, max_size=8))))
        else:
            edits.append(("zero-run", pos, draw(st.integers(1, 64))))
    return edits


def apply_edits(data: bytes, edits) -> bytes:
    b = bytearray(data)
    for kind, pos, arg in edits:
        pos = min(pos, max(len(b) - 1, 0))
        if kind == "set" and b:
            b[pos] = arg
        elif kind == "truncate":
            del b[pos:]
        elif kind == "insert":
            b[pos:pos] = arg
        elif kind == "zero-run":
            b[pos:pos + arg] = bytes(len(b[pos:pos + arg]))
    return bytes(b)


@FUZZ
@given(data=st.data())
def test_byte_mutations_give_named_errors(valid, tmp_path, data):
    path, blob, _, _ = valid
    edits = data.draw(byte_edits(len(blob)))
    target = str(tmp_path / "mutated.snell")
    with open(target, "wb") as f:
        f.write(apply_edits(blob, edits))
    check_load(target)


@FUZZ
@given(data=st.data())
def test_byte_mutations_inside_the_header_member(valid, tmp_path, data):
    # Raw byte edits mostly break the zip's CRC; this one rewrites the header member's JSON
    # bytes and re-zips it, so that the loader's own JSON and field checks are reached.
    path, _, header, arrays = valid
    text = json.dumps(header).encode()
    edits = data.draw(byte_edits(len(text)))
    target = str(tmp_path / "mutated.snell")
    write(target, header, arrays, raw_header=apply_edits(text, edits))
    check_load(target)


# ---------------------------------------------------------------------------------------------
# Field mutations


JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-3, 3) | st.integers() | st.sampled_from([10 ** 400, -10 ** 400])
    | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=6),
    lambda children: st.lists(children, max_size=5) | st.dictionaries(st.text(max_size=4), children, max_size=3),
    max_leaves=8)


def paths_of(tree, prefix=()):
    """Every key path into a JSON tree (dict keys and list indices)."""
    out = [prefix] if prefix else []
    if isinstance(tree, dict):
        for k, v in tree.items():
            out += paths_of(v, prefix + (k,))
    elif isinstance(tree, list):
        for i, v in enumerate(tree):
            out += paths_of(v, prefix + (i,))
    return out


def mutate_header(header, path, action, value):
    header = copy.deepcopy(header)
    parent = header
    for key in path[:-1]:
        parent = parent[key]
    if action == "delete":
        del parent[path[-1]]
    else:
        parent[path[-1]] = value
    return header


@FUZZ
@given(data=st.data())
def test_header_value_mutations_give_named_errors(valid, tmp_path, data):
    _, _, header, arrays = valid
    for _ in range(data.draw(st.integers(1, 3))):
        paths = paths_of(header)
        path = data.draw(st.sampled_from(paths))
        action = data.draw(st.sampled_from(["replace", "replace", "delete"]))
        header = mutate_header(header, path, action, data.draw(JSON_VALUES))
    target = str(tmp_path / "mutated.snell")
    write(target, header, arrays)
    check_load(target)


@FUZZ
@given(value=JSON_VALUES)
def test_whole_header_replaced(valid, tmp_path, value):
    _, _, _, arrays = valid
    target = str(tmp_path / "mutated.snell")
    write(target, None, arrays, raw_header=json.dumps(value).encode())
    check_load(target)


DTYPES = ["float32", "float64", "float16", "int32", "int64", "int8", "uint32", "uint8", "bool",
          "complex64", "U3", ">f4", ">i4"]     # big-endian: the same name, another byte order
SPECIAL = [np.nan, np.inf, -np.inf, -1.0, 0.0, 1e30, -1e30, 2 ** 31 - 1, -(2 ** 31), 3.5, 1e38]


@FUZZ
@given(data=st.data())
def test_array_mutations_give_named_errors(valid, tmp_path, data):
    _, _, header, arrays = valid
    arrays = dict(arrays)
    for _ in range(data.draw(st.integers(1, 3))):
        key = data.draw(st.sampled_from(ARRAYS))
        arr = arrays.get(key)
        action = data.draw(st.sampled_from(["dtype", "shape", "value", "drop", "empty", "scalar"]))
        if arr is None or action == "drop" or (arr.ndim == 0 and action in ("empty", "value")):
            arrays[key] = None
        elif action == "dtype":
            dtype = data.draw(st.sampled_from(DTYPES))
            with np.errstate(invalid="ignore", over="ignore"):
                arrays[key] = arr.astype(dtype) if dtype != "U3" else arr.astype(str)
        elif action == "shape":
            shape = tuple(data.draw(st.lists(st.integers(0, 5), min_size=0, max_size=3)))
            n = int(np.prod(shape)) if shape else 1
            arrays[key] = np.resize(arr, shape) if n else np.zeros(shape, arr.dtype)
        elif action == "value" and arr.size:
            arr = arr.copy()
            index = data.draw(st.integers(0, arr.size - 1))
            value = data.draw(st.sampled_from(SPECIAL))
            with np.errstate(invalid="ignore", over="ignore"):
                arr.flat[index] = np.array(value).astype(arr.dtype) if arr.dtype.kind in "iu" else value
            arrays[key] = arr
        elif action == "empty":
            arrays[key] = arr[:0]
        elif action == "scalar":
            arrays[key] = np.array(arr.flat[0] if arr.size else 0, arr.dtype)
    target = str(tmp_path / "mutated.snell")
    write(target, header, arrays)
    check_load(target)


def test_other_files_in_the_zip_and_pickled_members(valid, tmp_path):
    _, _, header, arrays = valid
    target = str(tmp_path / "pickled.snell")
    with open(target, "wb") as f:   # an object array can only be stored pickled
        np.savez(f, header=np.frombuffer(json.dumps(header).encode(), np.uint8),
                 **{**arrays, "positions": np.array([object()] * 3, dtype=object)})
    check_load(target)
    with pytest.raises(SceneError, match="positions"):
        load(target)
    plain = tmp_path / "plain.snell"
    with zipfile.ZipFile(plain, "w") as z:
        z.writestr("readme.txt", "not numpy")
    with pytest.raises(SceneError, match="no header"):
        load(str(plain))
    with pytest.raises(SceneError, match="not a Snell scene file"):
        load(str(tmp_path))   # a directory


def test_profile_is_deterministic():
    assert FUZZ.derandomize and FUZZ.database is None and FUZZ.max_examples == 200
