"""Rendering on Dask (farm/): windows traced by worker processes and merged in window
order make the local render bit for bit, through lost workers; failures are one-line errors.

One LocalCluster of two worker processes serves the module (starting one takes seconds); the
workers import this checkout's snell through PYTHONPATH, which they inherit.
"""
import multiprocessing
import os
import signal
import socket
import sys
import time

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")
cloudpickle = pytest.importorskip("cloudpickle")

from snell import cli                                            # noqa: E402
from snell.farm import aliases, cluster as cluster_module, keys    # noqa: E402
from snell.farm import render as render_module, worker    # noqa: E402
from snell.errors import CliError                                 # noqa: E402
from snell.tracer import image, passes                            # noqa: E402
from snell.tracer.integrator import Renderer                      # noqa: E402
from snell.tracer.result import RenderResult                       # noqa: E402
from snell.tracer.scene import save, validate                     # noqa: E402
from snell.tracer.shader.closures import EMISSION, HOLDOUT, MIX_CLOSURE   # noqa: E402
from snell.tracer.shader.inputs import LAYER_WEIGHT               # noqa: E402
from support.builders import box, camera, icosphere, make_scene, quad, tiny_scene  # noqa: E402
from support.dask_cluster import client  # noqa: E402,F401  (the shared LocalCluster fixture)
from support.windows import sample_windows                        # noqa: E402

SIZE = 16
SPP = 12
# Windows of 2 samples on a 16x16 image, 6 windows (small_windows): passes of one sample, two to a
# window (WINDOW_PASSES). Only the client's windows change: the local render sums each window's
# two passes from zero and adds the window whole; a worker traces the window it is given, as one
# pass of 2 samples.
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
    render = {"max_depth": 4, "spp": SPP, "noise_threshold": 0.0, **render}
    return make_scene([(*walls, 0), (*lamp, 1), (*sphere, 2)], MATERIALS, cam, **render)


def windows_of(monkeypatch, samples: int, count: int) -> None:
    """Windows of `samples` samples in `count` passes, on the client."""
    sample_windows(monkeypatch, SIZE * SIZE, samples, count)


@pytest.fixture
def small_windows(monkeypatch):
    windows_of(monkeypatch, 2, 2)


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



def test_the_client_holds_a_bounded_number_of_windows(client, small_windows, monkeypatch):
    """With room for two windows' sums, never more than two windows are submitted and not yet
    added (the workers' memory: the client fetches one window at a time, in window order), and
    the image is still the local render's."""
    monkeypatch.setattr(render_module, "AHEAD_BYTES", 1)
    scene = glass_room()
    local = Renderer(scene, scene.settings()).render()
    counts = {"submitted": 0, "added": 0, "most": 0}
    submit, add = client.submit, render_module._add

    def counting_submit(*args, **kwargs):
        counts["submitted"] += 1
        counts["most"] = max(counts["most"], counts["submitted"] - counts["added"])
        return submit(*args, **kwargs)

    def counting_add(result, reply):
        counts["added"] += 1
        add(result, reply)
    monkeypatch.setattr(client, "submit", counting_submit)
    monkeypatch.setattr(render_module, "_add", counting_add)
    merged = render_module.render_frame(client, scene, scene.settings(), "room.snell")
    assert counts["submitted"] == counts["added"] == 6 and counts["most"] == 2
    assert same_image(local, merged)

# ---------------------------------------------------------------------------------------------
# The film's alpha and the denoising passes


