"""Stored Cycles references (tests/support/cycles_reference.py): a file read back gives the
CyclesResult that was written (the per-seed images to float16's rounding, far below their noise;
the pixels every seed rendered alike exactly), a file from another Blender version is not used,
and the key changes with what Cycles renders and with nothing else."""
import copy

import numpy as np
import pytest

from snell.validation.cycles import CyclesResult
from support import cycles_reference as cr
from support.builders import icosphere, tiny_scene


def _result(rng, shape=(4, 6, 3), scale=1.0):
    images = [(scale * rng.random(shape)).astype(np.float32) for _ in range(8)]
    for k, image in enumerate(images):
        image[0, :2] = 15.3                 # a lamp seen directly: every seed renders 15.3
        image[0, 2] = 15.3 + 2e-6 * k       # seeds that differ in their last bits
    images = [im.astype(np.float64) for im in images]
    stack = np.stack(images)
    return CyclesResult(stack.mean(0), stack.var(0, ddof=1) / len(stack), 64, list(range(1, 9)), 1.5,
                        [("cycles.samples", 8, "per seed")], images)


@pytest.fixture
def blender_501(monkeypatch):
    monkeypatch.setattr(cr, "blender_version", lambda: [5, 0, 1])


def test_a_stored_reference_reads_back_as_rendered(tmp_path, blender_501):
    cyc = _result(np.random.default_rng(0), (32, 32, 3))
    path = str(tmp_path / "references" / "key.npz")
    cr.save_cycles(path, cyc)
    back = cr.load_cycles(path)
    assert (back.spp, back.seeds, back.time_s, back.settings) == (cyc.spp, cyc.seeds, cyc.time_s, cyc.settings)
    # float16: every value to half a unit in the last place (2^-11 relative; 2^-25 absolute
    # below float16's normal range) ...
    for a, b in zip(back.images, cyc.images):
        assert np.allclose(a, b, rtol=2.0 ** -11, atol=2.0 ** -25)
    # ... which leaves the statistics where they were: means to 1e-3 of their standard error,
    # variances to 1 % (uniform noise of 0.3 relative, 8 seeds)
    se = np.sqrt(cyc.variance_of_mean)
    noisy = se > 0
    assert np.abs(back.mean - cyc.mean)[noisy].max() < 1e-3 * se[noisy].max()
    assert np.allclose(back.variance_of_mean[noisy], cyc.variance_of_mean[noisy], rtol=0.01)
    # pixels every seed rendered alike are exact (the validator holds them to Snell's exactly)
    assert np.all(back.mean[0, :2] == 15.3 * np.ones(1, np.float32)) and np.all(back.variance_of_mean[0, :2] == 0)
    # and so are pixels of little noise, whose float16 rounding would move their mean by many
    # standard errors (15.3 +- 1e-6 rounds to 15.3 +- 0.004)
    assert all(np.array_equal(a[0, 2], b[0, 2]) for a, b in zip(back.images, cyc.images))


def test_images_float16_cannot_hold_are_stored_as_float32(tmp_path, blender_501):
    cyc = _result(np.random.default_rng(2), scale=1e5)
    path = str(tmp_path / "key.npz")
    cr.save_cycles(path, cyc)
    back = cr.load_cycles(path)
    assert all(np.array_equal(a, b) for a, b in zip(back.images, cyc.images))


def test_a_reference_from_another_blender_is_not_used(tmp_path, monkeypatch, blender_501):
    path = str(tmp_path / "key.npz")
    cr.save_cycles(path, _result(np.random.default_rng(1)))
    monkeypatch.setattr(cr, "blender_version", lambda: [5, 1, 0])
    assert cr.load_cycles(path) is None
    assert cr.load_cycles(str(tmp_path / "missing.npz")) is None


SETTINGS = {"spp": 256, "max_depth": 2, "seed": 0, "camera": {"resolution_percentage": 25},
            "n_seeds": 8}


