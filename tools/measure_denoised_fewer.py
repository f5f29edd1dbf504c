#!/usr/bin/env python3
"""Target (b) of the denoised bench (issue 33) at a file's own resolution: each renderer
denoised at n spp against itself undenoised at 10 n spp, FLIP against a converged reference,
and the inputs each renderer hands Open Image Denoise kept so that they can be swapped.

    tools/measure_denoised_fewer.py reference SCENE [--batches 8 --spp 256]
    tools/measure_denoised_fewer.py ladder SCENE [--renderer snell|cycles] [--n 1,2,4,8,16,32]
    tools/measure_denoised_fewer.py report SCENE [--n ...]
    tools/measure_denoised_fewer.py figure SCENE [--renderer ...] [--n ...]

`reference`: Snell's unbiased hybrid (caustics on, photon merging off, independent sampler),
in batches kept apart, so that the reference's own noise can be read from them. `ladder`: at
each n the noisy image, Denoising Albedo, Denoising Normal and denoised image (OIDN, accurate
prefilter, high quality) at n spp, and the noisy image at 10 n spp; Snell as `snell bench`
renders a point (bench.SNELL_SEED, caustics on), Cycles as the bench forces it with its own
OIDN denoiser, its passes read back from a multilayer EXR. `report`: FLIP against the
reference and the swaps (each renderer's noisy image denoised with the other's passes, and
Cycles' inputs through Snell's OIDN call, held against Cycles' own denoised image). `figure`:
the reference, the denoised image at n and the undenoised one at 10 n with their FLIP maps.
Everything runs in this process with one thread (time does not enter target (b)); the files go
to out/denoised_fewer/.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "out", "denoised_fewer")
FACTOR = 10          # bench_curves.FEWER_SAMPLES


def blend_of(scene: str) -> str:
    return os.path.join(ROOT, "scenes", f"{scene}.blend")


def reference(args):
    """Snell's reference, its batches kept."""
    from snell.addon.console import stdout_silenced
    from snell.addon.export import export_blend
    from snell.tracer.integrator import Renderer
    from snell.validation import cycles
    from snell.validation.bench import SNELL_REFERENCE_SEED
    with stdout_silenced():
        scene, _ = export_blend(blend_of(args.scene))
    scene = scene.with_render(spp=args.batches * args.spp, max_depth=8, seed=SNELL_REFERENCE_SEED)
    settings = scene.settings(threads=1, caustics=True, photon_merging="off",
                              sampler="independent", batches=args.batches, **cycles.AS_FORCED,
                              noise_threshold=0.0, min_spp=0, time_limit=0.0, denoise=False)
    result = Renderer(scene, settings).render()
    path = os.path.join(OUT, f"ref_{args.scene}.npz")
    np.savez_compressed(path, batches=np.stack(result.batch_images).astype(np.float32))
    print(f"{args.scene}: reference {args.batches} x {args.spp} spp, {result.time_s:.0f} s: {path}")


def snell_point(blend: str, spp: int, denoise: bool) -> dict:
    """Snell at spp as the bench renders a point: noisy image, and with denoise the passes and
    the denoised image."""
    from snell.addon.console import stdout_silenced
    from snell.addon.export import export_blend
    from snell.tracer.denoise import denoise_result
    from snell.tracer.integrator import Renderer
    from snell.validation import cycles
    from snell.validation.bench import SNELL_SEED
    with stdout_silenced():
        scene, _ = export_blend(blend)
    scene = scene.with_render(spp=spp, max_depth=8, seed=SNELL_SEED)
    extra = dict(denoising_input_passes="albedo_normal", denoising_prefilter="accurate",
                 denoising_quality="high") if denoise else {}
    settings = scene.settings(threads=1, caustics=True, **cycles.AS_FORCED, noise_threshold=0.0,
                              min_spp=0, time_limit=0.0, denoise=denoise,
                              denoising_passes=denoise, **extra)
    result = Renderer(scene, settings).render()
    if not denoise:
        return {"noisy": result.mean().astype(np.float32)}
    out = denoise_result(result, settings)
    if not out.denoised:
        raise RuntimeError(out.warning)
    return {"noisy": out.noisy, "albedo": out.albedo, "normal": out.normal,
            "denoised": out.image}