def held_out(**render):
    """tiny_scene at SIZE x SIZE under a world, its quad a Mix of Holdout and Emission by the
    Layer Weight's Facing (blend 0.5): every sample's held-out share differs, so the alpha's sums
    depend on the order of their additions."""
    scene = tiny_scene(spp=SPP, noise_threshold=0.0, **render).with_camera(
        resolution=[SIZE, SIZE])
    scene.world = {"color": [0.2, 0.3, 0.4]}
    code = [(LAYER_WEIGHT, 5, 6, 0, -1),           # Fresnel in 5, Facing in 6, blend 0.5
            (MIX_CLOSURE, 7, 8, -1, 6),            # weights 1 - Facing in 7, Facing in 8
            (HOLDOUT, 8),
            (EMISSION, 7, 1, 4)]
    rows = [list(row) + [0] * (8 - len(row)) for row in code]
    scene.materials = [{"name": "Held", "kind": "program", "program": {
        "registers": 21, "constants": [0.5, 1.0, 1.0, 1.0, 5.0], "code": rows,
        "emission_varies": True}}]
    return scene


def same_extra(a, b) -> bool:
    """The same alpha and denoising sums and NaN counts, bit for bit (both made, or neither)."""
    names = ("transparent_sum", "transparent_sq", "albedo_sum", "normal_sum")
    return (all((getattr(a, n) is None) == (getattr(b, n) is None) for n in names)
            and all(getattr(a, n) is None or np.array_equal(getattr(a, n), getattr(b, n))
                    for n in names)
            and (a.alpha_nan_count, a.feature_nan_count) == (b.alpha_nan_count,
                                                              b.feature_nan_count)
            and a.film_transparent == b.film_transparent)


EXTRA_CASES = {
    "holdout": lambda: (held_out(), {}),
    "transparent-film": lambda: (held_out(), {"film_transparent": True}),
    "features": lambda: (glass_room(), {"denoising_passes": True}),
    "all": lambda: (held_out(), {"film_transparent": True, "denoising_passes": True}),
}


@pytest.mark.parametrize("case", EXTRA_CASES)
def test_alpha_and_denoising_passes_on_the_cluster_are_the_local_render(client, small_windows,
                                                                         case):
    """Fixed samples in six windows: the workers send each sample's alpha and features, and the
    client adds them in sample order: the local sums bit for bit. Deliberate errors caught
    (measured): each window's samples summed first and added as one: the albedo sums differ
    in 7 of 256 pixels in the room, 75 with the holdout, the alpha's in 1; each window's first
    sample left out: every pixel's alpha (256) and 128-256 pixels' features."""
    scene, render = EXTRA_CASES[case]()
    settings = scene.settings(**render)
    local = Renderer(scene, settings).render()
    merged = render_module.render_frame(client, scene, settings, "scene.snell")
    assert len(passes.fixed_windows(SIZE * SIZE, SPP)) == 6
    assert local.has_alpha == (case != "features") and local.has_features == (
        case in ("features", "all"))
    assert same_image(local, merged) and same_extra(local, merged)
    if local.has_alpha:
        alpha = local.alpha()
        assert len(np.unique(alpha)) > 10                # the held-out share varies
        assert np.array_equal(alpha, merged.alpha())
    if local.has_features:
        assert np.array_equal(local.denoising_normal(), merged.denoising_normal())


ADAPTIVE = {"noise_threshold": 0.05, "min_spp": 4, "spp": 64}


@pytest.mark.parametrize("make, render", [
    (glass_room, ADAPTIVE), (held_out, ADAPTIVE), (held_out, {"batches": 3}),
], ids=["adaptive", "adaptive-holdout", "batches-holdout"])
def test_alpha_and_denoising_passes_of_passes_on_the_cluster_are_the_local_render(client, make,
                                                                                  render):
    """Adaptive sampling and batches: each task's rows of the alpha and denoising sums go to
    the worker with its pixels and come back with the pass's samples added: bit for bit.
    Deliberate errors caught (measured): a task's albedo rows not put back on the client: 256
    of 256 pixels differ in the room (adaptive), 128 with the holdout (batches); its alpha rows
    not put back: 256 with the holdout."""
    scene = make()
    settings = scene.settings(film_transparent=True, denoising_passes=True, **render)
    local = Renderer(scene, settings).render()
    merged = render_module.render_frame(client, scene, settings, "scene.snell")
    assert local.has_alpha and local.has_features
    assert same_image(local, merged) and same_extra(local, merged)
    assert np.array_equal(local.samples(), merged.samples())
    if make is glass_room:
        assert local.samples().min() < local.samples().max()      # it did adapt


