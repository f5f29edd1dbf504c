"""The scene file: round trips, and every kind of bad data rejected with the field named."""
import json

import numpy as np
import pytest

from support.builders import camera, icosphere, make_scene, quad
from snell.tracer import scene as S


@pytest.fixture
def good(tmp_path):
    pos, tri, nrm = icosphere(1)
    lamp = quad((0, 0, 3), 0.5, 0.5)
    mats = [{"name": "Glass", "kind": "glass", "color": [1, 1, 1], "ior": 1.5},
            {"name": "Lamp", "kind": "emission", "color": [1, 1, 1], "strength": 2.0}]
    sc = make_scene([(pos, tri, 0, nrm), (*lamp, 1)], mats, camera(),
                    lights=[{"name": "P", "kind": "point", "position": [0, 0, 2], "intensity": [1, 1, 1]}])
    path = tmp_path / "good.snell"
    S.save(sc, str(path))
    return sc, path


def test_round_trip_keeps_arrays_and_header(good):
    sc, path = good
    back = S.load(str(path))
    for key in ("positions", "triangles", "material_ids", "object_ids", "normals"):
        assert np.array_equal(getattr(back, key), getattr(sc, key))
        assert getattr(back, key).dtype == getattr(sc, key).dtype
    assert back.materials == sc.materials and back.lights == sc.lights and back.camera == sc.camera
    assert back.features() == {"glass": True, "mirrors": False, "rough": False,
                               "depth_of_field": False, "world": False,
                               "environment": False, "emissive_meshes": True,
                               "textures": False}


def _rewrite(path, out, header=None, **arrays):
    with np.load(path) as npz:
        data = {k: npz[k] for k in npz.files}
    if header is not None:
        h = json.loads(data["header"].tobytes())
        header(h)
        data["header"] = np.frombuffer(json.dumps(h).encode(), np.uint8)
    for k, v in arrays.items():
        if v is None:
            del data[k]
        else:
            data[k] = v
    np.savez(out, **data)
    return str(out)


def _set(path, value):
    def apply(h):
        node = h
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    return apply


@pytest.mark.parametrize("edit, message", [
    (dict(header=_set(["version"], 99)), "header.version"),
    (dict(header=_set(["format"], "obj")), "header.format"),
    (dict(header=_set(["materials", 0, "kind"], "velvet")), "materials[0] ('Glass').kind"),
    (dict(header=_set(["materials", 0, "ior"], float("nan"))), "materials[0] ('Glass').ior"),
    (dict(header=_set(["materials", 1, "color"], [1, 1])), "materials[1] ('Lamp').color"),
    (dict(header=_set(["lights", 0, "kind"], "laser")), "lights[0] ('P').kind"),
    (dict(header=_set(["lights", 0, "position"], [0, float("inf"), 0])), "lights[0] ('P').position"),
    (dict(header=_set(["camera"], None)), "no camera"),
    (dict(header=_set(["camera", "lens"], 0)), "camera.lens"),
    (dict(header=_set(["camera", "resolution"], [0, 10])), "camera.resolution"),
    (dict(header=_set(["camera", "type"], "PANO")), "camera.type: unknown value"),
    (dict(header=_set(["camera", "type"], "ORTHO")), "camera.ortho_scale: expected a number"),
    (dict(header=_set(["render", "fresnel"], "fast")), "render.fresnel"),
    (dict(header=_set(["world", "color"], [0, -1, 0])), "world.color"),
    (dict(header=_set(["render", "noise_threshold"], -0.01)), "render.noise_threshold: must be >= 0"),
    (dict(header=_set(["render", "noise_threshold"], float("nan"))), "render.noise_threshold: is NaN"),
    (dict(header=_set(["render", "noise_threshold"], "low")), "render.noise_threshold: expected a number"),
    (dict(header=_set(["render", "min_spp"], -1)), "render.min_spp: expected an integer"),
    (dict(header=_set(["render", "min_spp"], 2.5)), "render.min_spp: expected an integer"),
    (dict(header=_set(["render", "min_spp"], True)), "render.min_spp: expected an integer"),
    (dict(header=_set(["images"], "sky.exr")), "images: expected a list"),
    (dict(header=_set(["images"], [{"name": "sky"}] * 4097)), "images: 4097 images (at most 4096)"),
    (dict(header=_set(["images"], [7])), "images[0]: expected an object with a name"),
    (dict(header=_set(["images"], [{"name": "sky", "sha256": "0"}])), "images[0] ('sky'): missing array image_0"),
    (dict(positions=np.zeros((4, 3), np.float64)), "positions: expected dtype float32"),
    (dict(triangles=np.zeros((3, 4), np.int32)), "triangles: expected shape"),
    (dict(material_ids=np.full(10, 7, np.int32)), "material_ids"),
    (dict(normals=np.zeros((3, 3), np.float32)), "normals"),
    (dict(positions=None), "positions: missing array"),
])
def test_bad_data_is_rejected_naming_the_field(good, tmp_path, edit, message):
    _, path = good
    bad = _rewrite(path, tmp_path / "bad.npz", **edit)
    with pytest.raises(S.SceneError) as err:
        S.load(bad)
    assert message in str(err.value)


