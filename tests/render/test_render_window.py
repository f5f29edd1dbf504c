"""Render windows (Renderer.render_window): a fixed-sample render is the merge of its windows.

Distributed rendering traces the windows of a render on different machines, in any order, and
adds them in window order; that must give the render's float64 sums bit for bit, the path
tracer's and the light tracer's.
"""
import numpy as np
import pytest

from support.builders import box, camera, icosphere, make_scene, quad
from support.windows import sample_windows
from snell.tracer.integrator import Renderer, RenderResult

SIZE = 24
SPP = 10
MATERIALS = [{"name": "White", "kind": "diffuse", "color": [0.8, 0.8, 0.8]},
             {"name": "Lamp", "kind": "emission", "color": [1.0, 1.0, 1.0], "strength": 20.0},
             {"name": "Glass", "kind": "glass", "color": [1.0, 1.0, 1.0], "ior": 1.5}]


def glass_room():
    """A closed room lit by a ceiling lamp, a glass sphere focusing it on the floor: the light
    tracer runs."""
    pos, tri = box((-1, -1, 0), (1, 1, 2))
    walls = pos[tri].reshape(-1, 3), np.arange(3 * len(tri), dtype=np.int32).reshape(-1, 3)
    lamp = quad((0, 0, 1.98), 0.25, 0.25, normal_sign=-1)
    sphere = icosphere(2, radius=0.3, center=(0.0, 0.0, 0.6))[:2]
    cam = camera(position=(0.0, 0.0, 1.9), resolution=(SIZE, SIZE), lens=20.0)
    return make_scene([(*walls, 0), (*lamp, 1), (*sphere, 2)], MATERIALS, cam, max_depth=4,
                      spp=SPP, noise_threshold=0.0)


def merge(renderer, sums) -> RenderResult:
    """A render's result from window sums, added in the given order."""
    w, h = renderer.camera.width, renderer.camera.height
    result = RenderResult(w, h, np.zeros((h, w, 3)), np.zeros((h, w, 3)))
    for s in sums:
        result.add(s)
    return result


def same_sums(a: RenderResult, b: RenderResult) -> bool:
    """Whether two results hold the same float64 sums, bit for bit."""
    return (np.array_equal(a.sum, b.sum) and np.array_equal(a.sum_sq, b.sum_sq)
            and (a.light_sum is None) == (b.light_sum is None)
            and (a.light_sum is None or np.array_equal(a.light_sum, b.light_sum)))


@pytest.mark.parametrize("caustics", [False, True])
@pytest.mark.parametrize("window_passes", [1, 3])
def test_a_fixed_render_is_the_merge_of_its_windows(monkeypatch, caustics, window_passes):
    """Windows of 3 samples (one pass of 3, or three passes of 1) traced separately in a shuffled
    order, added in window order: the render's sums, light paths, NaN count and counters. Added
    in another order, or with a window left out, the sums differ: the comparison can see a wrong
    merge. Deliberate error caught (measured): the render merging a window of three passes pass
    by pass (each pass's sums added as it ends) rather than summed from zero and added whole:
    the sums differ."""
    sample_windows(monkeypatch, SIZE * SIZE, 3, window_passes)
    room = glass_room()
    renderer = Renderer(room, room.settings(caustics=caustics))
    assert (renderer.caustics is not None) == caustics
    whole = renderer.render()
    windows = renderer.windows(SPP)
    assert [(w.first, w.end) for w in windows] == [(0, 3), (3, 6), (6, 9), (9, 10)]
    traced = {}
    for i in np.random.default_rng(1).permutation(len(windows)):
        traced[windows[i]] = renderer.render_window(windows[i], SPP)
    merged = merge(renderer, [traced[w] for w in windows])
    assert whole.spp == merged.spp == SPP and same_sums(whole, merged)
    assert (whole.light_paths, whole.nan_count, whole.stats) == \
        (merged.light_paths, merged.nan_count, merged.stats)
    assert (whole.light_paths > 0) == caustics
    assert not same_sums(whole, merge(renderer, [traced[w] for w in reversed(windows)]))
    assert not same_sums(whole, merge(renderer, [traced[w] for w in windows[:2] + windows[3:]]))


def test_windows_of_disjoint_pixels_add_up_to_the_window_of_all():
    """The camera sums of a window over a set of pixels are those pixels' sums in the window
    over every pixel, and nothing elsewhere; the light tracer runs in the window of all pixels
    only (tiles of a window would trace the same light paths)."""
    renderer = Renderer(glass_room())
    window = renderer.windows(SPP)[0]
    everything = renderer.render_window(window, SPP)
    pixels = np.arange(SIZE * SIZE)
    odd = renderer.render_window(window, SPP, pixels[1::2])
    even = renderer.render_window(window, SPP, pixels[::2])
    assert everything.light_paths > 0 and odd.light_sum is None and odd.light_paths == 0
    assert np.all(odd.sum[::2] == 0.0) and np.all(even.sum[1::2] == 0.0)
    assert np.array_equal(odd.sum + even.sum, everything.sum)
    assert np.array_equal(odd.sum_sq + even.sum_sq, everything.sum_sq)