# ---------------------------------------------------------------------------------------------
# The light passes

def same_light_passes(a, b) -> bool:
    """The same light-pass sums of both halves and NaN counts, bit for bit (both made)."""
    return (a.has_light_passes and b.has_light_passes
            and np.array_equal(a.light_pass_sum, b.light_pass_sum)
            and a.light_pass_nan_count == b.light_pass_nan_count)


# Slow (67 s, mostly the light passes' variants of the stages compiled in the workers): the
# default run keeps them bit for bit on a cluster in tests/blender/test_farm_f12.py.
@pytest.mark.slow
def test_the_light_passes_on_the_cluster_are_the_local_render(client, monkeypatch):
    """Fixed samples in windows of 3 (20 spp: window 5, samples 15-17, straddles the halves'
    boundary at 16): the workers send each sample's pass rows, the client adds them in sample
    order to the half of the window's first sample: the local sums of both halves bit for bit,
    with the denoising passes beside them, and every pass read from them. Deliberate errors
    caught (measured): each sample's rows added to its own half (what the one-sample passes on
    the worker do): the halves differ in 256 of 256 pixels; each window's first sample left
    out on the client: 256 of 256 pixels."""
    windows_of(monkeypatch, 3, 1)
    scene = glass_room(spp=20)
    settings = scene.settings(light_passes=True, denoising_passes=True)
    local = Renderer(scene, settings).render()
    merged = render_module.render_frame(client, scene, settings, "room.snell")
    assert [w.first for w in passes.fixed_windows(SIZE * SIZE, 20)][5] == 15
    assert local.light_pass_sum[1].any() and local.light_pass_sum[0].any()
    assert same_image(local, merged) and same_extra(local, merged)
    assert same_light_passes(local, merged)
    ours, theirs = local.light_pass_images(), merged.light_pass_images()
    for name in ("Diffuse Direct", "Diffuse Indirect", "Glossy Indirect", "Transmission Color"):
        assert ours[name].any(), name        # the scene has light in each kind
    for name in ours:
        assert np.array_equal(ours[name], theirs[name]), name


@pytest.mark.parametrize("render", [ADAPTIVE, {"batches": 3}], ids=["adaptive", "batches"])
def test_the_light_passes_of_passes_on_the_cluster_are_the_local_render(client, render):
    """Adaptive sampling and batches: each task's rows of both halves of the light-pass sums go
    to the worker with its pixels and come back with the pass's samples added: bit for bit.
    Deliberate error caught (measured): a task's light rows not put back on the client
    (remote._put_rows): 256 of 256 pixels differ (adaptive and batches)."""
    scene = glass_room()
    settings = scene.settings(light_passes=True, **render)
    local = Renderer(scene, settings).render()
    merged = render_module.render_frame(client, scene, settings, "room.snell")
    assert same_image(local, merged) and same_light_passes(local, merged)
    assert np.array_equal(local.samples(), merged.samples())
    ours, theirs = local.light_pass_images(), merged.light_pass_images()
    for name in ours:
        assert np.array_equal(ours[name], theirs[name]), name


# ---------------------------------------------------------------------------------------------
# The light groups

def grouped_room(**render):
    """glass_room with its ceiling lamp in the light group "ceiling", a point lamp in "key"
    (whose caustic through the glass sphere puts the light tracer's splats in a group) and a
    point lamp in no group."""
    lights = [{"name": "key", "kind": "point", "position": [0.5, 0.5, 1.5],
               "intensity": [20.0, 20.0, 20.0], "radius": 0.05},
              {"name": "loose", "kind": "point", "position": [-0.5, -0.5, 1.2],
               "intensity": [5.0, 5.0, 5.0], "radius": 0.05}]
    scene = glass_room(lights=lights, **render)
    scene.light_groups = ["ceiling", "key"]
    scene.objects[1]["light_group"] = 0
    scene.lights[0]["light_group"] = 1
    return validate(scene)


