"""A Cycles reference rendered once, and Snell renders compared against it (the validator's
statistics, snell.validation.compare), shared by the tests that hold scenes against Cycles.

Stored references (Mitsuba 3's test_renders.py pattern): `tools/make_cycles_references.py`
renders the references the tests use into tests/references/<key>.npz (the per-seed images, their
seeds and times). A Reference loads its file when one is there for the same Blender version
(bpy.app.version), scene and Cycles settings (the key hashes all three), and renders Cycles
otherwise. SNELL_CYCLES_REFERENCES=write renders and (re)writes the files; =off ignores them.
"""
from __future__ import annotations

import hashlib
import json
import os

import numpy as np

from support.paths import TESTS

REFERENCES = os.path.join(TESTS, "references")

SPP = 256       # samples per pixel in both renderers: Cycles as 8 seeds of SPP / 8
SCALE = 25      # resolution percentage (64x64 of the reference scenes' 256x256)
SEED = 0


class Reference:
    """A Cycles reference plus the exported Snell scene at the test resolution."""

    def __init__(self, blend, dof=None, framing=None, max_depth=None, spp=SPP, cycles_seeds=8):
        from snell.validation import compare
        self.blend, self.spp = blend, spp
        scene, self.warnings = compare.load_snell_scene(blend)
        dof, framing = dict(dof or {}), dict(framing or {})
        framing = {"resolution_percentage": SCALE, **framing}
        scene = scene.with_camera(**framing).with_render(
            spp=spp, seed=SEED, max_depth=max_depth)
        if dof:
            scene = scene.with_camera(dof={"use_dof": True, **dof})
        self.scene = scene
        settings = {"spp": spp, "max_depth": scene.render["max_depth"], "seed": SEED,
                    "camera": {**dof, **framing}, "n_seeds": cycles_seeds}
        self.path = os.path.join(REFERENCES, reference_key(scene, settings) + ".npz")
        mode = os.environ.get("SNELL_CYCLES_REFERENCES", "read")
        self.cycles = load_cycles(self.path) if mode == "read" else None
        self.stored = self.cycles is not None
        if self.cycles is None:
            self.cycles = compare.cycles_render(blend, **settings)
            if mode == "write":
                save_cycles(self.path, self.cycles)

    def compare(self, modify=lambda s: s, noise_threshold=0.0, spp=None):
        """The validator's report dict for Snell (modify: a deliberate change) against Cycles."""
        from snell.validation import compare
        scene = modify(self.scene)
        result = compare.snell_render(scene, spp or self.spp, noise_threshold=noise_threshold)
        return compare.compare_renders(result, self.cycles, settings=compare.snell_settings(scene),
                                       scene=scene)


def verdict(result):
    """(verdict, the numbers an assertion message should show)."""
    detail = {k: result[k] for k in ("tests", "z_pass_fraction", "tiles_failed", "mean_z",
                                     "mean_ratio", "sharpness_z")}
    return result["verdict"], detail


def blender_version():
    import bpy
    return list(bpy.app.version)


def reference_key(scene, settings):
    """A hash of the Blender version, the Snell scene as exported (arrays and header, without the
    paths the .blend and its images were written to) and the Cycles settings."""
    header = scene.header()
    header.pop("source", None)
    for image in header["images"]:
        image.pop("source", None)
    h = hashlib.sha256(json.dumps([blender_version(), header, settings], sort_keys=True,
                                  default=str).encode())
    for array in (scene.positions, scene.triangles, scene.material_ids, scene.object_ids):
        h.update(np.ascontiguousarray(array).data)
    return h.hexdigest()[:20]


def save_cycles(path, cyc):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    meta = {"blender": blender_version(), "spp": cyc.spp, "seeds": list(cyc.seeds),
            "time_s": cyc.time_s, "settings": [list(s) for s in cyc.settings]}
    tmp = path + ".tmp.npz"
    np.savez_compressed(tmp, images=np.stack(cyc.images).astype(np.float32),
                        meta=np.array(json.dumps(meta, default=str)))
    os.replace(tmp, path)


def load_cycles(path):
    """The stored CyclesResult, or None (no file, or another Blender version)."""
    from snell.validation.cycles import CyclesResult
    if not os.path.exists(path):
        return None
    with np.load(path) as data:
        meta = json.loads(str(data["meta"]))
        if meta["blender"] != blender_version():
            return None
        stack = data["images"].astype(np.float64)
    # As cycles.render_seeds makes them: the mean and the variance of the mean over the seeds.
    return CyclesResult(stack.mean(axis=0), stack.var(axis=0, ddof=1) / len(stack), meta["spp"],
                        meta["seeds"], meta["time_s"], [tuple(s) for s in meta["settings"]],
                        list(stack))
