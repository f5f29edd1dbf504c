#!/usr/bin/env python3
"""Choose the caustics light tracer's share of the work: relMSE x time on a scene for several
numbers of light paths per camera path (tracer/settings.py LIGHT_PATHS_PER_CAMERA_PATH).

    .venv/bin/python tools/measure_caustics_split.py [SCENE.blend] [--spp 32] [--repeat 3]
        [--ratios 0,0.125,0.25,0.5,1,2] [--reference-spp 2048]

The reference is Snell's own hybrid render at --reference-spp (unbiased: the hybrid and the path
tracer agree, tests/render/test_caustics.py), so the numbers do not depend on Cycles. Ratio 0 is the
path tracer alone. Prints, per ratio, the median render time of --repeat runs, relMSE over the
image and over the caustic region (pixels where the light tracer carries at least 10% of the
reference), and both relMSE x time.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", nargs="?", default=os.path.join(ROOT, "scenes", "cornell_spheres.blend"))
    parser.add_argument("--spp", type=int, default=32)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--ratios", default="0,0.125,0.25,0.5,1,2")
    parser.add_argument("--reference-spp", type=int, default=2048)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args(argv)

    from snell.addon.export import export_blend
    from snell.validation.bench_curves import CAUSTIC_SHARE, light_share
    from snell.validation.metrics import relmse
    from snell.tracer import integrator
    from snell.tracer.integrator import Renderer

    integrator.warm_up()
    scene, _ = export_blend(args.scene)
    print(f"reference: {args.reference_spp} spp ...", file=sys.stderr, flush=True)
    ref_result = Renderer(scene, scene.settings(seed=12345, threads=args.threads,
                                                spp=args.reference_spp)).render()
    ref = ref_result.mean().astype(np.float64)
    region = light_share(ref_result.light_image(), ref) >= CAUSTIC_SHARE
    print(f"caustic region: {region.mean():.1%} of the pixels")
    print("| light paths per camera path | render s (median) | relMSE | relMSE x s | "
          "caustic relMSE | caustic relMSE x s |")
    print("| --- | --- | --- | --- | --- | --- |")
    for ratio in (float(r) for r in args.ratios.split(",")):
        times = []
        for _ in range(args.repeat):
            renderer = Renderer(scene, scene.settings(
                threads=args.threads, caustics=ratio > 0, spp=args.spp,
                light_paths_per_camera_path=max(ratio, 1e-9)))
            result = renderer.render()
            times.append(result.time_s)
        image = result.mean()
        t = statistics.median(times)
        e, ec = relmse(image, ref), relmse(image[region], ref[region])
        print(f"| {ratio:g} | {t:.2f} | {e:.4g} | {e * t:.4g} | {ec:.4g} | {ec * t:.4g} |", flush=True)


if __name__ == "__main__":
    main()
