#!/usr/bin/env python3
"""Photon merging (tracer/photon_merging.py) on the pool and the tumbler (tests/support/
sds_scenes.py): the path-traced references and the error of merged renders against them.

    .venv/bin/python tools/measure_photon_merging.py reference [--scene pool] [--spp 131072]
        [--seed 1] [--merge-with FILE]
    .venv/bin/python tools/measure_photon_merging.py measure [--scene pool] [--spp-per-pass 16]
        [--passes 1,4,16,64] [--seeds 4] [--light-paths 1.0] [--alpha 0.6667] [--radius 0]

Scenes: pool, tumbler, and the pool under a sun (pool_sun) or an area lamp (pool_area) instead of
its round lamp. `reference` renders Snell's own hybrid (path tracer and light tracer, merging
off: unbiased) at 16x16 with 16 independent batches and writes the mean and the variance of the
mean to tests/references/sds_<scene>.npz (--merge-with adds an earlier file's samples, weighted by
their spp). `measure` renders K passes of --spp-per-pass samples each, merging on and off, over
several seeds, and prints per K the relative RMSE against the reference (the reference's own
variance taken out), over the image and over the caustic region (where light paths carry at
least 10% of a long merged render), the image mean's ratio to the reference's and the time.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESOLUTION = (16, 16)
# The pool_sun reference's sun (radians): wide enough for the path tracer to find it through
# the water (tests/render/test_mnee.py holds manifold next-event estimation against it).
POOL_SUN_ANGLE = 0.2


def scene_of(name):
    """The scene builder of a name (tests/support/sds_scenes.py)."""
    sys.path[:0] = [os.path.join(ROOT, "tests"), os.path.join(ROOT, "scenes")]
    from support import sds_scenes
    lamp = {"pool_sun": sds_scenes.pool_sun(POOL_SUN_ANGLE),
            "pool_area": sds_scenes.pool_area()}.get(name)
    if lamp:
        return sds_scenes.pool(resolution=RESOLUTION, lamp=lamp)
    return {"pool": sds_scenes.pool, "tumbler": sds_scenes.tumbler}[name](resolution=RESOLUTION)


def reference_path(name):
    return os.path.join(ROOT, "tests", "references", f"sds_{name}.npz")


def make_reference(args):
    from snell.tracer.integrator import Renderer
    scene = scene_of(args.scene)
    start = time.perf_counter()
    settings = scene.settings(spp=args.spp, batches=16, threads=args.threads, noise_threshold=0.0,
                              sampler="independent", seed=args.seed)
    result = Renderer(scene, settings).render()
    mean, var, spp = result.mean().astype(np.float64), result.variance_of_mean(), args.spp
    if args.merge_with:
        old = np.load(args.merge_with)
        w_old, w_new = float(old["spp"]), float(spp)
        total = w_old + w_new
        mean = (w_old * old["mean"] + w_new * mean) / total
        var = (w_old ** 2 * old["var"] + w_new ** 2 * var) / total ** 2
        spp = int(total)
    np.savez_compressed(reference_path(args.scene), mean=mean.astype(np.float32),
                        var=var.astype(np.float32), spp=spp)
    rel = np.sqrt(var[..., 0].sum()) / mean[..., 0].sum()
    print(f"{args.scene}: {spp} spp, image mean {mean.mean():.5f} (relative standard error "
          f"{rel:.5f}), {time.perf_counter() - start:.0f} s")


def measure(args):
    from snell.tracer import photon_merging
    from snell.tracer.integrator import Renderer
    if args.alpha is not None:
        radius = photon_merging.radius
        photon_merging.radius = lambda r1, i: radius(r1, i, args.alpha)
    ref = np.load(reference_path(args.scene))
    reference, ref_var = ref["mean"][..., 0].astype(float), ref["var"][..., 0].astype(float)
    scene = scene_of(args.scene)
    # The caustic region: where light paths (the light tracer's splats and the merged photons)
    # carry at least 10% of a long merged render, as `snell bench` picks its caustic region.
    probe = Renderer(scene, scene.settings(spp=1024, threads=args.threads, noise_threshold=0.0,
                                           seed=99, photon_merging="on",
                                           light_paths_per_camera_path=args.light_paths)).render()
    region = probe.light_image()[..., 0] >= 0.1 * probe.mean()[..., 0]
    print(f"caustic region: {int(region.sum())} of {region.size} pixels")
    for merging in ("on", "off"):
        for k in (int(x) for x in args.passes.split(",")):
            errors, region_errors, ratios, start = [], [], [], time.perf_counter()
            for seed in range(args.seeds):
                settings = scene.settings(spp=k * args.spp_per_pass, batches=k,
                                          threads=args.threads, noise_threshold=0.0, seed=seed,
                                          photon_merging=merging, merge_radius=args.radius,
                                          light_paths_per_camera_path=args.light_paths)
                image = Renderer(scene, settings).render().mean()[..., 0].astype(float)
                errors.append(np.mean((image - reference) ** 2) - ref_var.mean())
                region_errors.append(np.mean((image - reference)[region] ** 2)
                                     - ref_var[region].mean())
                ratios.append(image.mean() / reference.mean())
            print(f"merging {merging:3} passes {k:4d}: relative RMSE "
                  f"{np.sqrt(max(np.mean(errors), 0.0)) / reference.mean():.4f}, in the caustic "
                  f"region "
                  f"{np.sqrt(max(np.mean(region_errors), 0.0)) / reference[region].mean():.4f}"
                  f", mean / "
                  f"reference {np.mean(ratios):.4f}, "
                  f"{(time.perf_counter() - start) / args.seeds:.2f} s a render", flush=True)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    ref = sub.add_parser("reference")
    ref.add_argument("--scene", default="pool")
    ref.add_argument("--spp", type=int, default=131072)
    ref.add_argument("--seed", type=int, default=1)
    ref.add_argument("--threads", type=int, default=1)
    ref.add_argument("--merge-with")
    mea = sub.add_parser("measure")
    mea.add_argument("--scene", default="pool")
    mea.add_argument("--spp-per-pass", type=int, default=16)
    mea.add_argument("--passes", default="1,4,16,64")
    mea.add_argument("--seeds", type=int, default=4)
    mea.add_argument("--light-paths", type=float, default=1.0)
    mea.add_argument("--alpha", type=float)
    mea.add_argument("--radius", type=float, default=0.0, help="first radius (0: automatic)")
    mea.add_argument("--threads", type=int, default=2)
    args = parser.parse_args(argv)
    (make_reference if args.command == "reference" else measure)(args)


if __name__ == "__main__":
    main()
