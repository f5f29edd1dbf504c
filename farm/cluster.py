"""Connecting to Dask: a scheduler at an address, or a LocalCluster of worker processes started
and stopped with the command; and checking that every worker runs this Snell."""
from __future__ import annotations

import contextlib
import logging
import time

from ..errors import CliError, one_line
from ..tracer import jit
from . import aliases, worker

PACKAGE = __name__.rsplit(".", 2)[0]   # snell, or bl_ext.<repository>.snell inside Blender
CONNECT_TIMEOUT = 10.0   # seconds to reach a scheduler
WORKERS_TIMEOUT = 60.0   # seconds for a scheduler's first worker to join
# A LocalCluster worker's preload (Dask imports a text with spaces as a module and calls its
# dask_setup as the worker starts, before it joins): worker.start, by the name the workers have
# Snell under. Text, not that module's name: a worker without Snell still starts, and
# check_workers says what it lacks.
WORKER_START = f"""
def dask_setup(dask_worker):
    try:
        from {aliases.INSTALLED}.farm.worker import start
    except ImportError:
        return
    start(dask_worker)
"""

# Dask's periodic work, turned down for renders whose tasks take seconds: on an idle LocalCluster
# of two workers, its sampling profiler (every 10 ms in each worker), the event loop's health
# tick (20 ms in every process), the system monitor (0.5 s) and the worker memory monitor
# (0.1 s) kept 5.2-5.9% of a processor busy, and 1.1% with these (docs/measurements.md,
# "Dask's own work"). Set in the client, so in a LocalCluster's workers too (a Nanny hands its
# worker the client's config); workers started by `dask worker` read their own.
QUIET = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "2s",
}


def _dask():
    """dask.distributed, or a CliError saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise CliError("--workers and --cluster need Dask "
                       "(pip install 'snell[distributed]')") from None
    return distributed


@contextlib.contextmanager
def connect(address: str | None = None, workers: int | None = None,
            timeout: float | None = None, origin: str | None = None):
    """A Dask Client: of the scheduler at `address`, or of a LocalCluster of `workers` processes
    (one thread each) closed on exit. Unreachable scheduler: CliError, starting with `origin`
    (what asked for the address; default "--cluster ADDRESS"). Dask's periodic work is turned
    down (QUIET) while it is open."""
    distributed = _dask()
    import dask
    with dask.config.set(QUIET), _client(distributed, address, workers, timeout,
                                         origin) as client:
        yield client


@contextlib.contextmanager
def _client(distributed, address, workers, timeout, origin):
    """connect's client, under the config in force."""
    if address is None:
        # Processes, not threads: the tracer releases the GIL but Python between its kernels does
        # not. Dashboard on a free port: other renders may run on this machine.
        # Each worker imports the tracer and loads the kernels as it starts (WORKER_START).
        cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1,
                                           processes=True, dashboard_address=":0",
                                           silence_logs=logging.ERROR, preload=[WORKER_START])
        try:
            with _closing(distributed.Client(cluster)) as client:
                yield client
        finally:
            cluster.close()
        return
    origin = origin or f"--cluster {address}"
    try:
        client = distributed.Client(address, timeout=timeout or CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as exc:
        raise CliError(f"{origin}: cannot reach the scheduler ({_reason(exc)})") from None
    except ValueError as exc:     # not an address: no port, an unknown scheme
        raise CliError(f"{origin}: {_reason(exc)}") from None
    with _closing(client):
        yield client


@contextlib.contextmanager
def _closing(client):
    """The client, closed on exit: not `with client`, which makes it the current client of
    the thread's context, and may only be left in that context (farm/render.py's Opening
    connects in a thread of its own and closes in the caller's)."""
    try:
        yield client
    finally:
        client.close()


def _reason(exc: BaseException) -> str:
    """The last line of a connection error's message (Dask's say what they tried first)."""
    text = str(exc).strip().splitlines()
    return text[-1] if text else type(exc).__name__


def check_workers(client, timeout: float | None = None) -> int:
    """Wait for a worker, then check that every worker runs this Snell (the same tracer sources)
    and can render; returns the worker threads. CliError otherwise."""
    timeout = timeout or WORKERS_TIMEOUT
    try:
        client.wait_for_workers(1, timeout=timeout)
    except TimeoutError:
        raise CliError(f"no Dask worker joined the scheduler {client.scheduler.address} "
                       f"in {timeout:g} s") from None
    here = jit.sources_hash()
    try:
        # Blender's extension is bl_ext.<repository>.snell, a worker's Snell `snell`.
        aliases.share(client, PACKAGE)
        described = client.run(worker.describe)
    except Exception as exc:  # noqa: BLE001  (a worker without snell cannot even unpickle it)
        raise CliError(f"a Dask worker cannot run Snell ({type(exc).__name__}: "
                       f"{_reason(exc)}): install snell[distributed] on every worker") from None
    for address, info in sorted(described.items()):
        if info["error"]:
            raise CliError(f"worker {address}: {info['error']}")
        if info["sources"] != here:
            raise CliError(f"worker {address} runs another Snell (tracer {info['path']}, sources "
                           f"{info['sources']}; here {here}): install the same version")
    return sum(client.nthreads().values())


def dashboard(client) -> str:
    """The Dask dashboard's address, or '' if the scheduler serves none."""
    try:
        return client.dashboard_link or ""
    except Exception:  # noqa: BLE001  (no dashboard: bokeh missing, or disabled)
        return ""


STOP_POLL_S = 0.05   # how often a wait for a task looks at its stop (Esc in Blender)


def finished(future, stop=None) -> bool:
    """Wait for a task; False if `stop` (anything with is_set(), None: never) was set first."""
    if stop is None:
        return True
    while not future.done():
        if stop.is_set():
            return False
        time.sleep(STOP_POLL_S)
    return True


def failure(name: str, what: str, exc: BaseException) -> CliError:
    """The error of a task that failed on the cluster (after Dask's retries): the scene, the
    task and the failure, on one line."""
    return CliError(f"{name}: {what} failed on the cluster: {type(exc).__name__}: "
                    f"{one_line(exc)[:300]}")
