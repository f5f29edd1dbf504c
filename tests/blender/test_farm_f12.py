"""F12 on a Dask cluster from Blender (Render Properties > Performance > Render On): the
frame's sample windows go to the workers through farm/'s Session, and the image F12 saves
(Combined with its alpha, Sample Count, the light passes and the light groups' passes) is
the local F12's bit for bit;
progress reaches the status bar, Esc cancels the cluster's tasks, and an unreachable scheduler
or a worker of another Snell is one error in Blender's report, with no traceback.

One LocalCluster of two worker processes serves the module (the scheduler's address is what
Render On > Dask Scheduler is given); the workers import this checkout's snell through
PYTHONPATH, which they inherit. F12 runs in this process (bpy.ops.render.render).
"""
from __future__ import annotations

import importlib
import multiprocessing
import socket
import sys
import time

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")
distributed = pytest.importorskip("distributed")
cloudpickle = pytest.importorskip("cloudpickle")

from snell.addon import final, registration  # noqa: E402
from snell.farm import cluster as cluster_module, worker  # noqa: E402
from support.dask_cluster import client  # noqa: E402,F401  (the shared LocalCluster fixture)
from support.render_passes import exr_channels, saves_multilayer_exr  # noqa: E402
from support.windows import sample_windows  # noqa: E402

common = importlib.import_module("common")

SIZE = (16, 12)
SPP = 6
LIGHT = ("use_pass_emit", "use_pass_environment", "use_pass_diffuse_direct",
         "use_pass_diffuse_indirect", "use_pass_diffuse_color", "use_pass_glossy_direct",
         "use_pass_glossy_indirect", "use_pass_glossy_color")


@pytest.fixture(scope="module", autouse=True)
def registered():
    registration.ensure_registered()
    yield


@pytest.fixture
def one_sample_windows(monkeypatch):
    """Windows of one sample (the client's PASS_PATHS, one pass each: a worker traces the
    window it is given): SPP windows a frame."""
    sample_windows(monkeypatch, SIZE[0] * SIZE[1], 1)


