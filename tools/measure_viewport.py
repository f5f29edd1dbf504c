#!/usr/bin/env python3
"""Time the viewport's Rendered mode from an edit to the first updated image (README, Viewport).

    .venv/bin/python tools/measure_viewport.py [SCENE.blend] [--size 960x540] [--repeat 3]
        [--threads 2] [--png-spp 16] [--png-dir docs/images]

Headless, with the bpy module: the engine's view_update is called from a depsgraph_update_post
handler, as Blender calls it during the edit's depsgraph update, and view_draw in a loop with a
stand-in region (camera view of the scene camera, --size pixels) and drawing module, as the
viewport redraws while the engine tags redraws. Depth of field is turned on (focused on the
glass sphere, f/4) so that the f-stop edit changes the image. Per edit (move the glass sphere,
change its IOR, change the f-stop): the seconds from the edit to the new generation's first
image (1/8 resolution), to its first full-resolution image, and the full-resolution samples per
second; the median over --repeat edits. The worker's image after the last repeat of each edit,
at --png-spp samples, is saved as a PNG through the Standard view transform (--png-half: at
half size, each pixel the mean of 2x2).
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import types

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


class Engine:
    """Stands in for the render engine (records nothing: the viewport's state is the measure)."""

    def bind_display_space_shader(self, scene):
        pass

    def unbind_display_space_shader(self):
        pass

    def tag_redraw(self):
        pass

    def update_stats(self, stats, info):
        self.info = info

    def report(self, level, message):
        print(f"  report {level}: {message}", file=sys.stderr)


class Drawing:
    """Stands in for the gpu drawing module (the texture is the pixel array)."""

    def texture(self, rgba):
        return rgba

    def draw_texture(self, texture, x, y, width, height):
        pass

    def text(self, x, y, lines, size=13.0):
        print("  text:", " ".join(lines), file=sys.stderr)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", nargs="?",
                        default=os.path.join(ROOT, "scenes", "cornell_spheres.blend"))
    parser.add_argument("--size", default="960x540")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--png-spp", type=int, default=16)
    parser.add_argument("--png-dir", default=os.path.join(ROOT, "docs", "images"))
    parser.add_argument("--png-half", action="store_true",
                        help="save the images at half size (2x2 pixel means), for the docs")
    args = parser.parse_args(argv)
    width, height = (int(v) for v in args.size.lower().split("x"))

    import bpy

    from snell.addon import engine as engine_mod
    from snell.addon import registration, viewport
    from snell.tracer import integrator
    from snell.tracer.image import write_png

    registration.ensure_registered()
    integrator.warm_up()
    bpy.ops.wm.open_mainfile(filepath=args.scene)
    scene = bpy.context.scene
    scene.render.engine = "SNELL"
    scene.snell.threads = args.threads
    scene.snell.viewport_spp = 0                      # refine until the next edit
    glass = bpy.data.objects["GlassSphere"]
    cam = scene.camera
    cam.data.dof.use_dof = True
    cam.data.dof.aperture_fstop = 4.0
    cam.data.dof.focus_distance = float((glass.location - cam.location).length)
    bpy.context.view_layer.update()

    engine, drawing = Engine(), Drawing()
    viewport.DRAWING = drawing
    viewport.RESIZE_DELAY = 0.0

    def context():
        depsgraph = bpy.context.evaluated_depsgraph_get()
        window = np.array(cam.calc_matrix_camera(depsgraph, x=width, y=height))
        return types.SimpleNamespace(
            region=types.SimpleNamespace(width=width, height=height),
            region_data=types.SimpleNamespace(view_perspective="CAMERA", window_matrix=window,
                                              view_matrix=np.array(cam.matrix_world.inverted())),
            space_data=types.SimpleNamespace(lens=50.0, camera=None, use_local_camera=False))

    def on_update(_, depsgraph):
        engine_mod.SnellRenderEngine.view_update(engine, context(), depsgraph)

    def draw_until(predicate, timeout=600.0):
        end = time.perf_counter() + timeout
        while time.perf_counter() < end:
            engine_mod.SnellRenderEngine.view_draw(engine, context(),
                                                   bpy.context.evaluated_depsgraph_get())
            view = engine._snell_viewport
            if view.frame is not None and predicate(view.frame):
                return time.perf_counter(), view.frame
            time.sleep(1 / 60)       # a redraw loop at a display's rate, as Blender's
        raise TimeoutError("the viewport did not update")

    bpy.app.handlers.depsgraph_update_post.append(on_update)
    on_update(None, bpy.context.evaluated_depsgraph_get())   # the first view_update
    draw_until(lambda f: f.divisor == 1 and f.samples >= 2)
    view = engine._snell_viewport

    def move(i):
        glass.location.x += 0.05 if i % 2 == 0 else -0.05

    def ior(i):
        node = bpy.data.materials["Glass"].node_tree.nodes["Glass BSDF"]
        node.inputs["IOR"].default_value = 1.33 if i % 2 == 0 else 1.5

    def fstop(i):
        cam.data.dof.aperture_fstop = 1.4 if i % 2 == 0 else 4.0

    edits = [("move the glass sphere", "viewport_move_glass.png", move),
             ("change its IOR (1.5 -> 1.33)", "viewport_ior.png", ior),
             ("change the f-stop (4 -> 1.4)", "viewport_fstop.png", fstop)]
    print(f"{os.path.basename(args.scene)}, {width}x{height} region (camera view), "
          f"{args.threads} threads")
    for label, png, edit in edits:
        first, full, rates, restarts = [], [], [], []
        for i in range(args.repeat if args.repeat % 2 else args.repeat + 1):
            before = view.session.generation
            t0 = time.perf_counter()
            edit(i)
            bpy.context.view_layer.update()      # the depsgraph update: view_update runs
            t1, frame = draw_until(lambda f: f.generation > before)
            t2, frame = draw_until(lambda f: f.generation > before and f.divisor == 1)
            _, frame = draw_until(lambda f: f.generation > before and f.divisor == 1
                                  and f.samples >= 4)
            first.append(t1 - t0)
            full.append(t2 - t0)
            rates.append(frame.stats["samples_per_second"])
            restarts.append(view.generations[frame.generation])
            if i == 0:       # the edited state (odd repeats undo the edit)
                _, frame = draw_until(lambda f: f.generation > before and f.samples >= args.png_spp)
                image = frame.image
                if args.png_half:
                    h, w = image.shape[0] // 2 * 2, image.shape[1] // 2 * 2
                    image = image[:h, :w].reshape(h // 2, 2, w // 2, 2, 3).mean(axis=(1, 3))
                write_png(os.path.join(args.png_dir, png), image)
                bvh = "kept" if frame.stats["bvh_reused"] else "rebuilt"
        print(f"{label}: restart {restarts[0]} (BVH {bvh}); first image "
              f"{statistics.median(first):.3f} s (runs {', '.join(f'{t:.3f}' for t in first)}), "
              f"first full-resolution image {statistics.median(full):.3f} s, "
              f"{statistics.median(rates):.2f} samples/s at full resolution")
    bpy.app.handlers.depsgraph_update_post.remove(on_update)
    viewport.release(engine)


if __name__ == "__main__":
    main()
