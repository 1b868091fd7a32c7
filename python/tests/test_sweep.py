"""`Model.sweep()`: one row per variant x cycle, equal to the single runs and to the command line."""

import json

import numpy as np
import pandas as pd
import pytest

import invsim
from conftest import SI_ENGINE, assert_close, cli_json, run_cli, shared_model
from invsim import _flatten

MASSES = [1100.0, 1300.0, 1500.0]
CDS = [0.28, 0.32, 0.36]


def row_summary(row):
    """The summary of a sweep row, as the single run's flattened summary (NaN columns of other rows dropped)."""
    return {k: v for k, v in row.items() if not (isinstance(v, float) and np.isnan(v))}


def test_rows_equal_single_runs(si_engine):
    df = si_engine.sweep(params={"m": MASSES, "C_d": CDS}, cycles=["nedc", "udds"], dt=0.5)
    assert len(df) == 6 and list(df["variant"]) == [0, 0, 1, 1, 2, 2]
    assert list(df["cycle"]) == ["nedc", "udds"] * 3
    assert df["error"].isna().all()
    for _, row in df.iterrows():
        i = row["variant"]
        single = si_engine.simulate(
            cycle=row["cycle"], dt=0.5, params={"m": MASSES[i], "C_d": CDS[i]}, keep_series=False
        )
        flat = _flatten(single.summary)
        for k, v in flat.items():
            assert row[k] == v, (i, k)  # bit for bit: the same code on the same inputs
        assert row["m"] == MASSES[i] and row["C_d"] == CDS[i]
        assert row["i_t"] == 5.0  # every model parameter, swept or not


def test_rows_equal_cli(si_engine, tmp_path):
    df = si_engine.sweep(params=pd.DataFrame({"m": MASSES[:2]}), cycles=["nedc"])
    for i, m in enumerate(MASSES[:2]):
        out = tmp_path / "s{}.json".format(i)
        run_cli("simulate", SI_ENGINE, "--cycle", "nedc", "--set", "m={}".format(m), "--summary-json", out)
        summary = json.loads(out.read_text())
        summary.pop("provenance", None)  # the command line's record of its invocation
        cli = _flatten(summary)
        assert_close({k: df.iloc[i][k] for k in cli}, cli)


def test_threads_and_engines_agree(si_engine):
    params = {"m": MASSES, "C_d": CDS}
    one = si_engine.sweep(params=params, cycles=["ece"], threads=1)
    two = si_engine.sweep(params=params, cycles=["ece"], threads=2)
    pd.testing.assert_frame_equal(one, two)
    interp = invsim.Model(SI_ENGINE, engine="interpreted").sweep(params=params, cycles=["ece"], threads=2)
    assert (interp["engine"] == "interpreted").all()
    for c in ["integrals.fuel", "integrals_per_100km.fuel_volume", "input_max"]:
        np.testing.assert_allclose(interp[c], one[c], rtol=1e-12)


def test_failing_variant_is_a_row(si_engine):
    df = si_engine.sweep(params={"m": [1300.0, float("nan"), 1400.0]}, cycles=["ece"])
    assert len(df) == 3
    assert df["error"].isna().tolist() == [True, False, True]
    assert "finite" in df["error"][1]
    assert df["integrals.fuel"][2] > df["integrals.fuel"][0]


def test_inputs_and_defaults(si_engine):
    base = si_engine.sweep(cycles="ece")
    assert len(base) == 1 and base["m"][0] == 1300.0
    single = si_engine.simulate(cycle="ece", keep_series=False)
    assert base["integrals.fuel"][0] == single.summary["integrals"]["fuel"]
    pl = pytest.importorskip("polars")
    a = si_engine.sweep(params=pl.DataFrame({"m": MASSES}), cycles=["ece"])
    b = si_engine.sweep(params={"m": np.array(MASSES)}, cycles=["ece"])
    pd.testing.assert_frame_equal(a, b)
    with_base = si_engine.sweep(params={"m": MASSES}, cycles=["ece"], base={"C_d": 0.3})
    assert (with_base["C_d"] == 0.3).all()


def test_sweep_errors(si_engine):
    with pytest.raises(invsim.InvsimError, match="no such parameter"):
        si_engine.sweep(params={"nosuch": [1.0]}, cycles=["ece"])
    with pytest.raises(invsim.InvsimError, match="one value per variant"):
        si_engine.sweep(params={"m": [1.0, 2.0], "C_d": [0.3]}, cycles=["ece"])
    with pytest.raises(invsim.InvsimError, match="nocycle"):
        si_engine.sweep(params={"m": [1300.0]}, cycles=["nocycle"])


def test_shared_model_sweep():
    path = shared_model("motor_pendulum.toml")
    m = invsim.Model(path)
    names = m.derive()["parameters"]
    name = next(iter(names))
    values = [names[name] * f for f in (0.9, 1.0, 1.1)]
    df = m.sweep(params={name: values}, cycles=["ece"])
    for i, v in enumerate(values):
        single = _flatten(m.simulate(cycle="ece", params={name: v}, keep_series=False).summary)
        assert all(df.iloc[i][k] == x for k, x in single.items())


def test_unaligned_columns_are_copied(si_engine):
    # A float64 array starting one byte into its buffer, as Dask or pickle can hand over after deserialising
    # in place: the wrapper copies it to an aligned array, and the extension refuses an unaligned one.
    values = np.array([1200.0, 1350.0, 1500.0])
    raw = np.zeros(values.nbytes + 1, dtype=np.uint8)
    raw[1:] = values.view(np.uint8)
    unaligned = np.frombuffer(raw[1:].data, dtype=np.float64)
    assert not unaligned.flags.aligned
    np.testing.assert_array_equal(unaligned, values)
    got = si_engine.sweep(params={"m": unaligned}, cycles=["ece"])
    pd.testing.assert_frame_equal(got, si_engine.sweep(params={"m": values}, cycles=["ece"]))
    with pytest.raises(ValueError, match="not aligned"):
        si_engine._m.sweep(["m"], [unaligned], ["ece"], [], 1.0, 5.0, False, None, [], [])
