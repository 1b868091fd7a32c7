"""`Model.simulate()` against `invsim simulate --summary-json … --out …`."""

import json

import numpy as np
import pandas as pd
import pytest

import invsim
from conftest import REPO, SHARED, SI_ENGINE, assert_close, run_cli, shared_model


def cli_run(tmp_path, model, *args):
    summary, csv = tmp_path / "s.json", tmp_path / "r.csv"
    run_cli("simulate", model, *args, "--summary-json", summary, "--out", csv)
    cli = json.loads(summary.read_text())
    # The command line records its own invocation (provenance: command, options, file hashes); the package's
    # summary is the run's, without it.
    cli.pop("provenance", None)
    return cli, pd.read_csv(csv)


def assert_series_equal(result, frame):
    df = result.to_pandas()
    assert list(df.columns) == list(frame.columns)
    for c in frame.columns:
        np.testing.assert_allclose(df[c].to_numpy(), frame[c].to_numpy(), rtol=1e-12, atol=1e-300, err_msg=c)


@pytest.mark.parametrize("cycle", ["nedc", "udds"])
def test_si_engine_equals_cli(si_engine, tmp_path, cycle):
    r = si_engine.simulate(cycle=cycle, dt=0.1, lookahead=5.0)
    summary, frame = cli_run(tmp_path, SI_ENGINE, "--cycle", cycle, "--dt", "0.1", "--lookahead", "5")
    assert_close(r.summary, summary)
    assert r.summary["engine"] == "compiled"
    assert_series_equal(r, frame)


def test_params_and_verify_equal_cli(si_engine, tmp_path):
    r = si_engine.simulate(cycle="nedc", dt=0.5, lookahead=3.0, params={"m": 1500.0, "C_d": 0.3}, verify=True)
    summary, frame = cli_run(
        tmp_path, SI_ENGINE, "--cycle", "nedc", "--dt", "0.5", "--lookahead", "3", "--set", "m=1500",
        "--set", "C_d=0.3", "--verify",
    )
    assert_close(r.summary, summary)
    assert "max_abs_tracking_error" in r.summary
    assert_series_equal(r, frame)


def test_interpreted_engine_equals_compiled(si_engine):
    a = si_engine.simulate(cycle="ece", dt=0.1)
    b = invsim.Model(SI_ENGINE, engine="interpreted").simulate(cycle="ece", dt=0.1)
    assert b.summary["engine"] == "interpreted"
    for c in a.columns:
        # 1e-12 relative to the column's scale (T_e is a difference that cancels to ~1e-15 at standstill).
        scale = max(np.abs(a[c]).max(), 1.0)
        np.testing.assert_allclose(a[c], b[c], rtol=1e-12, atol=1e-12 * scale, err_msg=c)


def test_cycle_file_path(si_engine, tmp_path):
    udds = SHARED / "cycles" / "udds.csv"
    if not udds.exists():
        pytest.skip("shared cycle udds.csv is absent (expected at {})".format(udds))
    r = si_engine.simulate(cycle=str(udds), dt=1.0)
    summary, frame = cli_run(tmp_path, SI_ENGINE, "--cycle", udds, "--dt", "1")
    assert_close(r.summary, summary)
    assert_series_equal(r, frame)


@pytest.mark.parametrize("name", ["motor_pendulum.toml", "internal_dynamics.toml"])
def test_shared_model_equals_cli(tmp_path, name):
    path = shared_model(name)
    r = invsim.Model(path).simulate(cycle="ece", dt=0.1)
    summary, frame = cli_run(tmp_path, path, "--cycle", "ece", "--dt", "0.1")
    assert r.summary["engine"] == "interpreted"
    assert_close(r.summary, summary)
    assert_series_equal(r, frame)


def test_frames_and_units(si_engine):
    r = si_engine.simulate(cycle="ece")
    df = r.to_pandas()
    assert df.attrs["units"]["v"] == "m/s" and df.attrs["units"]["t"] == "s"
    assert df.attrs["units"]["yd_1"] == "m/s/s"
    assert len(df) == r.summary["samples"]
    # The arrays are the extension's buffers, handed over without a copy, and writable.
    assert r["t"].flags.owndata is False and r["t"].dtype == np.float64
    pl = pytest.importorskip("polars")
    f = r.to_polars()
    assert f.columns == r.columns and f.height == len(df)
    assert "v [m/s]" in r.to_polars(units_in_names=True).columns


