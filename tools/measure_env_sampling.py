"""Noise of an HDRI-lit scene with and without the environment's importance sampling, at equal
time (README, Image-based lighting). Renders the test HDRI spheres scene (tests/support/hdri.py,
tests/validation/test_environment_compare.py) with Snell: a reference at many samples, then both samplers
at a ladder of sample counts, and reports relMSE (the compare rule) against wall time.

    python tools/measure_env_sampling.py [--scale 200] [--ref-spp 8192]
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
# tests/ (the support package), the test module and scenes/ (what tests/conftest.py puts on the path)
sys.path[:0] = [os.path.join(os.path.dirname(HERE), *p) for p in
               (("tests",), ("tests", "validation"), ("scenes",))]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--scale", type=int, default=200)
    parser.add_argument("--ref-spp", type=int, default=8192)
    parser.add_argument("--spp", default="16,32,64,128")
    args = parser.parse_args()
    from support import hdri
    import test_environment_compare as spheres
    from snell.validation.compare import load_snell_scene
    from snell.validation.metrics import relmse
    from snell.tracer.integrator import Renderer
    tmp = tempfile.mkdtemp()
    exr = hdri.write_exr(os.path.join(tmp, "sky.exr"), hdri.sky())
    scene, _ = load_snell_scene(spheres.build_spheres(os.path.join(tmp, "spheres.blend"), exr))
    scene = scene.with_camera(resolution_percentage=args.scale).with_render(noise_threshold=0.0)
    reference = Renderer(scene, scene.settings(spp=args.ref_spp, seed=99, threads=2)).render()
    ref = reference.mean().astype(np.float64)
    print(f"reference {args.ref_spp} spp, {reference.time_s:.1f} s")
    rows = {}
    for label, env_sampling in (("importance", True), ("uniform", False)):
        for spp in map(int, args.spp.split(",")):
            renderer = Renderer(scene, scene.settings(spp=spp, threads=2,
                                                      env_sampling=env_sampling))
            start = time.perf_counter()
            result = renderer.render()
            wall = time.perf_counter() - start
            err = relmse(result.mean().astype(np.float64), ref)
            rows.setdefault(label, []).append((spp, wall, err))
            print(f"{label:10s} {spp:5d} spp {wall:6.2f} s relMSE {err:.5f} "
                  f"relMSE x time {err * wall:.5f}")
    imp = np.array(rows["importance"])
    uni = np.array(rows["uniform"])
    # relMSE x time is flat in the sample count (slope -1); its ratio is the relMSE ratio at
    # equal time.
    gain = np.median(uni[:, 1] * uni[:, 2]) / np.median(imp[:, 1] * imp[:, 2])
    print(f"relMSE at equal time, uniform / importance: {gain:.2f}")


if __name__ == "__main__":
    main()
