"""Depth-of-field test: a small emissive quad at a chosen depth in a black world.

Run: python scenes/lens.py OUT.blend [depth] [focus] [lens_radius] [size]
The camera sits at the origin looking down +Y (the quad faces it at distance depth), with depth
of field on: fstop = lens_mm * 1e-3 / (2 lens_radius). Out of focus, the quad blurs into a disk
whose size follows from thin-lens optics.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

LENS_MM = 50.0


def build(path, depth=3.0, focus=3.0, lens_radius=0.05, size=0.05):
    """Build the lens scene and save it to path."""
    scene = common.reset()
    common.setup_render(scene, (128, 128))
    s = size / 2
    lamp = common.material("Emitter", "emission", (1.0, 1.0, 1.0), Strength=1.0)
    common.quad("Emitter", [(-s, depth, -s), (s, depth, -s), (s, depth, s), (-s, depth, s)], lamp)
    cam = common.camera(scene, (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), lens=LENS_MM)
    cam.data.dof.use_dof = True
    cam.data.dof.focus_distance = focus
    cam.data.dof.aperture_fstop = common.aperture_fstop(LENS_MM, lens_radius)
    return common.save(path)


if __name__ == "__main__":
    a = sys.argv[1:]
    build(a[0], *(float(x) for x in a[1:5]))
