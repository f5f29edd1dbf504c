"""Print SHA-256 digests of small renders of the default scenes, to check a refactor changes no bit.

    PYTHONPATH=... .venv/bin/python tools/image_digests.py [SCENE.blend ...] > digests.txt

For each scene (default: every .blend in scenes/) and each mode (fixed stratified samples, with and
without the light tracer and light vertices; batches of the independent sampler; adaptive
sampling), one line: the digest of the float32 image's bytes, of the float64 sums (camera sums,
sums of squares, light sums) and the image's sum. Run it before and after a change and diff the
outputs: float results may differ across CPUs, so this is a tool, not a unit test.
"""
import argparse
import glob
import hashlib
import os

import numpy as np

from snell.addon.export import export_blend
from snell.tracer.integrator import Renderer

# (name, settings): every scheduler, and the optional stages on and off.
FIXED = {"spp": 16, "noise_threshold": 0.0}
ADAPTIVE = {"spp": 64, "noise_threshold": 0.05, "min_spp": 16}
MODES = [
    ("fixed", FIXED),
    ("fixed-passes", {"spp": 100, "noise_threshold": 0.0}),   # several passes (windows)
    ("fixed-no-caustics", {**FIXED, "caustics": False}),
    ("fixed-no-vertices", {**FIXED, "light_vertices": False}),
    ("batches", {"sampler": "independent", "spp": 8, "batches": 4}),
    ("adaptive", ADAPTIVE),
    ("adaptive-no-pilot", {**ADAPTIVE, "light_vertex_pilot": False}),
]


def digest(*arrays) -> str:
    """The first 16 hex digits of the SHA-256 of the arrays' bytes (None skipped)."""
    h = hashlib.sha256()
    for a in arrays:
        if a is not None:
            h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--percent", type=int, default=25)
    args = ap.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    blends = args.scenes or sorted(glob.glob(os.path.join(root, "scenes", "*.blend")))
    if not blends:
        raise SystemExit("no .blend files: build them with scenes/build_all.py, or name them")
    for blend in blends:
        scene, _ = export_blend(blend)
        scene = scene.with_camera(resolution_percentage=args.percent).with_render(seed=3)
        for name, settings in MODES:
            result = Renderer(scene, scene.settings(threads=2, **settings)).render()
            image = result.mean()
            print(f"{os.path.basename(blend):22s} {name:18s} image {digest(image)} "
                  f"sums {digest(result.sum, result.sum_sq, result.light_sum, result.batch_sum, result.batch_sq)} "
                  f"{result.width}x{result.height} spp {result.spp} light_paths {result.light_paths} nan {result.nan_count} "
                  f"image_sum {float(image.sum(dtype=np.float64))!r}", flush=True)


if __name__ == "__main__":
    main()
