"""A sweep across a local Dask cluster (two worker processes), partitioned by variants, equals the local one."""

import numpy as np
import pandas as pd
import pytest

distributed = pytest.importorskip("distributed", reason="Dask's distributed scheduler is not installed")
import invsim  # noqa: E402
import invsim.dask  # noqa: E402
from conftest import REPO  # noqa: E402


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None, host="127.0.0.1"
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_dask_delayed_without_client(si_engine):
    # Runs before the cluster fixture exists: no current client, so dask.delayed on the given scheduler.
    params = {"m": [1200.0, 1300.0, 1400.0]}
    import dask

    with dask.config.set(scheduler="synchronous"):
        spread = invsim.dask.sweep(si_engine, params, cycles=["ece"], npartitions=2, client=None)
    pd.testing.assert_frame_equal(spread, si_engine.sweep(params=params, cycles=["ece"]))


def test_dask_sweep_equals_local(si_engine, client):
    rng = np.random.default_rng(14)
    params = pd.DataFrame({"m": rng.uniform(1000, 1800, 10), "C_d": rng.uniform(0.25, 0.4, 10)})
    cycles = ["nedc", "udds"]
    local = si_engine.sweep(params=params, cycles=cycles, dt=0.5)
    spread = invsim.dask.sweep(si_engine, params, cycles=cycles, npartitions=4, client=client, dt=0.5, threads=1)
    pd.testing.assert_frame_equal(spread, local)
    # The partitions ran in both worker processes.
    assert len(client.scheduler_info()["workers"]) == 2


def test_dask_sweep_of_a_model_with_modes(client):
    # The 5-speed car travels to the workers as its file's bytes and runs its compiled modes there.
    model = invsim.Model(REPO / "models" / "si_engine_5speed.toml")
    params = {"m": [1200.0, 1350.0, 1500.0, 1650.0]}
    local = model.sweep(params=params, cycles=["ece"], dt=0.5)
    spread = invsim.dask.sweep(model, params, cycles=["ece"], npartitions=2, client=client, dt=0.5, threads=1)
    pd.testing.assert_frame_equal(spread, local)
    assert spread["error"].isna().all() and (spread["modes.switches"] > 0).all()