def test_adaptive_settings_default_to_cycles_and_are_checked(good, tmp_path):
    """A file without them (written before adaptive sampling) gets Cycles' defaults; overrides are
    checked like the file's own fields."""
    _, path = good

    def drop(h):
        h["render"].pop("noise_threshold", None)
        h["render"].pop("min_spp", None)
    old = S.load(_rewrite(path, tmp_path / "old.npz", header=drop))
    assert (old.render["noise_threshold"], old.render["min_spp"]) == (0.01, 0)
    assert old.with_render(noise_threshold=0, min_spp=16).render["min_spp"] == 16
    with pytest.raises(S.SceneError, match="render.noise_threshold"):
        old.with_render(noise_threshold=float("inf"))
    with pytest.raises(S.SceneError, match="render.min_spp"):
        old.with_render(min_spp=-3)


def test_nan_vertex_and_out_of_range_index(good, tmp_path):
    sc, path = good
    pos = sc.positions.copy()
    pos[5, 1] = np.nan
    with pytest.raises(S.SceneError, match=r"positions: vertex 5 \(object .object0.\) is NaN or Inf"):
        S.load(_rewrite(path, tmp_path / "a.npz", positions=pos))
    tri = sc.triangles.copy()
    tri[0, 0] = len(pos)
    with pytest.raises(S.SceneError, match="triangles: vertex index out of range"):
        S.load(_rewrite(path, tmp_path / "b.npz", triangles=tri))


def test_zero_area_emitters_are_rejected(good, tmp_path):
    sc, path = good
    pos = sc.positions.copy()
    lamp = sc.triangles[sc.material_ids == 1]
    pos[np.unique(lamp)] = pos[lamp[0, 0]]        # collapse the lamp to a point
    with pytest.raises(S.SceneError, match=r"materials\[1\] \('Lamp'\): zero-area emitter"):
        S.load(_rewrite(path, tmp_path / "c.npz", positions=pos))
    m = np.eye(4).tolist()
    with pytest.raises(S.SceneError, match="zero-area emitter"):
        S.validate(make_scene([], [], camera(), lights=[
            {"name": "A", "kind": "area", "shape": "square", "matrix": m, "size": [0, 0], "radiance": [1, 1, 1]}]))


# ---------------------------------------------------------------------------------------------
# Version 3: glossy and principled materials, rough glass and refraction

WHITE = [1.0, 1.0, 1.0]
# Every optional field of the new kinds, none at its default.
FULL = {
    "glossy": {"kind": "glossy", "color": [0.9, 0.8, 0.7], "roughness": 0.25,
               "distribution": "beckmann"},
    "glass": {"kind": "glass", "color": WHITE, "ior": 1.45, "transmission_color": [0.5, 0.6, 0.7],
              "roughness": 0.2, "distribution": "ggx"},
    "refraction": {"kind": "refraction", "color": WHITE, "ior": 1.33, "roughness": 0.4,
                   "distribution": "ggx"},
    "principled": {"kind": "principled", "color": [0.2, 0.3, 0.4], "metallic": 0.25,
                   "roughness": 0.75, "ior": 1.6, "specular_ior_level": 0.8,
                   "specular_tint": [0.9, 0.8, 0.7], "transmission": 0.5, "coat_weight": 0.3,
                   "coat_roughness": 0.1, "coat_ior": 1.7, "coat_tint": [0.6, 0.7, 0.8],
                   "emission_color": [1.0, 0.5, 0.25], "emission_strength": 3.0,
                   "distribution": "ggx"},
}


def one_material(mat, name="M"):
    """A scene of one quad of the material, checked."""
    return make_scene([(*quad((0, 0, 0), 1, 1), 0)], [{"name": name, **mat}], camera())


def test_kind_and_distribution_codes_are_positions():
    """The tracer's codes: adding a kind or distribution anywhere but the end would renumber."""
    assert S.MATERIAL_KINDS == ("diffuse", "mirror", "glass", "refraction", "emission", "glossy",
                                "principled", "program")
    assert S.DISTRIBUTIONS == ("ggx", "multi_ggx", "beckmann")
    assert S.VERSION == 4 and S.READS_VERSIONS == (1, 2, 3, 4)


