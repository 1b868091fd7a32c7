"""Hybrids from Python (models/hev_p2.toml, docs/hybrids.md): `Model.simulate(strategy=...)` equals
`invsim simulate --strategy ...` (summary, `Result.hybrid`, every column), `Model.sweep(strategy=...)` equals
`invsim sweep --strategy ...` row for row (the hybrid columns bit for bit, CSV and Parquet), a verified run
(`verify=True`) equals `--verify`, and the strategy's options are refused as on the command line, and so is
`Model.forward` of a hybrid."""

import json
import math

import numpy as np
import pandas as pd
import polars as pl
import pytest

import invsim
from conftest import REPO, assert_close, cli_sweep, run_cli

HEV = REPO / "models" / "hev_p2.toml"

# The sweep's hybrid columns: each the `hybrid` block's key of the same name.
HYBRID_COLUMNS = [
    "fuel_energy_j",
    "fuel_energy_corrected_j",
    "delta_soc",
    "soc_end",
    "battery_energy_j",
    "engine_starts",
    "engine_on_s",
    "equivalence_factor",
    "search_runs",
]

STRATEGIES = [
    ({"strategy": "ecms"}, ["--strategy", "ecms"]),
    ({"strategy": "ecms", "equivalence": 3.4}, ["--strategy", "ecms", "--equivalence", "3.4"]),
    (
        {"strategy": "dp", "soc_grid": 21, "split_grid": 11, "soc_window": 0.05},
        ["--strategy", "dp", "--soc-grid", "21", "--split-grid", "11", "--soc-window", "0.05"],
    ),
    ({"strategy": "rule-based", "rb_engine_power": 12000}, ["--strategy", "rule-based", "--rb-engine-power", "12000"]),
]


@pytest.fixture(scope="module")
def hev():
    return invsim.Model(HEV)


def test_a_verified_strategy_run_equals_the_command_line(hev, tmp_path):
    """`verify=True` replays a strategy's run as `--verify` does: the tracking error and the replayed charge."""
    summary = tmp_path / "s.json"
    run_cli("simulate", HEV, "--cycle", "ece", "--dt", "1", "--strategy", "dp", "--verify", "--summary-json", summary)
    cli = json.loads(summary.read_text())
    run = hev.simulate(cycle="ece", dt=1.0, strategy="dp", verify=True)
    assert run.hybrid == cli["hybrid"]
    assert run.summary["max_abs_tracking_error"] == cli["max_abs_tracking_error"]
    assert 0.0 < run.summary["max_abs_tracking_error"] < 0.03
    assert abs(run.hybrid["soc_end_replayed"] - run.hybrid["soc_end"]) < 1e-5


@pytest.mark.parametrize("kwargs,flags", STRATEGIES, ids=["ecms", "ecms-given", "dp", "rules"])
def test_simulate_equals_the_command_line(hev, tmp_path, kwargs, flags):
    summary, csv = tmp_path / "s.json", tmp_path / "r.csv"
    run_cli("simulate", HEV, "--cycle", "ece", "--dt", "1", *flags, "--summary-json", summary, "--out", csv)
    cli = json.loads(summary.read_text())
    cli.pop("provenance")
    run = hev.simulate(cycle="ece", dt=1.0, **kwargs)
    assert_close(run.summary, cli, rel=0.0)
    assert run.hybrid == cli["hybrid"]
    assert run.hybrid["strategy"] == kwargs["strategy"]
    frame = pd.read_csv(csv)
    assert run.columns == list(frame.columns)
    for c in frame.columns:
        np.testing.assert_array_equal(run[c], frame[c].to_numpy(), err_msg=c)
    # The SOC, the decided input and the chosen mode at every sample.
    assert {"soc", "T_m", "mode", "engine_on"} <= set(run.columns)


def test_a_run_without_a_strategy_has_no_hybrid_block(si_engine):
    assert si_engine.simulate(cycle="ece", dt=1.0).hybrid is None