def same_groups(a, b) -> bool:
    """The same light-group sums of both halves, splats and NaN counts, bit for bit (both
    made)."""
    return (a.has_light_groups and b.has_light_groups
            and a.light_group_names == b.light_group_names
            and np.array_equal(a.light_group_sum, b.light_group_sum)
            and np.array_equal(a.light_group_light, b.light_group_light)
            and int(a.light_group_nans[0]) == int(b.light_group_nans[0]))


def same_group_images(a, b) -> bool:
    """The same Combined_<group> passes, bit for bit, each with light in it."""
    ours, theirs = a.light_group_images(), b.light_group_images()
    return (sorted(ours) == sorted(theirs) == ["Combined_ceiling", "Combined_key"]
            and all(ours[name].any() and np.array_equal(ours[name], theirs[name])
                    for name in ours))


def render_grouped(client, spp=20, **render):
    """grouped_room rendered with its light groups here and on the cluster: (local, merged)."""
    scene = grouped_room(spp=spp)
    settings = scene.settings(light_groups=True, **render)
    local = Renderer(scene, settings).render()
    return local, render_module.render_frame(client, scene, settings, "room.snell")


def test_the_light_groups_on_the_cluster_are_the_local_render(client, monkeypatch):
    """Fixed samples in windows of 3, each three passes of one sample (20 spp: window 5,
    samples 15-17, straddles the halves' boundary at 16): the workers send each sample's group
    columns and each window's group splats summed from zero; the client adds the samples in
    sample order to the half of their local pass's first sample, and the splats in window
    order: the local sums of both halves and of the splats bit for bit, and the
    Combined_<group> passes read from them. Deliberate errors caught (measured): each sample
    added to the half of its window's first sample (right for windows of one pass only); and,
    measured with windows of one pass of 3 samples, each window's first group sample left out
    on the client (add_extra): the group sums differ in 256 of 256 pixels (Combined_ceiling in
    242, Combined_key in 256); window 2's group splats not added (its WindowSums.group_light
    dropped in _add): 11 pixels' splat sums (Combined_ceiling 1, Combined_key 10)."""
    windows_of(monkeypatch, 3, 3)
    local, merged = render_grouped(client)
    assert len(passes.fixed_windows(SIZE * SIZE, 20)) == 7
    assert local.light_group_sum[0].any() and local.light_group_sum[1].any()
    assert local.light_group_light[:, 3:].any()    # the key lamp's caustic: splats in a group
    assert same_image(local, merged) and same_groups(local, merged)
    assert same_group_images(local, merged)


@pytest.mark.parametrize("part", ["samples", "splats"])
def test_a_window_left_out_of_the_groups_merge_is_caught(client, monkeypatch, part):
    """The comparison above sees a wrong merge of the groups: window 2's group samples (or its
    group splats) left out on the client changes the groups' sums and passes, and nothing
    else."""
    windows_of(monkeypatch, 3, 3)
    real = render_module._add

    def dropping(result, reply):
        if reply.sums.window.index == 2:
            if part == "samples":
                reply.extra.groups[:] = 0.0
            else:
                reply.sums.group_light[:] = 0.0
        real(result, reply)
    monkeypatch.setattr(render_module, "_add", dropping)
    local, merged = render_grouped(client)
    assert same_image(local, merged)
    assert not same_groups(local, merged) and not same_group_images(local, merged)


@pytest.mark.parametrize("render", [ADAPTIVE, {"batches": 3}], ids=["adaptive", "batches"])
def test_the_light_groups_of_passes_on_the_cluster_are_the_local_render(client, render):
    """Adaptive sampling and batches: each task's rows of both halves of the group sums go to
    the worker with its pixels and come back with the pass's samples added, and the light
    passes' group splats are added here in chunk order: bit for bit. Deliberate errors caught
    (measured): a task's group rows not put back on the client (remote._put_rows): the group
    sums differ in 256 of 256 pixels (adaptive and batches); the light passes' group splats
    not added (RemoteTracer.light_pass without groups): 78 pixels' splat sums (adaptive), 52
    (batches)."""
    local, merged = render_grouped(client, **render)
    assert same_image(local, merged) and same_groups(local, merged)
    assert local.light_group_light[:, 3:].any()
    assert np.array_equal(local.samples(), merged.samples())
    assert same_group_images(local, merged)