def build(tmp_path, name):
    """A diffuse floor and a glossy ball under a point lamp (light group "key") and a blue world
    (light group "sky"), Film > Transparent, Snell the engine at fixed samples, eight light
    passes switched on, F12 saving a 32-bit multilayer EXR to tmp_path/name."""
    scene = common.reset()
    common.setup_render(scene, SIZE, samples=SPP, max_bounces=3)
    common.set_world(scene, (0.2, 0.3, 0.5))
    floor = common.material("Floor", "diffuse", (0.8, 0.5, 0.3))
    common.quad("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], floor)
    ball = common.material("Ball", "glossy", (0.9, 0.9, 0.9), Roughness=0.3)
    common.uv_sphere("Ball", (0.0, 0.0, 0.4), 0.4, ball, segments=16, rings=8)
    lamp = bpy.data.lights.new("Lamp", "POINT")
    lamp.energy = 100.0
    obj = bpy.data.objects.new("Lamp", lamp)
    obj.location = (0.5, -0.5, 2.0)
    scene.collection.objects.link(obj)
    common.camera(scene, (0.0, -3.0, 2.0), (0.0, 0.0, 0.3), lens=35.0)
    layer = scene.view_layers[0]
    for switch in LIGHT:
        setattr(layer, switch, True)
    for group in ("key", "sky"):
        layer.lightgroups.add(name=group)
    obj.lightgroup, scene.world.lightgroup = "key", "sky"
    scene.render.engine = "SNELL"
    scene.render.film_transparent = True
    saves_multilayer_exr(scene, tmp_path / name)
    return scene


def f12(scene, where, fails=False, **cluster):
    """F12 with Render On `where` (and the scheduler's address or the workers): the record.
    fails: the render ends with an error, which Blender's operator raises with the report."""
    scene.snell.render_on = where
    for name, value in cluster.items():
        setattr(scene.snell, name, value)
    if not fails:
        bpy.ops.render.render(write_still=True)
        return dict(final.last_render)
    with pytest.raises(RuntimeError) as raised:
        bpy.ops.render.render(write_still=True)
    record = dict(final.last_render)
    assert record["error"] in str(raised.value)
    return record


class Spy:
    """Stands in for the engine inside final.render (RNA methods cannot be overridden in a
    RenderEngine subclass): records the status lines, and says Esc was pressed once
    `esc_after` results were shown."""

    def __init__(self, engine, log, esc_after=None):
        self.engine, self.log, self.esc_after = engine, log, esc_after

    def __getattr__(self, name):
        return getattr(self.engine, name)

    def update_result(self, result):
        self.log.append(("result",))
        self.engine.update_result(result)

    def update_stats(self, stats, info):
        self.log.append(("stats", info))
        self.engine.update_stats(stats, info)

    def report(self, kinds, message):
        self.log.append(("report", kinds, message))
        self.engine.report(kinds, message)

    def test_break(self):
        shown = sum(1 for entry in self.log if entry[0] == "result")
        return self.esc_after is not None and shown >= self.esc_after


@pytest.fixture
def spied(monkeypatch):
    """F12 through a Spy: yields (log, set_esc(n)): Esc after n results shown."""
    log, esc = [], {"after": None}
    real = final.render
    monkeypatch.setattr(registration.engine.final, "render",
                        lambda engine, depsgraph: real(Spy(engine, log, esc["after"]),
                                                       depsgraph))
    yield log, lambda n: esc.update(after=n)


def test_f12_on_the_cluster_is_the_local_f12_bit_for_bit(client, tmp_path, one_sample_windows,
                                                          spied):
    """Render On > Dask Scheduler: every channel F12 saves (Combined RGBA, Sample Count, eight
    light passes, the light groups' Combined_key and Combined_sky) equals This Computer's F12
    bit for bit; the status bar showed the samples and says where it rendered. Deliberate
    errors caught (measured): each window's first light-pass sample left out on the client
    (farm/render.py's add_extra): 21 channels differ (Diffuse Color.B first); each window's
    first light-group sample left out there: the 6 channels of Combined_key and Combined_sky
    differ. (Windows 1 and 2 added in swapped order change the float64 sums only in their
    last bits, which the float32 EXR rounds away here: tests/render/test_farm.py holds the
    sums themselves.)"""
    log, _ = spied
    scene = build(tmp_path, "local.exr")
    local = f12(scene, "THIS_COMPUTER")
    assert local["error"] is None and local["spp"] == SPP
    scene.render.filepath = str(tmp_path / "farm.exr")
    log.clear()
    farm = f12(scene, "DASK_SCHEDULER", cluster_address=client.scheduler.address)
    assert farm["error"] is None, farm
    assert farm["spp"] == SPP and farm["workers"] == 2 and not farm["cancelled"]
    stats = [entry[1] for entry in log if entry[0] == "stats"]
    assert f"Snell: connecting to the Dask scheduler {client.scheduler.address}" in stats
    assert any(f"Sample 3/{SPP}" in line for line in stats), stats
    assert "on 2 Dask workers" in stats[-1] and stats[-1].startswith("Snell: Done:")
    ours, theirs = exr_channels(tmp_path / "local.exr"), exr_channels(tmp_path / "farm.exr")
    assert sorted(ours) == sorted(theirs)
    names = {name.split(".")[-2] for name in ours if name.count(".") >= 2}
    assert {"Combined", "Sample Count", "Emission", "Diffuse Direct", "Glossy Color",
            "Combined_key", "Combined_sky"} <= names
    differ = [name for name in sorted(ours) if not np.array_equal(ours[name], theirs[name])]
    assert differ == []
    alpha = next(ours[name] for name in ours if name.endswith("Combined.A"))
    assert 0.0 < alpha.mean() < 1.0                    # the world is transparent, the floor not
    glossy = next(ours[name] for name in ours if name.endswith("Glossy Direct.R"))
    assert glossy.max() > 0.0
    for group in ("Combined_key.R", "Combined_sky.B"):
        assert next(ours[name] for name in ours if name.endswith(group)).max() > 0.0, group


def tasks_left(client) -> tuple:
    """(tasks the scheduler holds, tasks the workers hold)."""
    on_scheduler = client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))
    on_workers = client.run(lambda dask_worker: len(dask_worker.state.tasks))
    return on_scheduler, sum(on_workers.values())


