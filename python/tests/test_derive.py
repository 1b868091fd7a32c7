"""`Model.derive()` is the command line's `invsim derive --format json`."""

import pytest

import invsim
from conftest import SI_ENGINE, cli_json, shared_model


def test_si_engine_derive_equals_cli(si_engine):
    d = si_engine.derive()
    assert d == cli_json("derive", SI_ENGINE, "--format", "json")
    assert d["relative_degree"] == 2
    assert d["states"] == ["v", "p_i"]


@pytest.mark.parametrize("name", ["motor_pendulum.toml", "internal_dynamics.toml", "singular_decoupling.toml"])
def test_shared_model_derive_equals_cli(name):
    path = shared_model(name)
    m = invsim.Model(path)
    assert m.engine == "interpreted"
    assert m.derive() == cli_json("derive", path, "--format", "json")


def test_motor_pendulum_known_answer():
    d = invsim.Model(shared_model("motor_pendulum.toml")).derive()
    assert d["relative_degree"] == 3 and d["eta"] == []
