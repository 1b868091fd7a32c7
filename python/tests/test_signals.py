"""Signals and initial states from Python: the same runs as `invsim simulate --signal … --initial …`."""

import json

import numpy as np

import invsim
from conftest import REPO, assert_close, run_cli

GRADE = REPO / "models" / "si_engine_grade.toml"


def _cli_summary(tmp_path, *args):
    out = tmp_path / "summary.json"
    run_cli("simulate", GRADE, "--cycle", "ece", "--dt", "0.5", "--summary-json", out, *args)
    summary = json.loads(out.read_text())
    summary.pop("provenance", None)
    # Where each signal came from (a file's path, Python samples) differs by construction; the numbers may not.
    assert all(s["used"] == "smoothed" for s in summary.pop("signals"))
    return summary


def _py_summary(**kwargs):
    summary = dict(invsim.Model(GRADE).simulate(cycle="ece", dt=0.5, **kwargs).summary)
    summary.pop("provenance", None)
    assert all(s["used"] == "smoothed" for s in summary.pop("signals"))
    return summary


def test_a_constant_signal_equals_the_command_line(tmp_path):
    assert_close(_py_summary(signals={"grade": 0.02}), _cli_summary(tmp_path, "--signal", "grade=0.02"))


def test_signal_samples_equal_a_signal_file(tmp_path):
    times = np.array([0.0, 60.0, 120.0, 195.0])
    grades = np.array([0.0, 0.03, -0.01, 0.0])
    path = tmp_path / "grade.csv"
    path.write_text("time_s,grade\n" + "".join("{},{}\n".format(t, g) for t, g in zip(times, grades)))
    from_file = _cli_summary(tmp_path, "--signal", "grade={}".format(path))
    assert_close(_py_summary(signals={"grade": (times, grades)}), from_file)
    assert_close(_py_summary(signals={"grade": str(path)}), from_file)
    # A grade changes the fuel: the signal reached the model.
    flat = _py_summary()
    assert flat["integrals"]["fuel"] != from_file["integrals"]["fuel"]


def test_sweep_takes_signals_for_every_variant():
    model = invsim.Model(GRADE)
    df = model.sweep(grid={"m": [1200.0, 1400.0]}, cycles=["ece"], dt=0.5, signals={"grade": 0.02})
    for i, m in enumerate([1200.0, 1400.0]):
        one = model.simulate(cycle="ece", dt=0.5, params={"m": m}, signals={"grade": 0.02}).summary
        assert df["integrals.fuel"][i] == one["integrals"]["fuel"]