def cycles_point(blend: str, spp: int, denoise: bool) -> dict:
    """Cycles at spp as the bench forces it; with denoise its own OIDN denoiser and the Denoising
    Data passes."""
    from snell.addon.console import stdout_silenced
    from snell.validation import cycles
    from snell.validation.bench import CYCLES_SEED, cycles_denoised
    settings = cycles.forced_settings(8, spp, CYCLES_SEED, 1)
    if denoise:
        settings = cycles_denoised(settings, "accurate", "high") + [
            ("view_layers.cycles.denoising_store_passes", True, "the passes OIDN is given"),
            ("output", cycles.DENOISING_OUTPUT, "read back")]
    with tempfile.TemporaryDirectory(prefix="snell-fewer-") as tmp:
        path = os.path.join(tmp, "c.exr")
        with stdout_silenced(True):
            cycles._render_file(blend, settings, None, path)
        if not denoise:
            from snell.tracer.image import read_exr
            return {"noisy": read_exr(path).astype(np.float32)}
        return {key: cycles.read_pass(path, layer).astype(np.float32) for key, layer in (
            ("denoised", "Combined"), ("noisy", "Noisy Image"), ("albedo", "Denoising Albedo"),
            ("normal", "Denoising Normal"))}


def ladder(args):
    """Each n: the denoised point and the noisy point at FACTOR n, saved as they come."""
    point = snell_point if args.renderer == "snell" else cycles_point
    path = os.path.join(OUT, f"ladder_{args.scene}_{args.renderer}.npz")
    saved = dict(np.load(path)) if os.path.exists(path) else {}
    for n in args.n:
        for spp, denoise in ((n, True), (n * FACTOR, False)):
            key = f"{'dn' if denoise else 'noisy'}{spp}"
            if any(k.startswith(key + "_") for k in saved):
                continue
            start = time.perf_counter()
            for name, image in point(blend_of(args.scene), spp, denoise).items():
                saved[f"{key}_{name}"] = image
            np.savez_compressed(path, **saved)
            print(f"{args.scene} {args.renderer} {key}: {time.perf_counter() - start:.1f} s",
                  flush=True)


