"""`Model.sweep()`: one row per variant x cycle, equal to the single runs and to the command line; `grid=` is
`invsim sweep --grid` (every combination, last axis fastest), `table=` is `--table` (rows as given)."""

import json
import warnings

import numpy as np
import pandas as pd
import pytest

import invsim
from conftest import SI_ENGINE, assert_close, assert_rows_equal_cli, cli_json, cli_sweep, run_cli, shared_model
from invsim import _flatten

MASSES = [1100.0, 1300.0, 1500.0]
CDS = [0.28, 0.32, 0.36]


def row_summary(row):
    """The summary of a sweep row, as the single run's flattened summary (NaN columns of other rows dropped)."""
    return {k: v for k, v in row.items() if not (isinstance(v, float) and np.isnan(v))}


def test_rows_equal_single_runs(si_engine):
    df = si_engine.sweep(table={"m": MASSES, "C_d": CDS}, cycles=["nedc", "udds"], dt=0.5)
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
    df = si_engine.sweep(table=pd.DataFrame({"m": MASSES[:2]}), cycles=["nedc"])
    for i, m in enumerate(MASSES[:2]):
        out = tmp_path / "s{}.json".format(i)
        run_cli("simulate", SI_ENGINE, "--cycle", "nedc", "--set", "m={}".format(m), "--summary-json", out)
        summary = json.loads(out.read_text())
        summary.pop("provenance", None)  # the command line's record of its invocation
        cli = _flatten(summary)
        assert_close({k: df.iloc[i][k] for k in cli}, cli)


def test_threads_and_engines_agree(si_engine):
    grid = {"m": MASSES, "C_d": CDS}
    one = si_engine.sweep(grid=grid, cycles=["ece"], threads=1)
    two = si_engine.sweep(grid=grid, cycles=["ece"], threads=2)
    assert len(one) == 9
    pd.testing.assert_frame_equal(one, two)
    interp = invsim.Model(SI_ENGINE, engine="interpreted").sweep(grid=grid, cycles=["ece"], threads=2)
    assert (interp["engine"] == "interpreted").all()
    for c in ["integrals.fuel", "integrals_per_100km.fuel_volume", "input_max"]:
        np.testing.assert_allclose(interp[c], one[c], rtol=1e-12)


def test_failing_variant_is_a_row(si_engine):
    # A wheel radius of 0 makes the decoupling coefficient NaN: that run fails, the sweep goes on.
    df = si_engine.sweep(table={"r_w": [0.3, 0.0, 0.32]}, cycles=["ece"])
    assert len(df) == 3
    assert df["error"].isna().tolist() == [True, False, True]
    assert "decoupling coefficient" in df["error"][1] and "ece" in df["error"][1]
    assert df["r_w"].tolist() == [0.3, 0.0, 0.32]
    assert df["integrals.fuel"][2] != df["integrals.fuel"][0]


def test_inputs_and_defaults(si_engine):
    base = si_engine.sweep(grid={"m": [1300.0]}, cycles="ece")
    assert len(base) == 1 and base["m"][0] == 1300.0
    single = si_engine.simulate(cycle="ece", keep_series=False)
    assert base["integrals.fuel"][0] == single.summary["integrals"]["fuel"]
    pl = pytest.importorskip("polars")
    a = si_engine.sweep(table=pl.DataFrame({"m": MASSES}), cycles=["ece"])
    b = si_engine.sweep(table={"m": np.array(MASSES)}, cycles=["ece"])
    pd.testing.assert_frame_equal(a, b)
    # One parameter: the grid and the table are the same variants.
    pd.testing.assert_frame_equal(si_engine.sweep(grid={"m": MASSES}, cycles=["ece"]), b)
    with_base = si_engine.sweep(grid={"m": MASSES}, cycles=["ece"], base={"C_d": 0.3})
    assert (with_base["C_d"] == 0.3).all()


