"""The gradient of a hybrid's charge-sustaining ECMS fuel from Python: `simulate(strategy="ecms", gradient=...)`
of hev_p2 equals the command line's block (the one figure `fuel_energy_corrected_j`, a gear's ratio by its
per-gear name), as a DataFrame with a row per parameter."""

import json

import invsim
from conftest import REPO, run_cli

HEV = REPO / "models" / "hev_p2.toml"


def test_a_hybrid_gradient_equals_the_command_line_s(tmp_path):
    names = ["m", "C_d", "i_g[2]"]
    run = invsim.Model(HEV).simulate(cycle="udds", dt=1.0, strategy="ecms", keep_series=False, gradient=names)
    out = tmp_path / "s.json"
    run_cli("simulate", HEV, "--cycle", "udds", "--dt", "1", "--strategy", "ecms", "--gradient", ",".join(names),
            "--summary-json", out)
    cli = json.loads(out.read_text())
    assert run.summary["gradient"] == cli["gradient"]
    frame = run.gradient
    assert list(frame.columns) == ["fuel_energy_corrected_j"]
    assert list(frame.index) == sorted(names)
    # Heavier costs fuel: about 4.3 kJ per kg over UDDS.
    assert 3e3 < frame.loc["m", "fuel_energy_corrected_j"] < 6e3