@pytest.mark.slow     # 85 s; the same data paths on the cluster are held by the client tests above
def test_render_workers_writes_the_local_alpha_passes_and_denoised_image(tmp_path):
    """`snell render --workers 2` with a transparent film, a Holdout, --denoise and --passes
    writes the local render's EXR: every channel (R, G, B, A, samples, the noisy image, the
    denoising, data and light passes, the light groups') bit for bit. Deliberate errors
    caught: each window's first sample of the features left out on the client: `Denoising
    Albedo.R` differs (4.51 against 4.14 in the first pixel); of the light passes:
    `Emission.R` differs; of the light groups: `Combined_quad.R` differs."""
    import OpenImageIO as oiio
    from snell.tracer.light_passes import PASSES as LIGHT
    path = tmp_path / "held.snell"
    scene = held_out()
    scene.light_groups = ["quad", "sky"]
    scene.objects[0]["light_group"], scene.world["light_group"] = 0, 1
    save(validate(scene), str(path))
    options = ["--film-transparent", "--denoise", "--passes",
               ",".join(("Depth,Normal,Denoising Albedo,Denoising Normal,Noisy Image",) + LIGHT
                        + ("Combined_quad", "Combined_sky")),
               "--quiet"]
    local, farm = tmp_path / "local.exr", tmp_path / "farm.exr"
    assert cli.main(["render", str(path), "-o", str(local), *options]) == 0
    assert cli.main(["render", str(path), "-o", str(farm), "--workers", "2", *options]) == 0

    def channels(exr):
        buf = oiio.ImageBuf(str(exr))
        names = list(buf.spec().channelnames)
        return names, {name: image.read_channel(str(exr), name) for name in names}
    names, ours = channels(local)
    assert {"A", "samples", "Noisy Image.R", "Denoising Normal.B", "Depth.Z"} <= set(names)
    assert {f"{name}.G" for name in LIGHT} <= set(names)
    assert ours["Emission.R"].any() and ours["Environment.B"].any()
    assert ours["Combined_quad.G"].any() and ours["Combined_sky.B"].any()
    farm_names, theirs = channels(farm)
    assert farm_names == names
    for name in names:
        assert np.array_equal(ours[name], theirs[name]), name
    assert len(np.unique(ours["A"])) > 10                      # held out by varying shares
    assert not np.array_equal(ours["R"], ours["Noisy Image.R"])   # it was denoised


# ---------------------------------------------------------------------------------------------
# The command line


def test_render_workers_writes_the_local_image(tmp_path, capsys):
    """`snell render --workers 2` starts two worker processes, writes the EXR of the local
    render, says where it rendered and where the dashboard is, and stops its workers."""
    path = tmp_path / "room.snell"
    save(glass_room(), str(path))
    local, farm = tmp_path / "local.exr", tmp_path / "farm.exr"
    assert cli.main(["render", str(path), "-o", str(local), "--quiet"]) == 0
    before = set(multiprocessing.active_children())
    assert cli.main(["render", str(path), "-o", str(farm), "--workers", "2"]) == 0
    out, err = capsys.readouterr()
    assert "snell: rendering on 2 Dask workers (2 threads), dashboard http" in err
    assert f"{SPP} spp in " in out and " on 2 workers " in out
    assert np.array_equal(image.read_exr(str(local)), image.read_exr(str(farm)))
    assert set(multiprocessing.active_children()) <= before    # no worker left running