@pytest.mark.parametrize("kwargs,flags", [STRATEGIES[0], STRATEGIES[2]], ids=["ecms", "dp"])
def test_sweep_equals_the_command_line(hev, tmp_path, kwargs, flags):
    grid = {"Q": [12000.0, 24000.0], "k_c": [0.02, 0.04]}
    df = hev.sweep(grid=grid, cycles=["ece"], dt=1.0, threads=2, **kwargs)
    header, rows = cli_sweep(tmp_path, HEV, "--cycle", "ece", "--dt", "1", "--grid", "Q=12000:24000:2",
                             "--grid", "k_c=0.02:0.04:2", *flags)
    assert len(df) == len(rows) == 4
    for (_, row), fields in zip(df.iterrows(), rows):
        cli = dict(zip(header, fields))
        assert cli["status"] == "ok" and row["error"] is None
        assert (row["Q"], row["k_c"]) == (float(cli["Q"]), float(cli["k_c"]))
        for name in HYBRID_COLUMNS:
            value = row["hybrid." + name]
            if cli[name] == "":
                assert value is None or (isinstance(value, float) and math.isnan(value)), name
            else:
                assert value == float(cli[name]), name
        for mode in json.loads(row["modes.per_mode"]):
            assert mode["time_s"] == float(cli["time_{}_s".format(mode["name"])])


def test_sweep_rows_equal_single_runs(hev):
    df = hev.sweep(table={"Q": [12000.0, 30000.0]}, cycles=["ece"], dt=1.0, strategy="ecms", equivalence=3.4)
    for _, row in df.iterrows():
        single = hev.simulate(cycle="ece", dt=1.0, params={"Q": row["Q"]}, strategy="ecms", equivalence=3.4)
        for key, value in single.hybrid.items():
            if not isinstance(value, (dict, list)):
                assert row["hybrid." + key] == value, key


def test_parquet_has_the_hybrid_columns_typed(tmp_path):
    csv, parquet = tmp_path / "rows.csv", tmp_path / "rows.parquet"
    args = ["sweep", HEV, "--cycle", "ece", "--dt", "1", "--grid", "Q=12000:24000:2", "--strategy", "dp",
            "--soc-grid", "21", "--split-grid", "11"]
    for out in (csv, parquet):
        run_cli(*args, "--out", out)
    a, b = pl.read_parquet(parquet), pl.read_csv(csv)
    assert a.columns == b.columns
    assert a.schema["engine_starts"] == pl.Int64 and a.schema["search_runs"] == pl.Int64
    assert a.schema["fuel_energy_j"] == pl.Float64
    # DP has no equivalence factor: null in both.
    assert a["equivalence_factor"].null_count() == 2 and b["equivalence_factor"].null_count() == 2
    for name in HYBRID_COLUMNS:
        assert a[name].to_list() == b[name].to_list(), name


@pytest.mark.parametrize(
    "kwargs,message",
    [
        ({"equivalence": 3.0}, "--equivalence and --soc-tolerance apply to --strategy ecms"),
        ({"strategy": "dp", "equivalence": 3.0}, "--equivalence applies to --strategy ecms"),
        ({"strategy": "ecms", "soc_grid": 11}, "--soc-grid, --split-grid and --soc-window apply to --strategy dp"),
        ({"strategy": "ecms", "soc_tolerance": 0.0}, "--soc-tolerance must be a positive number"),
        ({"strategy": "greedy"}, "--strategy `greedy`: expected ecms, dp or rule-based"),
    ],
)
def test_strategy_options_are_refused_as_on_the_command_line(hev, kwargs, message):
    with pytest.raises(invsim.InvsimError, match=message.replace("[", r"\[")):
        hev.simulate(cycle="ece", dt=1.0, **kwargs)


def test_a_strategy_on_a_model_without_hybrid_is_refused(si_engine):
    with pytest.raises(invsim.InvsimError, match="needs a model with modes and a \\[hybrid\\] table"):
        si_engine.sweep(grid={"m": [1200.0, 1300.0]}, cycles=["ece"], strategy="ecms")
    with pytest.raises(invsim.InvsimError, match="the model has no modes and no \\[hybrid\\] table"):
        si_engine.simulate(cycle="ece", strategy="ecms")
    with pytest.raises(TypeError, match="unexpected keyword argument 'equivalance'"):
        si_engine.simulate(cycle="ece", strategy="ecms", equivalance=3.0)


def test_forward_of_a_hybrid_is_refused_as_on_the_command_line(hev):
    cli = run_cli("forward", HEV, "--cycle", "ece", "--dt", "1", check=False)
    assert cli.returncode == 2
    with pytest.raises(invsim.InvsimError, match="leaves `T_m` to an energy-management strategy") as e:
        hev.forward(cycle="ece", dt=1.0)
    assert str(e.value) in cli.stderr
