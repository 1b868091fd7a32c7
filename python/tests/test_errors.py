"""Errors are `invsim.InvsimError` (a ValueError) with the command line's message, file, line and column."""

import pytest

import invsim
from conftest import SI_ENGINE, run_cli, shared_model


def cli_error(*args):
    p = run_cli(*args, check=False)
    assert p.returncode == 2, p.stderr
    return p.stderr


def test_unknown_symbol_has_position():
    path = shared_model("bad_unknown_symbol.toml")
    with pytest.raises(invsim.InvsimError) as e:
        invsim.Model(path)
    err = e.value
    assert isinstance(err, ValueError)
    assert err.file == str(path) and err.line is not None and err.column is not None
    assert "c9" in str(err)
    assert "{}:{}:{}".format(path, err.line, err.column) in str(err)
    assert str(err) in cli_error("derive", path)


@pytest.mark.parametrize("name", ["bad_no_relative_degree.toml"])
def test_bad_shared_models(name):
    path = shared_model(name)
    with pytest.raises(invsim.InvsimError) as e:
        invsim.Model(path)
    assert e.value.file == str(path)
    assert str(e.value) in cli_error("derive", path)


def test_missing_file(tmp_path):
    path = tmp_path / "nope.toml"
    with pytest.raises(invsim.InvsimError) as e:
        invsim.Model(path)
    assert e.value.file == str(path) and e.value.line is None


def test_run_errors_equal_cli(si_engine):
    cases = [
        (dict(cycle="nocycle"), ["--cycle", "nocycle"]),
        (dict(cycle="nedc", dt=-1.0), ["--cycle", "nedc", "--dt=-1"]),
        (dict(cycle="nedc", lookahead=0.0), ["--cycle", "nedc", "--lookahead", "0"]),
    ]
    for kwargs, args in cases:
        with pytest.raises(invsim.InvsimError) as e:
            si_engine.simulate(**kwargs)
        assert str(e.value) in cli_error("simulate", SI_ENGINE, *args), kwargs


def test_bad_parameter(si_engine):
    with pytest.raises(invsim.InvsimError, match="nosuch"):
        si_engine.simulate(cycle="nedc", params={"nosuch": 1.0})
    with pytest.raises(invsim.InvsimError, match="finite"):
        si_engine.simulate(cycle="nedc", params={"m": float("inf")})


def test_compiled_engine_needs_builtin():
    with pytest.raises(invsim.InvsimError, match="no compiled code"):
        invsim.Model(shared_model("motor_pendulum.toml"), engine="compiled")
    with pytest.raises(invsim.InvsimError, match="engine"):
        invsim.Model(SI_ENGINE, engine="fast")


def test_unknown_or_bad_signals_are_errors(si_engine):
    # si_engine has no [signals]: a signal given for it is an error naming it, as `--signal` is.
    with pytest.raises(invsim.InvsimError, match="grade"):
        si_engine.simulate(cycle="nedc", signals={"grade": 0.01})
    with pytest.raises(invsim.InvsimError, match="not finite"):
        si_engine.simulate(cycle="nedc", signals={"grade": float("nan")})
    with pytest.raises(invsim.InvsimError, match="increase strictly"):
        si_engine.simulate(cycle="nedc", signals={"grade": ([0.0, 0.0], [0.0, 0.1])})
    with pytest.raises(invsim.InvsimError, match="give a number"):
        si_engine.simulate(cycle="nedc", signals={"grade": object()})