@pytest.mark.parametrize("render", [
    {"noise_threshold": 0.05, "min_spp": 4, "spp": 64},      # light tracer, light-vertex pilot
    {"noise_threshold": 0.05, "min_spp": 4, "spp": 64, "light_vertex_pilot": False},
    {"batches": 3},
], ids=["adaptive", "adaptive-no-pilot", "batches"])
def test_adaptive_sampling_and_batches_on_the_cluster_are_the_local_render(client, render):
    """The coordinator runs the schedulers, the workers trace the passes: the local render's
    sums, sample counts, batches, counters and progress, bit for bit."""
    scene = glass_room()
    settings = scene.settings(**render)
    local_seen, seen = [], []
    local = Renderer(scene, settings).render(
        progress=lambda r, done, total: local_seen.append((done, r.spp)))
    merged = render_module.render_frame(client, scene, settings, "room.snell",
                                        progress=lambda r, done, total: seen.append((done, r.spp)))
    assert same_image(local, merged) and local.light_paths > 0
    assert (local.nan_count, local.stats, local.spp) == (merged.nan_count, merged.stats, merged.spp)
    assert seen == local_seen and len(seen) > 2
    if "batches" in render:
        assert merged.batches == 3 and np.array_equal(local.batch_sq, merged.batch_sq)
        assert np.array_equal(local.light_batch_sq, merged.light_batch_sq)
    else:
        assert np.array_equal(local.samples(), merged.samples())
        assert local.samples().min() < local.samples().max()      # it did adapt
        assert merged.stages == local.stages
    assert np.array_equal(local.mean(), merged.mean())


def test_the_rows_sent_back_are_what_makes_the_adaptive_render_exact(client, monkeypatch):
    """The comparison above sees a wrong merge: one pass's samples lost changes the image."""
    from snell.farm import remote
    scene = glass_room()
    settings = scene.settings(noise_threshold=0.05, min_spp=4, spp=64)
    local = Renderer(scene, settings).render()
    real = remote.RemoteTracer.camera_pass
    calls = []

    def dropping(self, *args, **kwargs):
        calls.append(1)
        film = args[4]
        saved = film[0].copy() if len(calls) == 3 else None
        bad = real(self, *args, **kwargs)
        if saved is not None:
            film[0][:] = saved                  # the third pass's samples lost
        return bad
    monkeypatch.setattr(remote.RemoteTracer, "camera_pass", dropping)
    merged = render_module.render_frame(client, scene, settings, "room.snell")
    assert len(calls) > 3 and not same_image(local, merged)


# ---------------------------------------------------------------------------------------------
# Faults


def on_workers(client, name, replacement):
    """Replace a function of farm/worker.py in every worker process, the original kept there as
    worker.saved_<name>."""
    def swap():
        if not hasattr(worker, "saved_" + name):
            setattr(worker, "saved_" + name, getattr(worker, name))
        setattr(worker, name, replacement)
    client.run(swap)


def restore(client, name):
    """Put back what on_workers replaced (a restarted worker has its own already)."""
    def put():
        if hasattr(worker, "saved_" + name):
            setattr(worker, name, getattr(worker, "saved_" + name))
    client.run(put)


# The worker processes cannot import this module: its functions travel by value.
cloudpickle.register_pickle_by_value(sys.modules[__name__])


def test_a_worker_killed_mid_render_loses_nothing(client, small_windows):
    """Kill the process of a worker that is tracing a window: Dask reruns its windows on the
    other worker and the image is still the local render's, bit for bit."""
    scene = glass_room()
    local = Renderer(scene, scene.settings()).render()
    def slow(*args):      # long enough that the kill lands inside a task
        time.sleep(0.5)
        return worker.saved_trace_window(*args)
    on_workers(client, "trace_window", slow)
    pids = client.run(os.getpid)
    killed = {}

    def kill(result, done, total):
        if killed:
            return
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            busy = [a for a, keys in client.processing().items() if keys and a in pids]
            if busy:
                killed["pid"], killed["keys"] = pids[busy[0]], set(client.processing()[busy[0]])
                killed["left"] = total - done
                os.kill(killed["pid"], signal.SIGKILL)
                return
            time.sleep(0.01)
    try:
        merged = render_module.render_frame(client, scene, scene.settings(), "room.snell",
                                            progress=kill)
    finally:
        restore(client, "trace_window")
        # The nanny restarts the killed worker: the tests after this one see two workers again.
        client.wait_for_workers(2, timeout=120)
    assert killed and killed["keys"] and killed["left"] >= 1, killed
    with pytest.raises(ProcessLookupError):
        os.kill(killed["pid"], 0)
    assert same_image(local, merged)
    assert (local.nan_count, local.stats) == (merged.nan_count, merged.stats)