def test_sweep_errors(si_engine):
    with pytest.raises(invsim.InvsimError, match="no such parameter"):
        si_engine.sweep(table={"nosuch": [1.0]}, cycles=["ece"])
    with pytest.raises(ValueError, match="column `C_d` has 1 value.*one value per variant"):
        si_engine.sweep(table={"m": [1.0, 2.0], "C_d": [0.3]}, cycles=["ece"])
    with pytest.raises(invsim.InvsimError, match="nocycle"):
        si_engine.sweep(table={"m": [1300.0]}, cycles=["nocycle"])


def test_shared_model_sweep():
    path = shared_model("motor_pendulum.toml")
    m = invsim.Model(path)
    names = m.derive()["parameters"]
    name = next(iter(names))
    values = [names[name] * f for f in (0.9, 1.0, 1.1)]
    df = m.sweep(grid={name: values}, cycles=["ece"])
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
    got = si_engine.sweep(table={"m": unaligned}, cycles=["ece"])
    pd.testing.assert_frame_equal(got, si_engine.sweep(table={"m": values}, cycles=["ece"]))
    with pytest.raises(ValueError, match="not aligned"):
        si_engine._m.sweep(["m"], [unaligned], ["ece"], [], 1.0, 5.0, False, None, [], [])


def test_grid_equals_cli_grid(si_engine, tmp_path):
    # --grid m=1100:1500:3 --grid C_d=0.28:0.36:3 are the values of np.linspace on the same numbers, bit for
    # bit; 9 variants, C_d (the last axis) varying fastest, each on both cycles.
    header, rows = cli_sweep(
        tmp_path,
        SI_ENGINE,
        "--cycles",
        "ece,udds",
        "--dt",
        "0.5",
        "--grid",
        "m=1100:1500:3",
        "--grid",
        "C_d=0.28:0.36:3",
    )
    grid = {"m": np.linspace(1100, 1500, 3), "C_d": np.linspace(0.28, 0.36, 3)}
    df = si_engine.sweep(grid=grid, cycles=["ece", "udds"], dt=0.5)
    assert len(df) == 18
    assert list(df["variant"]) == [i // 2 for i in range(18)]
    assert list(df["cycle"]) == ["ece", "udds"] * 9
    assert list(df["m"][::2]) == [1100.0] * 3 + [1300.0] * 3 + [1500.0] * 3
    assert list(df["C_d"][::2]) == list(grid["C_d"]) * 3
    assert_rows_equal_cli(df, header, rows, ["m", "C_d"])
    # A grid of lists gives the same rows as one of arrays.
    lists = si_engine.sweep(grid={k: list(v) for k, v in grid.items()}, cycles=["ece", "udds"], dt=0.5)
    pd.testing.assert_frame_equal(lists, df)


def test_table_equals_cli_table(si_engine, tmp_path):
    # Rows as given, in their order (neither sorted nor combined): 3 variants, as --table.
    table = pd.DataFrame({"C_d": [0.36, 0.28, 0.32], "m": [1500.0, 1100.0, 1300.0]})
    path = tmp_path / "variants.csv"
    table.to_csv(path, index=False)
    header, rows = cli_sweep(tmp_path, SI_ENGINE, "--cycles", "ece,udds", "--dt", "0.5", "--table", path)
    df = si_engine.sweep(table=table, cycles=["ece", "udds"], dt=0.5)
    assert list(df["m"][::2]) == [1500.0, 1100.0, 1300.0]
    assert_rows_equal_cli(df, header, rows, ["C_d", "m"])


def test_params_is_a_deprecated_table(si_engine):
    frame = pd.DataFrame({"m": MASSES, "C_d": CDS})
    with pytest.warns(DeprecationWarning, match="table=.*grid="):
        old = si_engine.sweep(params=frame, cycles=["ece"])
    pd.testing.assert_frame_equal(old, si_engine.sweep(table=frame, cycles=["ece"]))
    with pytest.warns(DeprecationWarning):
        one = si_engine.sweep({"m": MASSES}, cycles=["ece"])  # positional, one parameter: grid = table
    pd.testing.assert_frame_equal(one, si_engine.sweep(grid={"m": MASSES}, cycles=["ece"]))
    # A dict of several parameters with several values each reads as a grid too: refused, naming both.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"ambiguous: grid= .*\(9 variants.*table= .*\(3 variants"):
            si_engine.sweep(params={"m": MASSES, "C_d": CDS}, cycles=["ece"])


def test_grid_and_table_errors(si_engine):
    with pytest.raises(ValueError, match="needs grid=.*or table="):
        si_engine.sweep(cycles=["ece"])
    with pytest.raises(ValueError, match="not grid= and table="):
        si_engine.sweep(grid={"m": MASSES}, table={"m": MASSES}, cycles=["ece"])
    with pytest.raises(ValueError, match="not table= and params="):
        si_engine.sweep(params={"m": MASSES}, table={"m": MASSES}, cycles=["ece"])
    with pytest.raises(ValueError, match=r"grid axis `m`: value nan \(index 1\) is not a finite number"):
        si_engine.sweep(grid={"m": [1300.0, float("nan")]}, cycles=["ece"])
    with pytest.raises(ValueError, match="table column `C_d`: value inf"):
        si_engine.sweep(table={"m": [1300.0], "C_d": [float("inf")]}, cycles=["ece"])
    with pytest.raises(ValueError, match="grid axis `m`: needs at least one value"):
        si_engine.sweep(grid={"m": []}, cycles=["ece"])
    with pytest.raises(ValueError, match="table=: the table has no variants"):
        si_engine.sweep(table=pd.DataFrame({"m": []}), cycles=["ece"])
    with pytest.raises(ValueError, match="grid axis `m`: the values must be numbers"):
        si_engine.sweep(grid={"m": ["heavy"]}, cycles=["ece"])
    with pytest.raises(ValueError, match=r"not '1000:1800:9' \(the command line's START:STOP:N is numpy.linspace"):
        si_engine.sweep(grid={"m": "1000:1800:9"}, cycles=["ece"])
    with pytest.raises(ValueError, match="grid=: no parameter given"):
        si_engine.sweep(grid={}, cycles=["ece"])
    with pytest.raises(TypeError, match="grid=: give a dict"):
        si_engine.sweep(grid=[1300.0], cycles=["ece"])
    with pytest.raises(ValueError, match="table=: parameter `m` is given twice"):
        si_engine.sweep(table=pd.DataFrame([[1.0, 2.0]], columns=["m", "m"]), cycles=["ece"])
    with pytest.raises(ValueError, match=r"parameter `m` is both set \(base=\) and swept \(grid=\)"):
        si_engine.sweep(grid={"m": MASSES}, base={"m": 1300.0}, cycles=["ece"])
    with pytest.raises(ValueError, match="needs a cycle"):
        si_engine.sweep(grid={"m": MASSES}, cycles=[])


def test_run_limit_is_the_command_lines(si_engine):
    assert invsim.max_sweep_runs == 1_000_000
    # Two axes of 1001 values: refused before the product (1,002,001 variants) is made, as --grid.
    axis = np.linspace(1000, 2000, 1001)
    with pytest.raises(invsim.InvsimError) as py:
        si_engine.sweep(grid={"m": axis, "C_d": axis}, cycles=["ece"])
    message = "1.002e6 runs (2 grid axes × 1 cycle) exceed the limit of 1000000 runs a sweep makes; sweep fewer values"
    assert str(py.value) == "sweep: " + message
    grid = ["--grid", "m=1000:2000:1001", "--grid", "C_d=1000:2000:1001"]
    cli = run_cli("sweep", SI_ENGINE, "--cycle", "ece", *grid, check=False)
    assert cli.returncode != 0 and message in cli.stderr
    # A table counts its rows times the cycles: 500,001 rows on 2 cycles are too many; on 1 cycle the count
    # passes (the unknown parameter is what is refused then).
    rows = np.full(500_001, 1300.0)
    with pytest.raises(invsim.InvsimError, match=r"runs \(a table of 500001 rows × 2 cycles\) exceed the limit"):
        si_engine.sweep(table={"m": rows}, cycles=["ece", "udds"])
    with pytest.raises(invsim.InvsimError, match="no such parameter"):
        si_engine.sweep(table={"nosuch": rows}, cycles=["ece"])
