"""A sweep across a local Dask cluster (two worker processes), partitioned by variants, equals the local one."""

import numpy as np
import pandas as pd
import pytest

distributed = pytest.importorskip("distributed", reason="Dask's distributed scheduler is not installed")
import invsim  # noqa: E402
import invsim.dask  # noqa: E402
from conftest import REPO, SI_ENGINE, assert_rows_equal_cli, cli_sweep  # noqa: E402


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
    grid = {"m": [1200.0, 1300.0, 1400.0], "C_d": [0.3, 0.34]}
    import dask

    with dask.config.set(scheduler="synchronous"):
        spread = invsim.dask.sweep(si_engine, grid=grid, cycles=["ece"], npartitions=2, client=None)
    assert len(spread) == 6
    pd.testing.assert_frame_equal(spread, si_engine.sweep(grid=grid, cycles=["ece"]))


def test_dask_sweep_equals_local(si_engine, client):
    rng = np.random.default_rng(14)
    table = pd.DataFrame({"m": rng.uniform(1000, 1800, 10), "C_d": rng.uniform(0.25, 0.4, 10)})
    cycles = ["nedc", "udds"]
    local = si_engine.sweep(table=table, cycles=cycles, dt=0.5)
    spread = invsim.dask.sweep(si_engine, table=table, cycles=cycles, npartitions=4, client=client, dt=0.5, threads=1)
    pd.testing.assert_frame_equal(spread, local)
    # The partitions ran in both worker processes.
    assert len(client.scheduler_info()["workers"]) == 2


def test_dask_sweep_of_a_model_with_modes(client):
    # The 5-speed car travels to the workers as its file's bytes and runs its compiled modes there.
    model = invsim.Model(REPO / "models" / "si_engine_5speed.toml")
    grid = {"m": [1200.0, 1350.0, 1500.0, 1650.0]}
    local = model.sweep(grid=grid, cycles=["ece"], dt=0.5)
    spread = invsim.dask.sweep(model, grid=grid, cycles=["ece"], npartitions=2, client=client, dt=0.5, threads=1)
    pd.testing.assert_frame_equal(spread, local)
    assert spread["error"].isna().all() and (spread["modes.switches"] > 0).all()


def test_dask_grid_equals_cli_grid(si_engine, client, tmp_path):
    # The same product in the same order as `invsim sweep --grid`, spread over the workers.
    header, rows = cli_sweep(
        tmp_path, SI_ENGINE, "--cycle", "ece", "--dt", "0.5", "--grid", "m=1100:1500:3", "--grid", "C_d=0.3:0.34:2"
    )
    grid = {"m": np.linspace(1100, 1500, 3), "C_d": np.linspace(0.3, 0.34, 2)}
    spread = invsim.dask.sweep(si_engine, grid=grid, cycles=["ece"], npartitions=3, client=client, dt=0.5, threads=1)
    assert_rows_equal_cli(spread, header, rows, ["m", "C_d"])


def test_dask_sweep_takes_the_same_designs(si_engine):
    with pytest.warns(DeprecationWarning, match="table="):
        old = invsim.dask.sweep(si_engine, {"m": [1200.0, 1400.0]}, cycles=["ece"], npartitions=2, client=None)
    assert list(old["m"]) == [1200.0, 1400.0]
    with pytest.raises(ValueError, match="ambiguous"):
        invsim.dask.sweep(si_engine, {"m": [1200.0, 1400.0], "C_d": [0.3, 0.34]}, cycles=["ece"], client=None)
    with pytest.raises(ValueError, match="not grid= and table="):
        invsim.dask.sweep(si_engine, grid={"m": [1200.0]}, table={"m": [1200.0]}, cycles=["ece"], client=None)
    with pytest.raises(ValueError, match="needs grid="):
        invsim.dask.sweep(si_engine, cycles=["ece"], client=None)
    with pytest.raises(invsim.InvsimError, match="exceed the limit of 1000000 runs"):
        axis = np.linspace(1000, 2000, 1001)
        invsim.dask.sweep(si_engine, grid={"m": axis, "C_d": axis}, cycles=["ece"], client=None)
    with pytest.raises(ValueError, match=r"both set \(base=\) and swept \(grid=\)"):
        invsim.dask.sweep(si_engine, grid={"m": [1200.0]}, cycles=["ece"], client=None, base={"m": 1.0})
