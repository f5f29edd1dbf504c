"""Furnace test: a sphere in a uniform white world of radiance 1.

Run: python scenes/furnace.py OUT.blend [mirror|glass|glass1.0|refraction] [scale]
A lossless white material must render as radiance 1 everywhere (up to the bounce limit).
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

MATERIALS = {
    "mirror": ("glossy", {}),
    "glass": ("glass", {"IOR": 1.5}),
    "glass1.0": ("glass", {"IOR": 1.0}),
    "refraction": ("refraction", {"IOR": 1.5}),
}


def build(path, material="glass", scale=1.0):
    """Build the furnace with a sphere of the given material and radius scale, save to path."""
    kind, values = MATERIALS[material]
    scene = common.reset()
    common.setup_render(scene, (64, 64), max_bounces=31)
    common.set_world(scene, (1.0, 1.0, 1.0), 1.0)
    mat = common.material(f"Furnace_{material}", kind, (1.0, 1.0, 1.0), **values)
    sphere = common.uv_sphere("Sphere", (0.0, 0.0, 0.0), 1.0, mat)
    sphere.scale = (scale, scale, scale)
    common.camera(scene, (0.0, -4.0 * scale, 0.0), (0.0, 0.0, 0.0), lens=50.0)
    return common.save(path)


if __name__ == "__main__":
    args = sys.argv[1:]
    build(args[0], args[1] if len(args) > 1 else "glass", float(args[2]) if len(args) > 2 else 1.0)
