"""Time the default scene in Snell and in Cycles with matched settings, in one process.

    .venv/bin/python tools/measure_default.py [SCENE.blend] [--spp 64] [--max-depth 8] [--runs 3]

Prints medians over the runs: wall time (export and BVH build reported apart), rays per second,
Embree's share of the render's thread time, and Cycles' render time for the same samples.
"""
import argparse
import statistics
import time

from snell.validation.cycles import render_seeds
from snell.addon.export import export_blend
from snell.tracer.integrator import Renderer


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default="scenes/cornell_spheres.blend")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    snell_t, build_t, export_t, rays, share, cycles_t = [], [], [], [], [], []
    for _ in range(args.runs):
        start = time.perf_counter()
        scene, _ = export_blend(args.scene)
        export_t.append(time.perf_counter() - start)
        renderer = Renderer(scene, scene.settings(spp=args.spp, max_depth=args.max_depth,
                                                  threads=args.threads))
        result = renderer.render()
        build_t.append(renderer.build_s)
        snell_t.append(result.time_s)
        rays.append(result.rays_per_second)
        share.append(result.embree_share)
        cyc = render_seeds(args.scene, spp=args.spp, max_depth=args.max_depth, seeds=(1, 2),
                           threads=args.threads)
        cycles_t.append(cyc.time_s / 2)
    med = statistics.median
    w, h = result.width, result.height
    print(f"{args.scene}: {w}x{h}, {args.spp} spp, max depth {args.max_depth}, {args.threads} threads, "
          f"median of {args.runs}")
    print(f"  snell  render {med(snell_t):.2f} s (export {med(export_t):.2f} s, build {med(build_t):.2f} s), "
          f"{med(rays) / 1e6:.2f} Mrays/s, Embree {100 * med(share):.0f}% of thread time, "
          f"NaN/Inf {result.nan_count}")
    print(f"  cycles render {med(cycles_t):.2f} s")
    print(f"  ratio snell / cycles {med(snell_t) / med(cycles_t):.2f}")


if __name__ == "__main__":
    main()