def flips(reference_batches: np.ndarray, image: np.ndarray) -> tuple:
    """(FLIP against the mean of all batches, FLIP against the mean of half of them)."""
    from snell.validation import metrics
    full = reference_batches.mean(axis=0)
    half = reference_batches[: len(reference_batches) // 2].mean(axis=0)
    return metrics.flip(full, image), metrics.flip(half, image)


def report(args):
    """FLIP table of target (b) for each renderer, and the swaps."""
    from snell.tracer.denoise import denoise
    from snell.validation import metrics
    ref = np.load(os.path.join(OUT, f"ref_{args.scene}.npz"))["batches"].astype(np.float64)
    full = ref.mean(axis=0)
    ladders = {}
    for renderer in ("snell", "cycles"):
        path = os.path.join(OUT, f"ladder_{args.scene}_{renderer}.npz")
        if os.path.exists(path):
            ladders[renderer] = dict(np.load(path))
    print(f"{args.scene}: reference {len(ref)} batches; FLIP (against half of them)")
    for renderer, lad in ladders.items():
        for n in args.n:
            dn, noisy = lad.get(f"dn{n}_denoised"), lad.get(f"noisy{n * FACTOR}_noisy")
            if dn is None or noisy is None:
                continue
            if renderer == "snell":      # denoised again: by this tree's call, whatever rendered it
                dn = denoise(lad[f"dn{n}_noisy"], lad[f"dn{n}_albedo"], lad[f"dn{n}_normal"],
                             "accurate", "high", 1).image
            (fd, hd), (fn, hn) = flips(ref, dn), flips(ref, noisy)
            own = metrics.flip(full, lad[f"dn{n}_noisy"])
            print(f"  {renderer:6s} n {n:3d}: denoised {fd:.4f} ({hd:.4f})  noisy at {n * FACTOR}"
                  f" {fn:.4f} ({hn:.4f})  ratio {fd / fn:.3f} ({hd / hn:.3f})  "
                  f"noisy at n {own:.4f}")
    if len(ladders) < 2:
        return
    s, c = ladders["snell"], ladders["cycles"]
    print("  swaps: FLIP of each noisy image denoised with each renderer's passes (Snell's call)")
    for n in args.n:
        if f"dn{n}_noisy" not in s or f"dn{n}_noisy" not in c:
            continue
        row = []
        for image, guides in (("snell", "snell"), ("snell", "cycles"), ("cycles", "cycles"),
                              ("cycles", "snell")):
            src, g = ladders[image], ladders[guides]
            out = denoise(src[f"dn{n}_noisy"], g[f"dn{n}_albedo"], g[f"dn{n}_normal"],
                          "accurate", "high", 1).image
            row.append(f"{image}+{guides} {metrics.flip(full, out):.4f}")
        cyc = c[f"dn{n}_denoised"]
        mine = denoise(c[f"dn{n}_noisy"], c[f"dn{n}_albedo"], c[f"dn{n}_normal"], "accurate",
                       "high", 1).image
        same = float(np.abs(mine - cyc).max() / max(float(cyc.max()), 1e-30))
        print(f"  n {n:3d}: " + "  ".join(row) + f"  | Snell's call on Cycles' inputs vs "
              f"Cycles' own: max |diff| / max {same:.2e}")


def figure(args):
    """A PNG per n: the reference, Snell denoised at n and its per-pixel FLIP map, Snell
    undenoised at FACTOR n and its map (the maps on the bench page's scale)."""
    from snell.pages.images import png_bytes, upscale
    from snell.tracer.denoise import denoise
    from snell.tracer.image import to_srgb8
    from snell.validation.bench_curves import flip_map
    from snell.validation.bench_report import flip_map_rgb, labelled_strip
    ref = np.load(os.path.join(OUT, f"ref_{args.scene}.npz"))["batches"].astype(np.float64)
    ref = ref.mean(axis=0)
    lad = dict(np.load(os.path.join(OUT, f"ladder_{args.scene}_{args.renderer}.npz")))
    for n in args.n:
        dn = (denoise(lad[f"dn{n}_noisy"], lad[f"dn{n}_albedo"], lad[f"dn{n}_normal"],
                      "accurate", "high", 1).image if args.renderer == "snell"
              else lad[f"dn{n}_denoised"])
        noisy = lad[f"noisy{n * FACTOR}_noisy"]
        maps = [flip_map(ref, dn), flip_map(ref, noisy)]
        tiles = [("reference", to_srgb8(ref)), (f"denoised {n} spp", to_srgb8(dn)),
                 (f"FLIP {maps[0].mean():.4f}", flip_map_rgb(maps[0])),
                 (f"undenoised {n * FACTOR} spp", to_srgb8(noisy)),
                 (f"FLIP {maps[1].mean():.4f}", flip_map_rgb(maps[1]))]
        path = os.path.join(OUT, f"fewer_{args.scene}_{args.renderer}_{n}.png")
        with open(path, "wb") as f:
            f.write(png_bytes(labelled_strip([(c, upscale(t, 256)) for c, t in tiles])))
        print(path)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("command", choices=("reference", "ladder", "report", "figure"))
    parser.add_argument("scene")
    parser.add_argument("--renderer", choices=("snell", "cycles"), default="snell")
    parser.add_argument("--n", default="1,2,4,8,16,32")
    parser.add_argument("--batches", type=int, default=8)
    parser.add_argument("--spp", type=int, default=256)
    args = parser.parse_args(argv)
    args.n = [int(v) for v in args.n.split(",")]
    os.makedirs(OUT, exist_ok=True)
    {"reference": reference, "ladder": ladder, "report": report,
     "figure": figure}[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