def _sphere_scene():
    """tiny_scene with a smooth-shaded sphere added (normals) and texture coordinates."""
    scene = tiny_scene()
    pos, tri, nrm = icosphere(1, radius=0.5, center=(0.0, 1.0, -1.5))
    other = copy.copy(scene)
    n = len(scene.positions)
    other.positions = np.concatenate([scene.positions, pos]).astype(np.float32)
    other.triangles = np.concatenate([scene.triangles, tri + n]).astype(np.int32)
    other.normals = np.concatenate([np.tile([0.0, 0.0, 1.0], (n, 1)), nrm]).astype(np.float32)
    other.material_ids = np.zeros(len(other.triangles), np.int32)
    other.object_ids = np.concatenate([scene.object_ids, np.ones(len(tri), np.int32)])
    other.objects = scene.objects + [{"name": "Sphere", "closed": True}]
    coords = np.random.default_rng(0).random((len(other.triangles), 3, 3)).astype(np.float32)
    other.texcoords = [{"kind": "uv", "name": "", "coords": coords}]
    return other


def _key(scene, settings=SETTINGS, cycles_only=None):
    return cr.reference_key(scene, settings, cycles_only or {"scene": {"light_tree": True}})


def test_the_key_ignores_what_cycles_does_not_render(blender_501):
    scene = _sphere_scene()
    key = _key(scene)
    # Snell-only render settings (the Cycles settings carry spp, max depth and seed)
    assert _key(scene.with_render(fresnel="schlick", spp=7, max_depth=5)) == key
    # where the .blend was written, and the triangles' order and first corners (Blender numbers
    # them differently from one build to the next), smooth normals to the last bit
    other = copy.copy(scene)
    other.source = "/tmp/elsewhere/x.blend"
    order = np.random.default_rng(3).permutation(len(scene.triangles))
    other.triangles = np.roll(scene.triangles[order], 1, axis=1)
    other.material_ids, other.object_ids = scene.material_ids[order], scene.object_ids[order]
    other.texcoords = [{**tc, "coords": np.roll(tc["coords"][order], 1, axis=1)} for tc in scene.texcoords]
    other.normals = scene.normals * np.float32(1 + 1e-7)
    assert _key(other) == key


def test_the_key_changes_with_what_cycles_renders(blender_501):
    scene = _sphere_scene()
    key = _key(scene)
    changed = {
        "spp": _key(scene, {**SETTINGS, "spp": 512}),
        "seeds": _key(scene, {**SETTINGS, "n_seeds": 16}),
        "camera override": _key(scene, {**SETTINGS, "camera": {"resolution_percentage": 50}}),
        "cycles-only setting": _key(scene, cycles_only={"scene": {"light_tree": False}}),
    }
    other = copy.copy(scene)
    other.materials = [dict(scene.materials[0], strength=2.5)]
    changed["material"] = _key(other)
    other = copy.copy(scene)
    other.positions = scene.positions * np.float32(1.01)
    changed["geometry"] = _key(other)
    other = copy.copy(scene)
    other.triangles = scene.triangles[:, ::-1].copy()
    changed["winding"] = _key(other)
    other = copy.copy(scene)
    other.normals = None
    changed["flat shading"] = _key(other)
    other = copy.copy(scene)
    other.normals = scene.normals.copy()
    other = copy.copy(scene)
    other.texcoords = [{**tc, "coords": tc["coords"] + np.float32(0.01)} for tc in scene.texcoords]
    changed["texture coordinates"] = _key(other)
    changed["camera"] = _key(scene.with_camera(lens=35.0))
    same = [name for name, k in changed.items() if k == key]
    assert not same
    assert len(set(changed.values())) == len(changed)


def test_a_stored_reference_is_not_used_for_other_smooth_normals(tmp_path, blender_501):
    """Normals differ in their last bits from one build of a scene to the next, so the key holds
    only which corners are smooth; the stored file holds their moments, checked on loading."""
    scene = _sphere_scene()
    path = str(tmp_path / "key.npz")
    cr.save_cycles(path, _result(np.random.default_rng(4)), cr.normal_moments(scene))
    assert cr.load_cycles(path, cr.normal_moments(scene)) is not None
    rebuilt = copy.copy(scene)
    rebuilt.normals = scene.normals * np.float32(1 + 1e-7)
    assert cr.load_cycles(path, cr.normal_moments(rebuilt)) is not None
    edited = copy.copy(scene)
    edited.normals = scene.normals.copy()
    edited.normals[-1] = [0.6, 0.0, 0.8]           # one smooth normal turned, still smooth
    assert _key(edited) == _key(scene)
    assert cr.load_cycles(path, cr.normal_moments(edited)) is None
