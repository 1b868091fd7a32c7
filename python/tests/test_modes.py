"""Models with operating modes (si_engine_5speed, the 6-speed dynamic Fusion) and `Model.forward` from Python:
`simulate`, `forward` and `sweep` equal the command line (`invsim simulate|forward --summary-json … --out …`,
`invsim sweep`), the derivation is `invsim derive --format json`'s, and the Dask path runs them."""

import json

import numpy as np
import pandas as pd
import pytest

import invsim
from conftest import REPO, SI_ENGINE, assert_close, assert_rows_equal_cli, cli_json, cli_sweep, run_cli
from invsim import _flatten

FIVE_SPEED = REPO / "models" / "si_engine_5speed.toml"
FUSION_6 = REPO / "models" / "ford_fusion_2012_dynamic_6speed.toml"
MODAL = [FIVE_SPEED, FUSION_6]


@pytest.fixture(scope="module", params=MODAL, ids=lambda p: p.stem)
def modal(request):
    return request.param, invsim.Model(request.param)


def cli_run(tmp_path, command, model, *args):
    summary, csv = tmp_path / "s.json", tmp_path / "r.csv"
    run_cli(command, model, *args, "--summary-json", summary, "--out", csv)
    cli = json.loads(summary.read_text())
    cli.pop("provenance", None)  # the command line's record of its invocation
    return cli, pd.read_csv(csv)


def assert_series_equal(result, frame):
    df = result.to_pandas()
    assert list(df.columns) == list(frame.columns)
    for c in frame.columns:
        np.testing.assert_allclose(df[c].to_numpy(), frame[c].to_numpy(), rtol=1e-12, atol=1e-300, err_msg=c)


def test_modal_model_is_compiled_and_has_modes(modal):
    _, m = modal
    assert m.modal and m.engine == "compiled"
    assert not invsim.Model(SI_ENGINE).modal


@pytest.mark.parametrize("cycle", ["ece", "udds"])
def test_simulate_equals_cli(modal, tmp_path, cycle):
    path, m = modal
    r = m.simulate(cycle=cycle, dt=0.5, params={"m": 1500.0})
    summary, frame = cli_run(tmp_path, "simulate", path, "--cycle", cycle, "--dt", "0.5", "--set", "m=1500")
    assert_close(r.summary, summary)
    assert r.summary["modes"]["switches"] > 0 and len(r.summary["modes"]["per_mode"]) > 1
    assert_series_equal(r, frame)
    assert r.units["t"] == "s"


def test_quasi_static_switching_equals_cli(tmp_path):
    m = invsim.Model(FIVE_SPEED)
    r = m.simulate(cycle="ece", dt=0.5, switching="quasi-static")
    summary, frame = cli_run(tmp_path, "simulate", FIVE_SPEED, "--cycle", "ece", "--dt", "0.5", "--switching",
                             "quasi-static")
    assert r.summary["modes"]["switching"] == "quasi_static"
    assert_close(r.summary, summary)
    assert_series_equal(r, frame)


@pytest.mark.parametrize("model", [SI_ENGINE, FIVE_SPEED, FUSION_6], ids=lambda p: p.stem)
def test_forward_equals_cli(tmp_path, model):
    r = invsim.Model(model).forward(cycle="ece", dt=0.5, params={"m": 1450.0})
    summary, frame = cli_run(tmp_path, "forward", model, "--cycle", "ece", "--dt", "0.5", "--set", "m=1450")
    assert_close(r.summary, summary)
    assert_series_equal(r, frame)
    assert r.summary["samples"] == len(r)


def test_forward_options_are_checked():
    m = invsim.Model(FIVE_SPEED)
    with pytest.raises(invsim.InvsimError, match="bounds"):
        m.forward(cycle="ece", bounds="sometimes")
    with pytest.raises(invsim.InvsimError, match="switching"):
        m.simulate(cycle="ece", switching="abrupt")


