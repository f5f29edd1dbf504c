"""Cycles' pixel filters against Cycles: a high-contrast checker of emissive squares, 2.8 pixels
each and turned 20 degrees, so that edges cross pixels at every position and the filter decides
the pixels along them. The file sets the filter in Cycles' Film panel; Snell exports it (Follow
Cycles' Settings) and the validator renders Cycles with the scene's filter, so both sides sample
the same filter. Blackman-Harris 1.5 (Cycles' default) and Gaussian 2.5 must be consistent; Snell
with a 1-pixel box against Cycles' Blackman-Harris, or Gaussian 2.0 against 2.5, must not.

Measured (seed 0, 256 spp, 40 x 40): Blackman-Harris 1.5 consistent (every pixel within its
bound, sharpness z -0.1), Gaussian 2.5 consistent (sharpness z 1.3). Against Cycles'
Blackman-Harris 1.5: Snell's box 1.0 fails the pixels (94.9% pass) and sharpness (z -92),
Blackman-Harris 2.5 sharpness z 125, Gaussian 2.0 z 42. Against Cycles' Gaussian 2.5: Gaussian
2.0 fails sharpness (z -60), box 1.0 also the tiles (z -238).
"""
from __future__ import annotations

import importlib
import math

import pytest

from support.cycles_reference import Reference
from support.cycles_reference import verdict as _verdict

bpy = pytest.importorskip("bpy")

common = importlib.import_module("common")

SIZE = (40, 40)
SPP = 256
SQUARE = 0.25           # 2.8 pixels at the camera's 0.09 m per pixel
FILTERS = {"blackman_harris": ("BLACKMAN_HARRIS", 1.5), "gaussian": ("GAUSSIAN", 2.5)}


def build(path, kind, width):
    """The checker (emission 1 on a black world) under a camera looking straight down at it,
    seen directly only (max bounces 0), with Cycles' pixel filter (kind, width)."""
    scene = common.reset()
    common.setup_render(scene, SIZE, max_bounces=0)
    scene.cycles.pixel_filter_type = kind
    scene.cycles.filter_width = width
    common.set_world(scene, (0.0, 0.0, 0.0))
    lamp = common.material("Lamp", "emission", (1.0, 1.0, 1.0), Strength=1.0)
    turn = math.radians(20.0)
    c, s = math.cos(turn), math.sin(turn)
    verts, faces = [], []
    n = 16                                      # 16 x 16 squares, 4 m: past the 3.6 m view
    for i in range(n):
        for j in range(n):
            if (i + j) % 2:
                continue
            x0, y0 = (i - n / 2) * SQUARE, (j - n / 2) * SQUARE
            base = len(verts)
            for x, y in ((x0, y0), (x0 + SQUARE, y0), (x0 + SQUARE, y0 + SQUARE),
                         (x0, y0 + SQUARE)):
                verts.append((c * x - s * y, s * x + c * y, 0.0))
            faces.append([base, base + 1, base + 2, base + 3])
    common.mesh_object("Checker", verts, faces, lamp)
    common.camera(scene, (0.013, 0.007, 5.0), (0.013, 0.007, 0.0), lens=50.0)
    return common.save(path)


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    out = tmp_path_factory.mktemp("filters")
    refs = {}
    for name, (kind, width) in FILTERS.items():
        refs[name] = Reference(build(str(out / f"{name}.blend"), kind, width),
                               framing={"resolution_percentage": 100}, spp=SPP)
        assert not refs[name].warnings, refs[name].warnings
    return refs


@pytest.mark.parametrize("name", list(FILTERS))
def test_pixel_filter_matches_cycles(references, name):
    """The exported scene carries the file's filter, and Snell and Cycles agree with it."""
    reference = references[name]
    kind, width = FILTERS[name]
    assert (reference.scene.render["pixel_filter"], reference.scene.render["filter_width"]) == (
        kind.lower(), width)
    result = reference.compare()
    assert ["cycles.pixel_filter_type", kind, ] == result["cycles_settings"][
        [s[0] for s in result["cycles_settings"]].index("cycles.pixel_filter_type")][:2]
    assert _verdict(result)[0] == "consistent", _verdict(result)


@pytest.mark.parametrize("name,wrong", [("blackman_harris", ("box", 1.0)),
                                        ("gaussian", ("gaussian", 2.0))])
def test_a_wrong_filter_is_caught(references, name, wrong):
    """Snell with a 1-pixel box against Cycles' Blackman-Harris 1.5, and Gaussian 2.0 against
    Cycles' 2.5, are inconsistent."""
    kind, width = wrong
    result = references[name].compare(lambda s: s.with_render(pixel_filter=kind,
                                                              filter_width=width))
    assert _verdict(result)[0] == "inconsistent", _verdict(result)