def until_no_tasks(client, seconds=20.0) -> tuple:
    """Wait until neither the scheduler nor a worker holds a task; what is left then."""
    deadline = time.monotonic() + seconds
    while tasks_left(client) != (0, 0) and time.monotonic() < deadline:
        time.sleep(0.1)
    return tasks_left(client)


def test_esc_after_a_window_keeps_it_and_cancels_the_rest(client, tmp_path,
                                                           one_sample_windows, spied):
    """Esc after the first window is shown: the render ends cancelled at one sample (the
    windows after it never added), the status bar says so, and the scheduler and both workers
    soon hold no task of it (nothing left running). Deliberate error caught (measured): the
    session kept open after F12 (final.py's resources.close() skipped, as a client kept between
    renders would be) and the frame's futures not cancelled (Started.cancel keeping them): the
    scheduler held 6 tasks and the workers 7 after 20 s. (Either alone is covered by the other:
    closing the client releases its futures.)"""
    log, esc_after = spied
    scene = build(tmp_path, "cancel.exr")
    scene.snell.use_cycles_settings = False
    scene.snell.spp, scene.snell.noise_threshold = 64, 0.0
    esc_after(1)
    record = f12(scene, "DASK_SCHEDULER", cluster_address=client.scheduler.address)
    assert record["error"] is None and record["cancelled"] and record["spp"] == 1, record
    assert any("Cancelled after 1/64 samples" in entry[1] for entry in log
               if entry[0] == "stats")
    assert until_no_tasks(client) == (0, 0)


def test_esc_while_a_window_is_traced_does_not_wait_for_it(client, tmp_path, monkeypatch):
    """Windows that take 3 s each on the workers, Esc 0.5 s into the render: F12 ends within
    a second of it, cancelled with no sample (a black image), and once the workers finish the
    windows they were tracing (Dask cannot stop a running task) nothing of the render is left
    on the cluster. Deliberate error caught (measured): Esc not handed to the farm (final.py
    calling the Session with stop=None): F12 waited for the window and ended uncancelled with
    all 6 samples."""
    log = []
    scene = build(tmp_path, "waiting.exr")

    def slow():
        worker.saved_trace_window = worker.trace_window

        def sleeping(*args):
            time.sleep(3.0)
            return worker.saved_trace_window(*args)
        worker.trace_window = sleeping

    def put_back():
        worker.trace_window = worker.saved_trace_window
    started = {}

    class Esc(Spy):
        def update_stats(self, stats, info):
            if info.startswith("Snell: rendering, sample 0/"):
                started["at"] = time.monotonic()
            super().update_stats(stats, info)

        def test_break(self):
            return "at" in started and time.monotonic() > started["at"] + 0.5
    real = final.render
    monkeypatch.setattr(registration.engine.final, "render",
                        lambda engine, depsgraph: real(Esc(engine, log), depsgraph))
    client.run(slow)
    try:
        record = f12(scene, "DASK_SCHEDULER", cluster_address=client.scheduler.address)
        ended = time.monotonic()
    finally:
        client.run(put_back)
    assert record["error"] is None and record["cancelled"] and record["spp"] == 0, record
    assert ended - started["at"] < 1.5
    assert until_no_tasks(client) == (0, 0)


