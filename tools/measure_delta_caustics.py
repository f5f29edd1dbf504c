#!/usr/bin/env python3
"""Snell's caustic from a point lamp of radius 0 against Cycles: with its shadow caustics
(manifold next-event estimation) and, as an unbiased check, its plain path tracer with a lamp of
radius 5 mm (whose caustic it finds by BSDF sampling, slowly).

    .venv/bin/python tools/measure_delta_caustics.py [--mnee-spp 1024] [--plain-spp 4096]
        [--snell-spp 1024]

The scene is tests/validation/test_caustics_compare.py's (a smooth glass sphere over a white
floor, 48x48, max depth 4). Prints, for the caustic region (pixels where Snell's light tracer
carries at least 10%), its focus (pixels brighter than 1) and the rest of it, and the pixels
outside: each image's mean, the ratio and the z of the difference (per-pixel variances from
Snell's 16 batches and Cycles' 8 seeds; Cycles' plain path tracer's variance is heavy-tailed and
its z says little).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
for folder in ("tests", "scenes", os.path.join("tests", "validation")):
    sys.path.insert(0, os.path.join(ROOT, folder))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mnee-spp", type=int, default=1024)
    parser.add_argument("--plain-spp", type=int, default=4096)
    parser.add_argument("--snell-spp", type=int, default=1024)
    parser.add_argument("--out", default="/tmp")
    args = parser.parse_args(argv)
    import bpy
    import test_caustics_compare as scenes
    from snell.tracer.integrator import Renderer
    from snell.validation import compare

    def cycles(blend, spp):
        scene, _ = compare.load_snell_scene(blend)
        start = time.perf_counter()
        result = compare.cycles_render(blend, spp=spp, max_depth=scene.render["max_depth"],
                                       seed=0, n_seeds=8)
        print(f"Cycles {os.path.basename(blend)} {spp} spp: {time.perf_counter() - start:.1f} s")
        return np.stack(result.images), scene

    mnee, scene = cycles(scenes.build_point_mnee(os.path.join(args.out, "mnee.blend")),
                         args.mnee_spp)
    blend = scenes.build_point_mnee(os.path.join(args.out, "plain.blend"), mnee=False)
    bpy.ops.wm.open_mainfile(filepath=blend)
    bpy.data.lights["Point"].shadow_soft_size = 0.005
    bpy.ops.wm.save_mainfile(filepath=blend)
    plain, _ = cycles(blend, args.plain_spp)
    snell = Renderer(scene, scene.settings(spp=args.snell_spp, sampler="independent",
                                           batches=16)).render()
    images, light = np.stack(snell.batch_images), np.stack(snell.light_batch_images)

    def estimate(x):
        return x.mean(axis=0), x.var(axis=0, ddof=1) / len(x)

    (sm, sv), (mm, mv), (pm, pv) = estimate(images), estimate(mnee), estimate(plain)
    share = light.mean(axis=0).sum(axis=2) / np.maximum(sm.sum(axis=2), 1e-12)
    region = share >= 0.1
    focus = region & (sm.mean(axis=2) > 1.0)

    def row(label, a, va, b, vb, mask):
        n = mask.sum()
        z = (a[mask].sum() - b[mask].sum()) / n / np.sqrt((va[mask].sum() + vb[mask].sum())) * n
        print(f"  {label:28s} {a[mask].mean():8.4f} {b[mask].mean():8.4f} "
              f"ratio {b[mask].mean() / a[mask].mean():6.3f} z {z:7.1f}")

    for name, mask in (("caustic region", region), ("focus", focus),
                       ("rest of the region", region & ~focus), ("outside", ~region)):
        print(f"{name} ({mask.sum()} pixels): Snell, Cycles, Cycles / Snell, z")
        row("Cycles MNEE", sm, sv, mm, mv, mask)
        row("Cycles plain, 5 mm lamp", sm, sv, pm, pv, mask)
    return 0


if __name__ == "__main__":
    sys.exit(main())