def test_sweep_rows_equal_single_runs_and_cli(modal, tmp_path):
    path, m = modal
    masses = [1300.0, 1700.0]
    df = m.sweep(grid={"m": masses}, cycles=["ece", "hwfet"], dt=0.5, threads=2)
    assert len(df) == 4 and df["error"].isna().all()
    for _, row in df.iterrows():
        mass = masses[row["variant"]]
        single = m.simulate(cycle=row["cycle"], dt=0.5, params={"m": mass}, keep_series=False)
        for k, v in _flatten(single.summary).items():
            assert row[k] == v, (row["variant"], k)  # bit for bit
    out = tmp_path / "cli.json"
    run_cli("simulate", path, "--cycle", "hwfet", "--dt", "0.5", "--set", "m=1700", "--summary-json", out)
    cli = json.loads(out.read_text())
    cli.pop("provenance", None)
    flat = _flatten(cli)
    assert_close({k: df.iloc[3][k] for k in flat}, flat)


def test_grid_equals_cli_grid_with_modes(tmp_path):
    # The 5-speed car over a 2 x 2 grid: the command line's rows, order and figures, with the modes' too.
    args = ["--cycles", "ece,udds", "--dt", "0.5", "--grid", "m=1200:1600:2", "--grid", "C_d=0.3:0.34:2"]
    header, rows = cli_sweep(tmp_path, FIVE_SPEED, *args)
    grid = {"m": np.linspace(1200, 1600, 2), "C_d": np.linspace(0.3, 0.34, 2)}
    df = invsim.Model(FIVE_SPEED).sweep(grid=grid, cycles=["ece", "udds"], dt=0.5)
    assert len(df) == 8 and list(df["C_d"][::2]) == [0.3, 0.34, 0.3, 0.34]
    assert_rows_equal_cli(df, header, rows, ["m", "C_d"])
    for (_, row), fields in zip(df.iterrows(), rows):
        cli = dict(zip(header, fields))
        assert row["modes.switches"] == int(cli["switches"]) > 0
        assert row["modes.max_transition_deviation"] == float(cli["max_transition_deviation"])
        for mode in json.loads(row["modes.per_mode"]):
            assert mode["time_s"] == float(cli["time_{}_s".format(mode["name"])]), mode["name"]


def test_sweep_refuses_a_gearbox_parameter():
    m = invsim.Model(FIVE_SPEED)
    df = m.sweep(grid={"i_g": [3.0, 3.5]}, cycles=["ece"])
    assert df["error"].str.contains(r"\[gearbox\]").all()


def test_one_gear_s_ratio_sweeps_by_its_per_gear_name(tmp_path):
    # `i_g[3]`, the third gear's ratio, as the command line's `--grid 'i_g[3]=…'` sweeps it: the same rows.
    header, rows = cli_sweep(tmp_path, FIVE_SPEED, "--cycle", "ece", "--dt", "0.5", "--grid", "i_g[3]=1.2:1.5:2")
    df = invsim.Model(FIVE_SPEED).sweep(grid={"i_g[3]": np.linspace(1.2, 1.5, 2)}, cycles=["ece"], dt=0.5)
    assert df["error"].isna().all(), df["error"].tolist()
    assert_rows_equal_cli(df, header, rows, ["i_g[3]"])
    assert df["integrals.fuel"].iloc[1] > df["integrals.fuel"].iloc[0]


def test_derive_equals_cli(modal):
    path, m = modal
    assert m.derive() == cli_json("derive", path, "--format", "json")


def test_interpreted_equals_compiled():
    a = invsim.Model(FIVE_SPEED).simulate(cycle="ece", dt=0.5)
    b = invsim.Model(FIVE_SPEED, engine="interpreted").simulate(cycle="ece", dt=0.5)
    assert b.summary["engine"] == "interpreted"
    assert abs(a.summary["integrals"]["fuel"] / b.summary["integrals"]["fuel"] - 1) < 1e-10