def test_a_task_that_keeps_failing_is_one_error_naming_the_scene(client, tmp_path, capsys):
    """Every try of a window fails on the workers: `snell render --cluster` exits 1 with one
    line naming the scene and the failure, and writes nothing."""
    path = tmp_path / "tiny.snell"
    save(tiny_scene(noise_threshold=0.0), str(path))

    def broken(*args):
        raise RuntimeError("the BVH could not be built")
    on_workers(client, "renderer_for", broken)
    try:
        status = cli.main(["render", str(path), "-o", str(tmp_path / "a.exr"),
                           "--png", str(tmp_path / "a.png"), "--cluster",
                           client.scheduler.address])
    finally:
        restore(client, "renderer_for")
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1
    assert err[-1].startswith("snell: error: ") and "tiny.snell" in err[-1]
    assert "RuntimeError: the BVH could not be built" in err[-1] and "Traceback" not in err[-1]
    assert len(err) == 2 and err[0].startswith("snell: rendering on 2 Dask workers")
    assert sorted(os.listdir(tmp_path)) == ["tiny.snell"]


def test_a_worker_of_another_snell_is_refused(client, tmp_path, capsys):
    """A worker whose tracer sources differ from the client's: one error naming it, no render."""
    path = tmp_path / "tiny.snell"
    save(tiny_scene(noise_threshold=0.0), str(path))
    real = worker.describe
    on_workers(client, "describe", lambda: {**worker.saved_describe(), "sources": "0123abcd"})
    try:
        status = cli.main(["render", str(path), "-o", str(tmp_path / "a.exr"), "--cluster",
                           client.scheduler.address])
    finally:
        restore(client, "describe")
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1 and len(err) == 1 and real is worker.describe
    assert "runs another Snell" in err[0] and "0123abcd" in err[0]
    assert sorted(os.listdir(tmp_path)) == ["tiny.snell"]


