"""Where a scene's noise comes from, and what adaptive sampling's samples cost (README, Adaptive
sampling).

    python tools/measure_noise_sources.py [SCENE.blend] [--spp 128] [--threshold 0.01] [--cap 1024]
                                          [--black-above Z]

1. Fixed-sample renders with max depth 1 (direct light), 2, 3, 4, 6 and the scene's own. For
   each: the per-sample variance in relMSE units (mean over pixels and channels of
   var / (R^2 + eps), R the deepest render's image, eps the compare rule's) times the samples,
   the share of it in the noisiest 1% of pixels, the image mean and rays per sample. What a
   depth adds to the variance is the noise its bounce brings. With --black-above Z, the same
   again with every non-emissive triangle wholly above height Z black: what the light those
   surfaces reflect adds to the image and to its noise.
2. An adaptive render at the threshold, then a fixed one at its mean samples: rays and seconds
   per sample of each (adaptive sampling spends its samples where paths are longer or shorter).

The variances are the camera paths' (the light tracer's splats are not in them).
"""
from __future__ import annotations

import argparse
import dataclasses

import numpy as np


def render(scene, threads, **settings):
    """A render of the scene with these render settings."""
    from snell.tracer.integrator import Renderer
    return Renderer(scene, scene.settings(threads=threads, **settings)).render()


def by_depth(scene, depths, spp, threads):
    """Print each max depth's variance figures (module docstring, part 1)."""
    from snell.validation.metrics import RELMSE_EPS

    results = {d: render(scene, threads, spp=spp, max_depth=d, noise_threshold=0.0)
               for d in depths}
    reference = results[depths[-1]].sum.reshape(-1, 3) / spp
    weight = 1.0 / (reference * reference + RELMSE_EPS)
    for depth, r in results.items():
        mean = r.sum.reshape(-1, 3) / spp
        var = np.maximum(r.sum_sq.reshape(-1, 3) / spp - mean * mean, 0.0) * spp / (spp - 1)
        per_pixel = (var * weight).mean(axis=1)
        top = np.sort(per_pixel)[::-1][:max(1, per_pixel.size // 100)].sum() / per_pixel.sum()
        print(f"  max depth {depth}: variance relMSE x spp {per_pixel.mean():.3f}, noisiest 1% of "
              f"pixels {100 * top:.0f}% of it, image mean {mean.mean():.4f}, "
              f"{r.rays / spp / per_pixel.size:.2f} rays/sample, {r.time_s:.1f} s")


def blackened_above(scene, z):
    """The scene with every non-emissive triangle wholly above height z black, and how many."""
    above = (scene.positions[scene.triangles][:, :, 2] > z).all(axis=1)
    lit = np.array([m["kind"] != "emission" for m in scene.materials])[scene.material_ids]
    black = {"name": "black", "kind": "diffuse", "color": [0.0, 0.0, 0.0]}
    return dataclasses.replace(
        scene, materials=scene.materials + [black],
        material_ids=np.where(above & lit, len(scene.materials), scene.material_ids)), \
        int((above & lit).sum())


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("scene", nargs="?", default="scenes/cornell_dragon.blend")
    parser.add_argument("--spp", type=int, default=128)
    parser.add_argument("--threshold", type=float, default=0.01)
    parser.add_argument("--cap", type=int, default=1024)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--black-above", type=float, default=None)
    args = parser.parse_args()
    from snell.addon.export import export_blend
    from snell.tracer.integrator import warm_up

    warm_up()
    scene, _ = export_blend(args.scene)
    depths = sorted(d for d in {1, 2, 3, 4, 6, scene.render["max_depth"]}
                    if d <= scene.render["max_depth"])
    print(f"{args.scene}: fixed {args.spp} spp, {args.threads} threads")
    by_depth(scene, depths, args.spp, args.threads)
    if args.black_above is not None:
        black, count = blackened_above(scene, args.black_above)
        print(f"with the {count} triangles above z = {args.black_above} black:")
        by_depth(black, depths, args.spp, args.threads)

    adaptive = render(scene, args.threads, spp=args.cap, noise_threshold=args.threshold)
    taken = int(adaptive.sample_count.sum())
    fixed = render(scene, args.threads, spp=max(1, round(taken / adaptive.sample_count.size)),
                   noise_threshold=0.0)
    for label, r, n in (("adaptive", adaptive, taken),
                        ("fixed", fixed, fixed.spp * fixed.width * fixed.height)):
        print(f"  {label:8s} {n / (r.width * r.height):6.1f} spp mean: {r.rays / n:.2f} rays/sample,"
              f" {1e6 * r.time_s / n:.2f} us/sample, {r.time_s:.1f} s")


if __name__ == "__main__":
    main()
