"""Build every scene's .blend file into a directory (default: this one).

Run: python scenes/build_all.py [OUT_DIR]
The default scene is OUT_DIR/cornell_spheres.blend.
"""
import importlib
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

SCENES = ["cornell_spheres", "cornell_dragon", "cornell_rough", "caustic_floor", "furnace", "slab",
          "lens", "node_materials", "glass_wall"]


def build_all(out_dir=HERE):
    """Build all scenes into out_dir; returns the written paths."""
    paths = []
    for name in SCENES:
        module = importlib.import_module(name)
        paths.append(module.build(os.path.join(out_dir, f"{name}.blend")))
    return paths


if __name__ == "__main__":
    for p in build_all(sys.argv[1] if len(sys.argv) > 1 else HERE):
        print(p)