def test_summary_only(si_engine):
    full = si_engine.simulate(cycle="ece")
    light = si_engine.simulate(cycle="ece", keep_series=False)
    assert light.summary == full.summary
    assert all(len(a) == 0 for a in light.arrays.values())


def test_pickle_round_trip(si_engine):
    import pickle

    m = pickle.loads(pickle.dumps(si_engine))
    assert m.engine == "compiled" and m.derive() == si_engine.derive()
    assert m.simulate(cycle="ece").summary == si_engine.simulate(cycle="ece").summary


def test_summary_is_read_once_and_pickles(si_engine):
    """The summary is parsed when first read, the same dict each time after; a pickled result carries it."""
    import pickle

    r = si_engine.simulate(cycle="udds", dt=1.0, keep_series=False)
    first = r.summary
    assert r.summary is first
    assert first["samples"] == 1370 and first["integrals"]["fuel"] > 0
    back = pickle.loads(pickle.dumps(r))
    assert back.summary == first and back.columns == r.columns


def test_auto_lookahead_as_on_the_command_line(si_engine, tmp_path):
    """`lookahead="auto"` chooses the look-ahead per cycle as `invsim simulate --lookahead auto` does: the same
    look-ahead, the same choice block, the same fuel; the default stays 5 s, as on the command line."""
    r = si_engine.simulate(cycle="udds", dt=0.1, lookahead="auto")
    summary, frame = cli_run(tmp_path, SI_ENGINE, "--cycle", "udds", "--dt", "0.1", "--lookahead", "auto")
    choice = r.summary["lookahead_choice"]
    assert choice["method"] == "auto" and choice["accepted"] is True
    assert r.summary["lookahead_s"] == summary["lookahead_s"] == choice["lookahead_s"] == 1.0
    assert r.summary["lookahead_choice"] == summary["lookahead_choice"]
    assert r.summary["tolerance_band"]["samples_outside"] == 0
    assert r.summary["integrals"]["fuel"] == summary["integrals"]["fuel"]
    default = si_engine.simulate(cycle="udds", dt=0.1)
    assert "lookahead_choice" not in default.summary and default.summary["lookahead_s"] == 5.0


def test_auto_lookahead_follows_a_changed_cycle_file(si_engine, tmp_path):
    """The package remembers the choice per cycle, by the cycle's contents: a cycle file rewritten between two
    runs gets the choice the command line makes for its new contents."""
    path = tmp_path / "c.csv"
    gentle = "time_s,speed_mps\n0,0\n10,0\n40,20\n100,20\n130,0\n160,0\n"
    sharp = "time_s,speed_mps\n0,0\n10,0\n14,8\n16,3\n20,12\n24,0\n60,0\n64,9\n66,2\n70,0\n100,0\n"
    chosen = []
    for text in (gentle, sharp, gentle):
        path.write_text(text)
        r = si_engine.simulate(cycle=str(path), dt=0.1, lookahead="auto")
        cli, _ = cli_run(tmp_path, SI_ENGINE, "--cycle", str(path), "--dt", "0.1", "--lookahead", "auto")
        assert r.summary["lookahead_choice"] == cli["lookahead_choice"]
        assert r.summary["integrals"]["fuel"] == cli["integrals"]["fuel"]
        chosen.append(r.summary["lookahead_s"])
    assert chosen == [2.5, 0.1, 2.5]


def test_summary_leads_with_the_headline(si_engine):
    """The run's summary carries the CLI's `headline` block: l/100 km, mpg (US, UK) and CO2 g/km."""
    s = si_engine.simulate(cycle="ece", dt=0.1).summary
    assert list(s)[0] == "headline"
    h = s["headline"]
    assert (h["output"], h["kind"], h["fuel"]) == ("fuel_volume", "fuel", "petrol")
    assert h["l_per_100km"] == s["integrals_per_100km"]["fuel_volume"]
    # 100 km = 62.137 mi; l/100 km litres = l/100 km / 3.785411784 US gallons.
    assert h["mpg_us"] == pytest.approx(100 * 3.785411784 / (1.609344 * h["l_per_100km"]), rel=1e-12)


