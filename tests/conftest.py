"""Puts what the tests share on sys.path once: tests/ (the `support` package) and scenes/ (the
reference scene scripts: common, cornell_spheres, ...). Fixtures used by several folders."""
import os
import subprocess
import sys

import pytest

TESTS = os.path.dirname(os.path.abspath(__file__))
for _path in (os.path.join(os.path.dirname(TESTS), "scenes"), TESTS):
    if _path not in sys.path:
        sys.path.insert(0, _path)

from support import paths  # noqa: E402


@pytest.fixture(scope="session")
def blender_scenes(tmp_path_factory):
    """The engine's test scenes (tests/support/blender_scenes.py at 32x32), built once per session
    in a subprocess (it resets bpy)."""
    pytest.importorskip("bpy")
    out = tmp_path_factory.mktemp("blends")
    subprocess.run([sys.executable, os.path.join(paths.SUPPORT, "blender_scenes.py"), str(out), "32"],
                   check=True, capture_output=True, timeout=300)
    return out