def test_an_unreachable_scheduler_is_one_error(tmp_path, capsys, monkeypatch):
    """A closed port: one line naming the address, within the connect timeout."""
    monkeypatch.setattr(cluster_module, "CONNECT_TIMEOUT", 2.0)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    path = tmp_path / "tiny.snell"
    save(tiny_scene(noise_threshold=0.0), str(path))
    start = time.monotonic()
    status = cli.main(["render", str(path), "-o", str(tmp_path / "a.exr"), "--cluster",
                       f"tcp://127.0.0.1:{port}"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1 and len(err) == 1, err
    assert err[0].startswith(f"snell: error: --cluster tcp://127.0.0.1:{port}: cannot reach "
                             "the scheduler")
    assert time.monotonic() - start < 30
    assert sorted(os.listdir(tmp_path)) == ["tiny.snell"]


EXTENSION_CLIENT = """
import sys, numpy as np
sys.path.insert(0, sys.argv[1])
from bl_ext.user_default.snell.farm import render
from bl_ext.user_default.snell.tracer.scene import load
scene = load(sys.argv[2])
with render.session(sys.argv[3], None, quiet=True) as frames:
    result = frames(scene, scene.settings(), "room.snell")
np.save(sys.argv[4], result.sum)
print(type(result).__module__, "snell" in sys.modules, sys.modules["snell"].__name__)
"""


def test_an_alias_answers_imports_with_the_real_modules_until_uninstalled():
    """install(alias, real) answers imports of alias and its submodules with real's module
    objects (no second copy) and of its parents with empty packages; uninstall takes all of
    it back, so the names no longer import. Deliberate errors caught: uninstall leaving the
    finder (the import still succeeds) or the parents (they stay in sys.modules)."""
    import importlib
    alias = "snell_test_ext.repo.snell"
    aliases.install(alias, "snell")
    try:
        tracer = importlib.import_module(alias + ".tracer.image")
        assert tracer is image and sys.modules["snell_test_ext"].__path__ == []
    finally:
        aliases.uninstall(alias)
    assert not [name for name in sys.modules if name.startswith("snell_test_ext")]
    assert not [f for f in sys.meta_path if isinstance(f, aliases.Alias)]
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(alias + ".tracer.image")
    assert sys.modules["snell.tracer.image"] is image        # the real names are untouched


def test_a_client_that_imports_snell_as_blenders_extension_renders_on_the_cluster(
        client, tmp_path):
    """Blender imports the extension as bl_ext.user_default.snell, the workers have `snell`:
    a client under the extension's name renders on them (farm/aliases.py: the scheduler and
    workers alias its name to their snell, the client `snell` to its package, one copy each),
    the local render's sums bit for bit. Deliberate error caught: no alias (aliases.share a
    no-op): "a Dask worker cannot run Snell (... No module named 'bl_ext')", exit 1."""
    import subprocess
    root = tmp_path / "extensions"
    (root / "bl_ext" / "user_default").mkdir(parents=True)
    (root / "bl_ext" / "__init__.py").write_text("")
    (root / "bl_ext" / "user_default" / "__init__.py").write_text("")
    os.symlink(os.path.dirname(cli.__file__), root / "bl_ext" / "user_default" / "snell")
    path, out = tmp_path / "room.snell", tmp_path / "sum.npy"
    save(glass_room(), str(path))
    try:
        proc = subprocess.run([sys.executable, "-c", EXTENSION_CLIENT, str(root), str(path),
                               client.scheduler.address, str(out)],
                              capture_output=True, text=True, timeout=300)
    finally:
        # The LocalCluster's scheduler runs in this process and now answers imports of bl_ext
        # with empty packages: a later `import bpy` here (the image regression's exports) would
        # find them in place of Blender's own extension packages and export other scenes.
        aliases.uninstall("bl_ext.user_default.snell")
    assert proc.returncode == 0, proc.stderr[-2000:]
    # The result's class is the extension's, and `snell` there is the extension's package.
    assert proc.stdout.split() == ["bl_ext.user_default.snell.tracer.result", "True",
                                   "bl_ext.user_default.snell"]
    scene = glass_room()
    local = Renderer(scene, scene.settings()).render()
    assert np.array_equal(np.load(out), local.sum)


def test_task_keys_are_the_render_content_frame_window_and_seed():
    """The same scene and settings give the same keys (a retried task is the same task); the
    scene, a setting of the image, the frame, the window or the seed each change it, the threads
    do not."""
    scene = glass_room()
    key = keys.render_key(scene, scene.settings())
    assert key == keys.render_key(glass_room(), scene.settings(threads=7))
    assert key != keys.render_key(scene, scene.settings(spp=SPP + 1))
    assert key != keys.render_key(glass_room(max_depth=3), scene.settings())
    moved = glass_room()
    moved.positions = moved.positions + np.float32(1e-3)
    assert keys.scene_hash(moved) != keys.scene_hash(scene)
    names = {keys.window_key(key, f, w, s) for f in (0, 1) for w in (0, 1) for s in (0, 1)}
    assert len(names) == 8


def test_a_time_limit_is_refused():
    """A time-limited render's samples depend on its clock: there is no image to be equal to."""
    scene = glass_room()
    with pytest.raises(CliError, match="--time-limit 0"):
        render_module.check_settings(scene.settings(time_limit=5.0), "room.snell")
    render_module.check_settings(scene.settings(), "room.snell")