def test_a_cycle_in_the_wrong_unit_warns_before_the_run(tmp_path):
    # km/h values (up to 80) in a `speed_mps` column: a top speed no drive cycle reaches in m/s. The warning
    # comes before the run, as on the command line, and is the summary's first warning.
    import math

    import invsim

    path = tmp_path / "kmh_in_mps.csv"
    rows = "".join(f"{t},{abs(80 * math.sin(math.pi * t / 100)):.3f}\n" for t in range(101))
    path.write_text("time_s,speed_mps\n" + rows)
    model = invsim.Model(str(SI_ENGINE.parent / "bev.toml"))
    with pytest.warns(UserWarning, match="probably holds km/h"):
        run = model.simulate(cycle=str(path), dt=0.1)
    assert "probably holds km/h" in run.summary["warnings"][0]
    # The forward run dies at 80 m/s (its driver cannot follow): the warning came before it, which says why.
    with pytest.warns(UserWarning, match="probably holds km/h"):
        with pytest.raises(invsim.InvsimError, match="forward integration failed"):
            model.forward(cycle=str(path), dt=0.1)
    # A built-in cycle has none.
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model.simulate(cycle="nedc", dt=1.0)


def test_a_map_s_grid_values_are_gradient_names_as_on_the_command_line(tmp_path):
    # `bsfc[3,2]` keeps its comma whether the names come as one string (split at every comma and joined back
    # by the runtime) or as a list; the block equals the command line's bit for bit.
    maps = REPO / "models" / "si_engine_maps.toml"
    model = invsim.Model(maps)
    names = "m,bsfc[3,2],eta_vol[4,2]"
    by_string = model.simulate(cycle="ece", keep_series=False, gradient=names)
    by_list = model.simulate(cycle="ece", keep_series=False, gradient=["m", "bsfc[3,2]", "eta_vol[4,2]"])
    summary, _ = cli_run(tmp_path, maps, "--cycle", "ece", "--gradient", names)
    assert by_string.summary["gradient"] == summary["gradient"] == by_list.summary["gradient"]
    g = by_string.gradient
    assert sorted(g.index) == ["bsfc[3,2]", "eta_vol[4,2]", "m"]
    assert g.loc["eta_vol[4,2]", "fuel"] != 0.0 and g.loc["bsfc[3,2]", "fuel_bsfc"] != 0.0


def test_gradient_is_the_cli_block_and_the_slope_of_the_fuel(si_engine, tmp_path):
    r = si_engine.simulate(cycle="ece", dt=0.1, lookahead=5.0, gradient=["m", "C_d"], keep_series=False)
    g = r.gradient
    assert sorted(g.index) == ["C_d", "m"] and "fuel" in g.columns and "fuel_per_100km" in g.columns
    summary, _ = cli_run(tmp_path, SI_ENGINE, "--cycle", "ece", "--gradient", "m,C_d")
    for figure, row in summary["gradient"].items():
        for p, v in row.items():
            assert g.loc[p, figure] == pytest.approx(v, rel=1e-12), (figure, p)
    # d fuel / d m (at the file's m = 1300 kg) against central differences of two runs (r = n: the fuel is
    # smooth in m away from the standstill kink, a step of 1e-6 of m stays clear of it).
    m, h = 1300.0, 1300.0 * 1e-6

    def fuel(mass):
        return si_engine.simulate(cycle="ece", params={"m": mass}, keep_series=False).summary["integrals"]["fuel"]

    fd = (fuel(m + h) - fuel(m - h)) / (2 * h)
    assert g.loc["m", "fuel"] == pytest.approx(fd, rel=1e-6)
    assert si_engine.simulate(cycle="ece", keep_series=False).gradient is None
    with pytest.raises(invsim.InvsimError, match="nosuch"):
        si_engine.simulate(cycle="ece", gradient="nosuch")