def test_an_unreachable_scheduler_is_one_error_in_the_report(tmp_path, spied, monkeypatch,
                                                             capfd):
    """A closed port: F12 fails within the connect timeout with one message naming the address
    in Blender's report (an ERROR), no traceback on the console, no image. Deliberate error
    caught: final.py catching RenderFailed but not the farm's CliError: the report says "render
    failed (CliError: ...); details in the console" and a traceback is printed."""
    log, _ = spied
    monkeypatch.setattr(cluster_module, "CONNECT_TIMEOUT", 2.0)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    scene = build(tmp_path, "unreachable.exr")
    start = time.monotonic()
    record = f12(scene, "DASK_SCHEDULER", True, cluster_address=f"tcp://127.0.0.1:{port}")
    assert time.monotonic() - start < 30
    assert record["error"].startswith(f"Snell: Render On: Dask Scheduler tcp://127.0.0.1:{port}: "
                                      "cannot reach the scheduler"), record
    errors = [entry[2] for entry in log if entry[0] == "report" and "ERROR" in entry[1]]
    assert errors == [record["error"]]
    assert "Traceback" not in capfd.readouterr().err
    assert not (tmp_path / "unreachable.exr").exists()


def test_an_empty_address_and_a_time_limit_are_errors(tmp_path, spied):
    """Render On > Dask Scheduler without an address, or with a time limit (whose samples
    depend on the clock): one message each saying what to change, before any connection."""
    scene = build(tmp_path, "empty.exr")
    record = f12(scene, "DASK_SCHEDULER", True, cluster_address="  ")
    assert "the scheduler's address is empty" in record["error"], record
    scene.cycles.time_limit = 5.0
    record = f12(scene, "DASK_SCHEDULER", True, cluster_address="tcp://127.0.0.1:1")
    assert "a time limit is not distributed" in record["error"], record
    assert "set Sampling > Time Limit to 0" in record["error"]


def test_a_worker_of_another_snell_is_one_error_in_the_report(client, tmp_path, spied, capfd):
    """A worker whose tracer sources differ from Blender's Snell: one ERROR naming the worker
    and both versions, no traceback, no image. Deliberate error caught: the same (CliError not
    caught): a traceback on the console."""
    log, _ = spied
    scene = build(tmp_path, "other.exr")

    def swap():
        worker.saved_describe = worker.describe
        worker.describe = lambda: {**worker.saved_describe(), "sources": "0123abcd"}

    def put_back():
        worker.describe = worker.saved_describe
    client.run(swap)
    try:
        record = f12(scene, "DASK_SCHEDULER", True, cluster_address=client.scheduler.address)
    finally:
        client.run(put_back)
    assert "runs another Snell" in record["error"] and "0123abcd" in record["error"], record
    errors = [entry[2] for entry in log if entry[0] == "report" and "ERROR" in entry[1]]
    assert errors == [record["error"]]
    assert "Traceback" not in capfd.readouterr().err
    assert not (tmp_path / "other.exr").exists()


def test_f12_on_local_workers_starts_and_stops_them(tmp_path, one_sample_windows):
    """Render On > Local Dask Workers (2): the local F12's image, and no worker process left
    running after it."""
    scene = build(tmp_path, "local.exr")
    local = f12(scene, "THIS_COMPUTER")
    scene.render.filepath = str(tmp_path / "workers.exr")
    before = set(multiprocessing.active_children())
    record = f12(scene, "LOCAL_WORKERS", cluster_workers=2)
    assert record["error"] is None and record["workers"] == 2 and local["spp"] == record["spp"]
    ours, theirs = exr_channels(tmp_path / "local.exr"), exr_channels(tmp_path / "workers.exr")
    assert all(np.array_equal(ours[name], theirs[name]) for name in ours)
    assert set(multiprocessing.active_children()) <= before


# The worker processes cannot import this module: its functions travel by value.
cloudpickle.register_pickle_by_value(sys.modules[__name__])
