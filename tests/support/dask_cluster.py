"""The LocalCluster the farm tests share: one per test module, its kernels warm on disk first
(a worker that compiled them would time the compile, not the render)."""
from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def client():
    """A LocalCluster of two single-threaded worker processes, kernels warm on disk first."""
    distributed = pytest.importorskip("distributed")
    from snell.tracer.integrator import kernels_compiled, warm_up
    if not kernels_compiled():
        warm_up()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as local, \
            distributed.Client(local) as dask_client:
        yield dask_client