def test_version_3_round_trip_keeps_every_field(tmp_path):
    mats = [{"name": kind, **mat} for kind, mat in FULL.items()]
    quads = [(*quad((3.0 * i, 0, 0), 1, 1), i) for i in range(len(mats))]
    sc = make_scene(quads, mats, camera())
    S.save(sc, str(tmp_path / "v3.snell"))
    back = S.load(str(tmp_path / "v3.snell"))
    assert back.materials == mats
    assert back.header()["version"] == S.VERSION
    assert all(S.material_field(m, key) == value
               for m in back.materials for key, value in m.items())


@pytest.mark.parametrize("kind, field, value", [
    ("glossy", "roughness", 0.5), ("glossy", "distribution", "multi_ggx"),
    ("glass", "roughness", 0.0), ("glass", "distribution", "multi_ggx"),
    ("refraction", "roughness", 0.0), ("refraction", "distribution", "beckmann"),
    ("principled", "metallic", 0.0), ("principled", "roughness", 0.5), ("principled", "ior", 1.5),
    ("principled", "specular_ior_level", 0.5), ("principled", "specular_tint", WHITE),
    ("principled", "transmission", 0.0), ("principled", "coat_weight", 0.0),
    ("principled", "coat_roughness", 0.03), ("principled", "coat_ior", 1.5),
    ("principled", "coat_tint", WHITE), ("principled", "emission_color", WHITE),
    ("principled", "emission_strength", 0.0), ("principled", "distribution", "multi_ggx"),
])
def test_a_field_left_out_reads_as_its_default(kind, field, value):
    mat = {k: v for k, v in FULL[kind].items() if k != field}
    assert S.material_field(one_material(mat).materials[0], field) == value


def test_material_field_reads_the_file_first_and_knows_no_other_fields():
    glass = {"kind": "glass", "color": [0.1, 0.2, 0.3], "ior": 1.5}
    assert S.material_field(glass, "transmission_color") == [0.1, 0.2, 0.3]   # defaults to color
    assert S.material_field(FULL["glass"], "transmission_color") == [0.5, 0.6, 0.7]
    assert S.material_field(FULL["glossy"], "roughness") == 0.25
    with pytest.raises(KeyError, match="'diffuse' has no field 'roughness'"):
        S.material_field({"kind": "diffuse", "color": WHITE}, "roughness")


@pytest.mark.parametrize("version", [1, 2])
def test_older_files_read_as_before(good, tmp_path, version):
    """A version 1 or 2 file has no roughness: its glass is the smooth glass it always was."""
    sc, path = good
    old = S.load(_rewrite(path, tmp_path / "old.npz", header=_set(["version"], version)))
    assert old.materials == sc.materials
    assert S.material_field(old.materials[0], "roughness") == 0.0
    assert not old.features()["rough"]


@pytest.mark.parametrize("kind, field, value, message", [
    ("glossy", "roughness", 1.5, "roughness: must be at most 1, got 1.5"),
    ("glossy", "roughness", -0.1, "roughness: must be >= 0"),
    ("glossy", "roughness", "rough", "roughness: expected a number"),
    ("glossy", "roughness", True, "roughness: expected a number"),
    ("glossy", "distribution", "phong", "distribution: expected one of ggx, multi_ggx, beckmann"),
    ("glossy", "distribution", 1, "distribution: expected one of"),
    ("glossy", "color", None, "color: expected 3 numbers"),
    ("glass", "roughness", 2.0, "roughness: must be at most 1"),
    ("glass", "distribution", "ashikhmin_shirley", "distribution: expected one of"),
    ("refraction", "roughness", float("nan"), "roughness: is NaN or Inf"),
    ("refraction", "distribution", "multi_ggx", "distribution: expected one of ggx, beckmann"),
    ("principled", "color", [1, 1], "color: expected 3 numbers"),
    ("principled", "metallic", 1.01, "metallic: must be at most 1"),
    ("principled", "metallic", -1, "metallic: must be >= 0"),
    ("principled", "roughness", float("inf"), "roughness: is NaN or Inf"),
    ("principled", "ior", 0.0, "ior: must be > 0"),
    ("principled", "specular_ior_level", -0.5, "specular_ior_level: must be >= 0"),
    ("principled", "specular_tint", [1, -1, 1], "specular_tint: must not be negative"),
    ("principled", "transmission", 1.5, "transmission: must be at most 1"),
    ("principled", "coat_weight", -0.1, "coat_weight: must be >= 0"),
    ("principled", "coat_roughness", 1.1, "coat_roughness: must be at most 1"),
    ("principled", "coat_ior", 0.9, "coat_ior: must be >= 1"),
    ("principled", "coat_tint", "white", "coat_tint: expected 3 numbers"),
    ("principled", "emission_color", [0, 0, float("nan")], "emission_color: contains NaN"),
    ("principled", "emission_strength", -2, "emission_strength: must be >= 0"),
    ("principled", "distribution", "beckmann", "distribution: expected one of ggx, multi_ggx"),
])
def test_new_material_fields_are_checked_naming_the_field(kind, field, value, message):
    mat = dict(FULL[kind])
    mat[field] = value
    with pytest.raises(S.SceneError) as err:
        one_material(mat, name="Bad")
    assert str(err.value).startswith(f"materials[0] ('Bad').{field}: ")
    assert message in str(err.value)


