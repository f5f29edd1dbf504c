"""The test HDRI (a sky with a sun-like hot spot) and the Blender world that shows it: scenes/sky.py
(on the path through tests/conftest.py), which scenes/hdri_caustic.py builds its world with too."""
from sky import set_hdri_world, sky, write_exr, write_image  # noqa: F401
