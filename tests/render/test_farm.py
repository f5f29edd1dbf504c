"""Rendering on Dask (farm/): windows traced by worker processes and merged in window
order make the local render bit for bit, through lost workers; failures are one-line errors.

One LocalCluster of two worker processes serves the module (starting one takes seconds); the
workers import this checkout's snell through PYTHONPATH, which they inherit.
"""
import os
import signal
import socket
import sys

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

from snell import cli                                            # noqa: E402
from snell.farm import cluster as cluster_module, keys    # noqa: E402
from snell.farm import render as render_module, worker    # noqa: E402
from snell.errors import CliError                                 # noqa: E402
from snell.tracer import image, passes                            # noqa: E402
from snell.tracer.integrator import Renderer, kernels_compiled, warm_up   # noqa: E402
from snell.tracer.result import RenderResult                       # noqa: E402
from snell.tracer.scene import save                               # noqa: E402
from support.builders import box, camera, icosphere, make_scene, quad   # noqa: E402

SIZE = 16
SPP = 12
# Windows of 2 samples on a 16x16 image (the tracer sizes them from PASS_PATHS): 6 windows. Only
# the client's windows change: a worker traces the window it is given, as one pass.
PASS_PATHS = 2 * SIZE * SIZE
MATERIALS = [{"name": "White", "kind": "diffuse", "color": [0.8, 0.8, 0.8]},
             {"name": "Lamp", "kind": "emission", "color": [1.0, 1.0, 1.0], "strength": 20.0},
             {"name": "Glass", "kind": "glass", "color": [1.0, 1.0, 1.0], "ior": 1.5}]


def glass_room(**render):
    """A closed room, a ceiling lamp and a glass sphere: the path and light tracers both run."""
    pos, tri = box((-1, -1, 0), (1, 1, 2))
    walls = pos[tri].reshape(-1, 3), np.arange(3 * len(tri), dtype=np.int32).reshape(-1, 3)
    lamp = quad((0, 0, 1.98), 0.25, 0.25, normal_sign=-1)
    sphere = icosphere(2, radius=0.3, center=(0.0, 0.0, 0.6))[:2]
    cam = camera(position=(0.0, 0.0, 1.9), resolution=(SIZE, SIZE), lens=20.0)
    return make_scene([(*walls, 0), (*lamp, 1), (*sphere, 2)], MATERIALS, cam, max_depth=4,
                      spp=SPP, noise_threshold=0.0, **render)


@pytest.fixture(scope="module")
def client():
    """A LocalCluster of two single-threaded worker processes, kernels warm on disk first."""
    if not kernels_compiled():
        warm_up()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as local, \
            distributed.Client(local) as dask_client:
        yield dask_client


@pytest.fixture
def small_windows(monkeypatch):
    monkeypatch.setattr(passes, "PASS_PATHS", PASS_PATHS)


def same_image(a, b) -> bool:
    """The same float64 sums, bit for bit, and the same light paths."""
    return (np.array_equal(a.sum, b.sum) and np.array_equal(a.sum_sq, b.sum_sq)
            and a.light_paths == b.light_paths
            and (a.light_sum is None) == (b.light_sum is None)
            and (a.light_sum is None or np.array_equal(a.light_sum, b.light_sum)))


def test_a_distributed_render_is_the_local_render_bit_for_bit(client, small_windows):
    """Two worker processes, six windows: the local render's sums, light paths, NaN count,
    counters and image, and both workers traced some."""
    scene = glass_room()
    local = Renderer(scene, scene.settings()).render()
    seen = []
    merged = render_module.render_frame(client, scene, scene.settings(), "room.snell",
                                        progress=lambda r, done, total: seen.append((done, total)))
    assert local.light_paths > 0 and local.spp == merged.spp == SPP
    assert same_image(local, merged)
    assert (local.nan_count, local.stats) == (merged.nan_count, merged.stats)
    assert np.array_equal(local.mean(), merged.mean())
    assert seen == [(k, 6) for k in range(1, 7)]
    assert merged.light_in_image and merged.stages == local.stages and merged.rays > 0


def test_the_merge_order_is_what_makes_it_exact(client, small_windows, monkeypatch):
    """The comparison above sees a wrong merge: windows added in reverse order, or one left out,
    change the sums."""
    scene = glass_room()
    local = Renderer(scene, scene.settings()).render()
    replies = []
    monkeypatch.setattr(render_module, "_add", lambda result, reply: replies.append(reply))
    render_module.render_frame(client, scene, scene.settings(), "room.snell")
    assert [r.sums.window.index for r in replies] == list(range(6))

    def merged(order):
        out = RenderResult(SIZE, SIZE, np.zeros((SIZE, SIZE, 3)), np.zeros((SIZE, SIZE, 3)))
        for reply in order:
            out.add(reply.sums)
        return out
    assert same_image(local, merged(replies))
    assert not same_image(local, merged(replies[::-1]))
    assert not same_image(local, merged(replies[:2] + replies[3:]))
