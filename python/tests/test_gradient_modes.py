"""Gradients of a model with modes from Python and the pieces of python/examples/optimise_gears.py that need no
scipy: `simulate(gradient=...)` of si_engine_5speed equals the command line's block (a gear's ratio by its
per-gear name `i_g[3]`, set by `params={"i_g[3]": ...}` as by `--set`); the example's WLTC l/100 km gradient
against central differences of two runs; its 0-100 km/h time's complex-step derivatives against central
differences of the closed form."""

import importlib.util
import json

import numpy as np
import pytest

import invsim
from conftest import REPO, run_cli

FIVE_SPEED = REPO / "models" / "si_engine_5speed.toml"


def example():
    spec = importlib.util.spec_from_file_location("optimise_gears", REPO / "python" / "examples" / "optimise_gears.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_modal_gradient_equals_the_command_line_s(tmp_path):
    names = ["m", "i_f", "i_g[3]"]
    run = invsim.Model(FIVE_SPEED).simulate(cycle="ece", params={"i_g[2]": 2.1}, keep_series=False, gradient=names)
    out = tmp_path / "s.json"
    run_cli("simulate", FIVE_SPEED, "--cycle", "ece", "--set", "i_g[2]=2.1", "--gradient", ",".join(names),
            "--summary-json", out)
    cli = json.loads(out.read_text())
    assert run.summary["gradient"] == cli["gradient"]
    frame = run.gradient
    assert list(frame.index) == sorted(names)
    assert frame.loc["i_g[3]", "fuel"] == cli["gradient"]["fuel"]["i_g[3]"] != 0.0


def test_the_example_s_fuel_gradient_against_central_differences():
    ex = example()
    fuel = ex.Fuel(invsim.Model(FIVE_SPEED))
    _, _, x0, _, _ = ex.problem()
    f0, g = fuel.value_and_gradient(x0)
    assert fuel.runs == 1
    for j in (0, 2):  # the final drive and third gear
        h = 1e-4 * x0[j]
        xp, xm = x0.copy(), x0.copy()
        xp[j] += h
        xm[j] -= h
        fd = (fuel.value(xp) - fuel.value(xm)) / (2 * h)
        assert abs(g[j] - fd) <= 1e-6 * abs(fd), (ex.NAMES[j], g[j], fd)


def test_the_0_100_time_and_its_complex_step_derivatives():
    ex = example()
    p, ratios, x0, _, t_max = ex.problem()
    assert 8.0 < t_max < 14.0  # a 2.0 l car of 1300 kg
    t, grad = ex.t_100_and_gradient(p, ratios, x0)
    assert t == t_max
    for j in range(len(x0)):
        h = 1e-6 * x0[j]
        xp, xm = x0.copy(), x0.copy()
        xp[j] += h
        xm[j] -= h
        fd = (ex.t_100_and_gradient(p, ratios, xp)[0] - ex.t_100_and_gradient(p, ratios, xm)[0]) / (2 * h)
        assert abs(grad[j] - fd) <= 1e-7 * max(abs(fd), 1e-3), (ex.NAMES[j], grad[j], fd)
    # Gears 4 and 5 are not reached below 100 km/h at the shift speed: the time does not depend on them.
    assert grad[3] == grad[4] == 0.0
    # Taller gears (smaller ratios) are slower.
    assert np.all(grad[:3] < 0.0)
