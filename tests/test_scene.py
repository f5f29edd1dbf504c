"""The scene file: round trips, and every kind of bad data rejected with the field named."""
import json

import numpy as np
import pytest

from builders import camera, icosphere, make_scene, quad
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
    assert back.features() == {"glass": True, "mirrors": False, "depth_of_field": False,
                               "environment": False, "emissive_meshes": True}


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
    (dict(header=_set(["render", "fresnel"], "fast")), "render.fresnel"),
    (dict(header=_set(["world", "color"], [0, -1, 0])), "world.color"),
    (dict(header=_set(["render", "noise_threshold"], -0.01)), "render.noise_threshold: must be >= 0"),
    (dict(header=_set(["render", "noise_threshold"], float("nan"))), "render.noise_threshold: is NaN"),
    (dict(header=_set(["render", "noise_threshold"], "low")), "render.noise_threshold: expected a number"),
    (dict(header=_set(["render", "min_spp"], -1)), "render.min_spp: expected an integer"),
    (dict(header=_set(["render", "min_spp"], 2.5)), "render.min_spp: expected an integer"),
    (dict(header=_set(["render", "min_spp"], True)), "render.min_spp: expected an integer"),
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
    with pytest.raises(S.SceneError, match="positions: vertex 5 is NaN or Inf"):
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


def test_aperture_radius_follows_cycles():
    cam = camera(lens=50.0, dof={"use_dof": True, "fstop": 2.5})
    assert S.aperture_radius(cam) == pytest.approx(0.05 / 5.0)
    cam["dof"]["use_dof"] = False
    assert S.aperture_radius(cam) == 0.0
