"""The start of `snell render --workers/--cluster` (farm/render.py's opening, farm/worker.py's
start): the cluster opens in a thread while the scene loads, a scene that fails to load or a
cluster that cannot open ends with one clear error and nothing left running or written, local
workers load the kernels as they start, Dask's periodic work is turned down while connected,
and a worker's exit skips only the interpreter's teardown."""
from __future__ import annotations

import contextlib
import multiprocessing
import os
import subprocess
import sys
import threading

import numpy as np
import pytest

pytest.importorskip("distributed")

from snell import cli                                             # noqa: E402
from snell.farm import cluster as cluster_module, worker          # noqa: E402
from snell.tracer import image                                    # noqa: E402
from snell.tracer.scene import save                               # noqa: E402
from support.builders import tiny_scene                           # noqa: E402
from support.dask_cluster import client  # noqa: E402,F401  (the shared LocalCluster fixture)

WAIT_S = 60.0   # a bound on waiting for the other thread, not a timing: ends a broken test


@pytest.fixture
def tiny(tmp_path):
    path = tmp_path / "tiny.snell"
    save(tiny_scene(noise_threshold=0.0), str(path))
    return path


def connect_spy(monkeypatch, began=None):
    """cluster.connect recorded (entered, left) around the real one; `began` set as it starts."""
    real, seen = cluster_module.connect, []

    def connect(*args, **kwargs):
        seen.append("entered")
        if began is not None:
            began.set()
        with real(*args, **kwargs) as dask_client:
            yield dask_client
        seen.append("left")
    monkeypatch.setattr(cluster_module, "connect", contextlib.contextmanager(connect))
    return seen


def test_the_cluster_opens_while_the_scene_loads(client, tiny, tmp_path, monkeypatch):
    """`snell render --cluster`: the connection (a LocalCluster's start with --workers) begins
    before the scene has loaded, and the image is the local render's. The scene's load waits
    for the connection to begin: run one after the other, it never would (the check fails
    after WAIT_S). Deliberate error caught: the opening's thread started by wait() instead of
    at once: "the scene loaded before the cluster began to open"."""
    began, order = threading.Event(), []
    connect_spy(monkeypatch, began)
    real_load = cli.load_scene

    def load_scene(path):
        order.append(("connecting while the scene loads", began.wait(WAIT_S)))
        return real_load(path)
    monkeypatch.setattr(cli, "load_scene", load_scene)
    farm, local = tmp_path / "farm.exr", tmp_path / "local.exr"
    assert cli.main(["render", str(tiny), "-o", str(farm), "--quiet",
                     "--cluster", client.scheduler.address]) == 0
    assert order == [("connecting while the scene loads", True)], \
        "the scene loaded before the cluster began to open"
    assert cli.main(["render", str(tiny), "-o", str(local), "--quiet"]) == 0
    assert np.array_equal(image.read_exr(str(farm)), image.read_exr(str(local)))


def test_a_scene_that_fails_to_load_closes_the_local_cluster(tmp_path, capsys, monkeypatch):
    """A bad scene file with --workers 2: one error line naming it, no traceback, no output
    file, and the LocalCluster that began to start meanwhile closed, its worker processes
    gone. Deliberate error caught: Opening.close not closing what it opened: connect's exit
    missing and two worker processes left."""
    path = tmp_path / "bad.snell"
    path.write_text("not a scene")
    seen = connect_spy(monkeypatch)
    before = set(multiprocessing.active_children())
    status = cli.main(["render", str(path), "-o", str(tmp_path / "a.exr"), "--png",
                       str(tmp_path / "a.png"), "--workers", "2"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1 and len(err) == 1, err
    assert err[0].startswith(f"snell: error: {path}: not a Snell scene file")
    assert seen == ["entered", "left"]
    assert set(multiprocessing.active_children()) <= before
    assert sorted(os.listdir(tmp_path)) == ["bad.snell"]


def test_without_dask_workers_are_one_error(tiny, tmp_path, capsys, monkeypatch):
    """Dask not installed: --workers ends with the CliError saying how to install it, raised
    in the opening's thread and reported by the command, after the scene loaded; nothing
    written. Deliberate error caught: the thread's exception not handed over by wait():
    "AttributeError: 'NoneType' object has no attribute 'client'"."""
    monkeypatch.setitem(sys.modules, "distributed", None)      # import distributed fails
    status = cli.main(["render", str(tiny), "-o", str(tmp_path / "a.exr"), "--workers", "2"])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 1 and err == ["snell: error: --workers and --cluster need Dask "
                                   "(pip install 'snell[distributed]')"], err
    assert sorted(os.listdir(tmp_path)) == ["tiny.snell"]


def test_local_workers_load_the_kernels_as_they_start():
    """A LocalCluster of cluster.connect: before any task and before check_workers (whose
    describe imports the tracer), each worker has imported the tracer and loaded the kernels
    (warm_up's: a kernel of the stages has its compiled signature). Deliberate error caught:
    no preload: both False."""
    from snell.tracer.integrator import kernels_compiled, warm_up
    if not kernels_compiled():
        warm_up()

    def loaded():
        wavefront = sys.modules.get("snell.tracer.wavefront")
        return wavefront is not None and any(   # a kernel called from Python, compiled here
            getattr(kernel, "_outer", None) is not None and bool(kernel._outer.signatures)
            for kernel in vars(wavefront).values())
    with cluster_module.connect(None, 2) as dask_client:
        assert list(dask_client.run(loaded).values()) == [True, True]


def test_dask_runs_quietly_while_connected():
    """While cluster.connect's session is open, the client and a LocalCluster's workers run
    with Dask's periodic work turned down (cluster.QUIET: no task profiler, a health tick of 1 s
    rather than 20 ms); the client's config is back as it was after. Deliberate error caught:
    connect without the config: every check False."""
    import dask

    def quiet(dask_worker):
        return ({key: dask.config.get(key) for key in cluster_module.QUIET} == cluster_module.QUIET
                and "profile" not in dask_worker.periodic_callbacks
                and dask_worker.periodic_callbacks["tick"].callback_time == 1000)
    before = {key: dask.config.get(key) for key in cluster_module.QUIET}
    with cluster_module.connect(None, 2) as dask_client:
        assert dask.config.get("distributed.admin.tick.interval") == "1s"
        assert list(dask_client.run(quiet).values()) == [True, True]
    assert {key: dask.config.get(key) for key in cluster_module.QUIET} == before != \
        cluster_module.QUIET


EXITING = """
import atexit, sys
sys.path.insert(0, sys.argv[1])
atexit.register(lambda: open(sys.argv[2] + "/handler", "w").close())
from snell.farm import worker
atexit.register(worker._exit_now)


class Torn:
    def __del__(self, write=open, path=sys.argv[2] + "/teardown"):   # bound: builtins go first
        write(path, "w").close()


torn = Torn()
"""


def test_a_workers_exit_runs_the_exit_handlers_and_skips_the_teardown(tmp_path):
    """farm/worker.py's _exit_now: the exit handlers registered before it run, the process
    exits 0, and the interpreter's teardown of the modules (which took a warm worker 1-1.5 s)
    does not happen: a module object's __del__ never runs. Deliberate errors caught: without
    atexit._run_exitfuncs, no "handler"; without os._exit, a "teardown"."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(cli.__file__)))
    proc = subprocess.run([sys.executable, "-c", EXITING, root, str(tmp_path)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert sorted(os.listdir(tmp_path)) == ["handler"]
