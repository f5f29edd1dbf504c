"""The default scenes render the same images as when tests/references/images.npz was written: a
refactor that should change no pixel is held to that, bit for bit.

Each default scene (scenes/*.blend) renders at 12% (31x31 of 256x256) in three modes that together run every
scheduler and optional stage (fixed samples with the light tracer and light vertices, batches of
the independent sampler, adaptive sampling with the light-vertex pilot). On the machine the file
was written on (same CPU name and features, so the same compiled code) the images must be equal
bit for bit. Elsewhere the compiled code may round differently (fused multiply-adds), which can
flip a Russian roulette or a light pick in a few pixels: there the test asks for the same image
within rounding, which a changed formula or sample still fails.

A change that is meant to change pixels rewrites the file:
    SNELL_IMAGE_REFERENCES=write .venv/bin/python -m pytest tests/render/test_image_regression.py
"""
import glob
import hashlib
import json
import os

import numpy as np
import pytest

from support.paths import ROOT, TESTS

PATH = os.path.join(TESTS, "references", "images.npz")
PERCENT = 12                   # 31x31 of the default scenes' 256x256
SEED = 3
MODES = {
    "fixed": {"spp": 8, "noise_threshold": 0.0},
    "batches": {"sampler": "independent", "spp": 8, "batches": 4},
    "adaptive": {"spp": 32, "noise_threshold": 0.05, "min_spp": 8},
}
# Elsewhere: the share of pixels that may differ by more than rounding, and the bound on the
# whole image's relative change.
FLIPPED_PIXELS = 0.02
IMAGE_CHANGE = 1e-3


def _machine() -> str:
    """The CPU the kernels were compiled for: equal names and features give equal code."""
    import llvmlite.binding as llvm
    return f"{llvm.get_host_cpu_name()} {llvm.get_host_cpu_features().flatten()}"


def _geometry(scene) -> str:
    """A hash of the scene's geometry arrays, which a scene script must build the same every time."""
    digest = hashlib.sha256()
    for array in (scene.positions, scene.triangles, scene.normals, scene.material_ids):
        digest.update(np.ascontiguousarray(array).data)
    return digest.hexdigest()[:16]


def _blends() -> list:
    return sorted(glob.glob(os.path.join(ROOT, "scenes", "*.blend")))


@pytest.fixture(scope="module")
def images() -> dict:
    """Every (scene, mode) image rendered now, keyed "scene/mode", and each scene's geometry hash
    under "scene/geometry"."""
    pytest.importorskip("bpy")
    from snell.addon.export import export_blend
    from snell.tracer.integrator import Renderer
    blends = _blends()
    if not blends:
        pytest.skip("no scenes/*.blend: build them with scenes/build_all.py (tools/bootstrap.sh)")
    out = {}
    for blend in blends:
        scene, _ = export_blend(blend)
        out[f"{os.path.basename(blend)[:-6]}/geometry"] = _geometry(scene)
        scene = scene.with_camera(resolution_percentage=PERCENT).with_render(seed=SEED)
        for mode, settings in MODES.items():
            result = Renderer(scene, scene.settings(threads=2, **settings)).render()
            out[f"{os.path.basename(blend)[:-6]}/{mode}"] = result.mean().astype(np.float32)
    return out


def _stored() -> tuple[dict, dict]:
    with np.load(PATH) as f:
        meta = json.loads(str(f["meta"]))
        return {key: f[key] for key in f.files if key != "meta"}, meta


def test_images_are_unchanged(images):
    geometry = {k: v for k, v in images.items() if k.endswith("/geometry")}
    images = {k: v for k, v in images.items() if k not in geometry}
    if os.environ.get("SNELL_IMAGE_REFERENCES") == "write":
        np.savez_compressed(PATH, meta=json.dumps({"machine": _machine(), "geometry": geometry}),
                            **images)
        pytest.skip(f"wrote {PATH}")
    stored, meta = _stored()
    assert sorted(stored) == sorted(images), "the default scenes or modes changed: rewrite the file"
    # A different build of a scene renders different pixels for a reason that is not the tracer's.
    rebuilt = sorted(k[:-9] for k, v in geometry.items() if meta["geometry"].get(k) != v)
    assert not rebuilt, (f"scenes/{{{','.join(rebuilt)}}}.blend are not the scenes the images were "
                         "rendered from: a scene script changed or builds differently each time")
    machine = meta["machine"]
    exact = machine == _machine()
    changed = []
    for key, image in images.items():
        old = stored[key]
        if exact:
            if not np.array_equal(image, old):
                changed.append(f"{key}: {int((image != old).any(-1).sum())} pixels differ")
            continue
        diff = np.abs(image.astype(np.float64) - old)
        flipped = (diff > 1e-5 * (1.0 + np.abs(old))).any(-1).mean()
        relative = diff.sum() / max(np.abs(old).sum(), 1e-30)
        if flipped > FLIPPED_PIXELS or relative > IMAGE_CHANGE:
            changed.append(f"{key}: {flipped:.1%} of pixels changed, image by {relative:.2e}")
    assert not changed, ("images changed (SNELL_IMAGE_REFERENCES=write rewrites the file if that "
                         "is meant): " + "; ".join(changed))
