"""A scene script builds the same scene every time: the stored images (tests/references/images.npz)
and Cycles references are keyed to what the scripts build on a fresh clone."""
import os
import subprocess
import sys

import numpy as np
import pytest

from support.paths import ROOT


def _build(name: str, path) -> None:
    code = (f"import sys; sys.path.insert(0, {os.path.join(ROOT, 'scenes')!r}); "
            f"import {name}; {name}.build({str(path)!r})")
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, timeout=300)


@pytest.mark.parametrize("name", ["cornell_spheres"])    # UV spheres, whose numbering Blender varies
def test_a_scene_script_builds_the_same_scene_twice(name, tmp_path):
    pytest.importorskip("bpy")
    from snell.addon.export import export_blend
    scenes = []
    for run in ("first", "second"):
        path = tmp_path / f"{run}.blend"
        _build(name, path)
        scenes.append(export_blend(str(path))[0])
    for field in ("positions", "triangles", "normals", "material_ids", "object_ids"):
        first, second = (getattr(scene, field) for scene in scenes)
        assert np.array_equal(first, second), f"scenes/{name}.py built two scenes: {field} differ"
