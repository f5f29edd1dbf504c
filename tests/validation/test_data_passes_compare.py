"""The data passes against Cycles' own (#33): Depth, Position, Normal and Object Index of a
scene with a floor, a flat-shaded box, a smooth sphere and a card seen from behind, from
Cycles' multilayer EXR (View Layer > Passes > Data).

Cycles writes Depth, Position and the index from each pixel's first sample, at a point of the
pixel its sampler picks; Snell through the pixel's centre (tracer/data_passes.py). So they are
held to each other where a pixel and its eight neighbours see one object in both renderers,
within what half a pixel moves each pass there (the larger of the pixel's differences to its
neighbours in Snell's own pass). Normal is Cycles' mean over the samples: on flat faces the
same, on the sphere within the normal's turn across a pixel.
"""
from __future__ import annotations

import importlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from support.render_passes import saves_multilayer_exr  # noqa: E402

common = importlib.import_module("common")

SIZE = (64, 48)
CAMERA = np.array([0.6, -4.0, 2.2])


def build(path):
    scene = common.reset()
    common.setup_render(scene, SIZE, samples=16, max_bounces=1)
    grey = common.material("Grey", "diffuse", (0.5, 0.5, 0.5))
    floor = common.quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], grey)
    floor.pass_index = 1
    box = common.mesh_object("Box", [(0.2, 0.0, 0), (1.0, 0.0, 0), (1.0, 0.8, 0), (0.2, 0.8, 0),
                                     (0.2, 0.0, 0.7), (1.0, 0.0, 0.7), (1.0, 0.8, 0.7),
                                     (0.2, 0.8, 0.7)],
                             [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5),
                              (2, 3, 7, 6), (3, 0, 4, 7)], grey)
    box.pass_index = 2
    ball = common.uv_sphere("Ball", (-0.7, 0.3, 0.6), 0.6, grey, segments=32, rings=16)
    ball.pass_index = 3
    for poly in ball.data.polygons:
        poly.use_smooth = True
    # Wound to face away from the camera: its Normal pass faces the viewer anyway.
    card = common.quad("Card", [(-1.4, -0.6, 1.4), (-1.4, -0.6, 0.4), (-0.4, -0.6, 0.4),
                                (-0.4, -0.6, 1.4)], grey)
    card.pass_index = 4
    common.camera(scene, tuple(CAMERA), (0.0, 0.3, 0.5), lens=35.0)
    layer = scene.view_layers[0]
    layer.use_pass_z = layer.use_pass_normal = layer.use_pass_position = True
    layer.use_pass_object_index = True
    return common.save(path)


def cycles_passes(blend, out):
    """{pass: (H, W, channels)} of Cycles' render of the file, row 0 at the top."""
    import OpenImageIO as oiio

    from snell.addon.blendfile import open_blend
    open_blend(blend)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    saves_multilayer_exr(scene, out)
    bpy.ops.render.render(write_still=True)
    found = {}
    inp = oiio.ImageInput.open(out)
    part = 0
    while inp.seek_subimage(part, 0):      # one part per pass
        names = list(inp.spec().channelnames)
        layer = names[0].split(".")[1]
        if layer in ("Depth", "Position", "Normal", "Object Index"):
            found[layer] = np.asarray(inp.read_image(part, 0, 0, len(names), "float"),
                                      np.float64).reshape(SIZE[1], SIZE[0], len(names))
        part += 1
    inp.close()
    return found


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    from snell.tracer.data_passes import data_passes
    from snell.tracer.integrator import Renderer
    from snell.validation import compare
    folder = tmp_path_factory.mktemp("data_passes")
    blend = build(str(folder / "passes.blend"))
    scene, _ = compare.load_snell_scene(blend)
    ours = data_passes(Renderer(scene, scene.settings(threads=2)),
                       ["Depth", "Position", "Normal", "Object Index"])
    return ours, cycles_passes(blend, str(folder / "cycles.exr"))


def interior(index):
    """Pixels whose 3x3 neighbourhood sees one object (index (H, W)); not the frame's border,
    whose neighbours beyond it are unknown."""
    pad = np.pad(index, 1, constant_values=-1)
    same = np.ones(index.shape, bool)
    h, w = index.shape
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            same &= pad[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] == index
    return same


def half_pixel_change(values):
    """The largest difference of each pixel to its 8 neighbours, over channels (H, W)."""
    pad = np.pad(values, ((1, 1), (1, 1), (0, 0)), mode="edge")
    h, w = values.shape[:2]
    most = np.zeros((h, w))
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            diff = np.abs(pad[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] - values).max(axis=2)
            most = np.maximum(most, diff)
    return most


def held(ours, theirs, name, extra=1e-4):
    """Where both see one object around a pixel: |ours - theirs| within half a pixel's change
    (plus extra); returns (pixels held, pixels outside)."""
    mask = interior(ours["Object Index"][..., 0]) & interior(theirs["Object Index"][..., 0]) & \
        (ours["Object Index"][..., 0] == theirs["Object Index"][..., 0])
    bound = half_pixel_change(ours[name].astype(np.float64)) + extra
    off = (np.abs(ours[name] - theirs[name]).max(axis=2) > bound) & mask
    return int(mask.sum()), int(off.sum())


def test_the_object_index_is_cycles(both):
    ours, theirs = both
    agree = ours["Object Index"][..., 0] == theirs["Object Index"][..., 0]
    # Pixels differ only on edges, where each renderer's point of the pixel sees one side.
    assert agree[interior(ours["Object Index"][..., 0])].all()
    assert set(np.unique(ours["Object Index"])) == {0.0, 1.0, 2.0, 3.0, 4.0}


@pytest.mark.parametrize("name", ["Depth", "Position", "Normal"])
def test_data_pass_is_cycles_inside_objects(both, name):
    ours, theirs = both
    count, off = held(ours, theirs, name, extra=0.02 if name == "Normal" else 1e-4)
    assert count > 1000 and off == 0, (count, off)


def test_the_distance_along_the_ray_is_caught(both):
    """Depth as the distance along each ray instead of along the view axis: off by 1 -
    cos(angle), caught at the frame's sides."""
    ours, theirs = both
    along_ray = np.linalg.norm(ours["Position"].astype(np.float64) - CAMERA, axis=2,
                               keepdims=True)
    wrong = {**ours, "Depth": np.where(ours["Depth"] < 1e9, along_ray, ours["Depth"])}
    _, off = held(wrong, theirs, "Depth")
    assert off > 20, off


def test_a_back_face_normal_not_turned_is_caught(both):
    ours, theirs = both
    card = ours["Object Index"][..., 0] == 4
    wrong = {**ours, "Normal": np.where(card[..., None], -ours["Normal"], ours["Normal"])}
    _, off = held(wrong, theirs, "Normal", extra=0.02)
    assert off > 20, off