def test_new_material_fields_are_checked_when_loading(good, tmp_path):
    _, path = good
    bad = _rewrite(path, tmp_path / "bad.npz", header=_set(["materials", 0, "roughness"], 3))
    with pytest.raises(S.SceneError, match=r"materials\[0\] \('Glass'\)\.roughness: must be at most 1"):
        S.load(bad)


@pytest.mark.parametrize("mat, expected", [
    (FULL["glossy"], {"rough"}),
    ({**FULL["glossy"], "roughness": 0.0}, {"rough", "mirrors"}),
    ({"kind": "glossy", "color": WHITE}, {"rough"}),     # default roughness 0.5
    ({**FULL["glass"], "roughness": 0.0}, {"glass"}),
    (FULL["glass"], {"glass", "rough"}),
    ({"kind": "refraction", "color": WHITE, "ior": 1.5}, {"glass"}),
    (FULL["refraction"], {"glass", "rough"}),
    ({"kind": "principled", "color": WHITE}, {"rough"}),
    ({"kind": "principled", "color": WHITE, "transmission": 0.1}, {"rough", "glass"}),
    ({"kind": "principled", "color": WHITE, "emission_strength": 2.0}, {"rough", "emissive_meshes"}),
    ({"kind": "principled", "color": WHITE, "emission_strength": 2.0,
      "emission_color": [0, 0, 0]}, {"rough"}),
    ({"kind": "principled", "color": WHITE, "emission_color": [1, 1, 1]}, {"rough"}),
])
def test_features_of_the_new_materials(mat, expected):
    features = one_material(mat).features()
    assert {name for name, used in features.items() if used} == expected


def test_principled_emitters_must_have_area(tmp_path):
    collapsed = np.zeros((4, 3), np.float32)
    tri = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    glowing = {"name": "Glow", "kind": "principled", "color": WHITE, "emission_strength": 1.0}
    with pytest.raises(S.SceneError, match=r"materials\[0\] \('Glow'\): zero-area emitter"):
        make_scene([(collapsed, tri, 0)], [glowing], camera())
    # Without emission a principled surface is not an emitter, and a degenerate one is no error.
    make_scene([(collapsed, tri, 0)], [dict(glowing, emission_strength=0.0)], camera())


def test_not_a_scene_file(tmp_path):
    junk = tmp_path / "junk.snell"
    junk.write_bytes(b"hello")
    with pytest.raises(S.SceneError, match="not a Snell scene file"):
        S.load(str(junk))
    with pytest.raises(S.SceneError, match="no such file"):
        S.load(str(tmp_path / "missing.snell"))


def test_failed_save_leaves_nothing(tmp_path, good):
    sc, _ = good
    broken = sc.with_render()
    broken.materials = [dict(sc.materials[0], kind="velvet"), sc.materials[1]]
    target = tmp_path / "out.snell"
    with pytest.raises(S.SceneError):
        S.save(broken, str(target))
    assert list(tmp_path.iterdir()) == [tmp_path / "good.snell"]


def test_orthographic_clip_range_may_start_behind_but_not_be_empty():
    cam = camera(clip_start=-5.0, clip_end=5.0)
    cam.update(type="ORTHO", ortho_scale=2.0)
    S._check_camera(cam)                              # the viewport's orthographic views
    with pytest.raises(S.SceneError, match="camera.clip_start: must be > 0"):
        S._check_camera({**cam, "type": "PERSP"})
    with pytest.raises(S.SceneError, match="camera.clip_end: must be greater"):
        S._check_camera({**cam, "clip_start": 3.0, "clip_end": 2.0})
    with pytest.raises(S.SceneError, match="camera.ortho_scale: must be > 0"):
        S._check_camera({**cam, "ortho_scale": 0.0})


def test_aperture_radius_follows_cycles():
    cam = camera(lens=50.0, dof={"use_dof": True, "fstop": 2.5})
    assert S.aperture_radius(cam) == pytest.approx(0.05 / 5.0)
    # Cycles' orthographic aperture: 1 / (2 f-stop) in scene units, whatever the lens.
    assert S.aperture_radius({**cam, "type": "ORTHO"}) == pytest.approx(1.0 / 5.0)
    cam["dof"]["use_dof"] = False
    assert S.aperture_radius(cam) == 0.0
