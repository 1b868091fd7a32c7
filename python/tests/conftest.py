"""Shared fixtures: the repository, the `invsim` command line to compare with, the shared models.

The command line is `$INVSIM_BIN` if set, else the repository's `target/release/invsim` (built by
`cargo build --release -p invsim`), else `cargo run --release -q --`. `.ci/python` sets it to the dev-profile
build that `cargo test --workspace` has already made.
"""

import csv
import json
import math
import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SHARED = REPO.parent / "shared"
SI_ENGINE = REPO / "models" / "si_engine.toml"


def _cli_command():
    if os.environ.get("INVSIM_BIN"):
        return [os.environ["INVSIM_BIN"]]
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    binary = target / "release" / "invsim"
    if binary.exists():
        return [str(binary)]
    if shutil.which("cargo"):
        return ["cargo", "run", "--release", "-q", "--manifest-path", str(REPO / "Cargo.toml"), "-p", "invsim", "--"]
    return None


CLI = _cli_command()


def run_cli(*args, check=True):
    """Run `invsim ARGS…`; returns the CompletedProcess (text)."""
    if CLI is None:
        pytest.skip("no invsim command line to compare with (set INVSIM_BIN or build target/release/invsim)")
    p = subprocess.run(CLI + [str(a) for a in args], capture_output=True, text=True, cwd=REPO)
    if check and p.returncode != 0:
        raise AssertionError("invsim {} failed ({}): {}".format(args, p.returncode, p.stderr))
    return p


def cli_json(*args):
    return json.loads(run_cli(*args).stdout)


def shared_model(name):
    """A model of ../shared/models, or a skip saying it is absent."""
    path = SHARED / "models" / name
    if not path.exists():
        pytest.skip("shared model {} is absent (expected at {})".format(name, path))
    return path


def assert_close(a, b, rel=1e-12, path="$"):
    """Equal JSON-like values: numbers within `rel` relative (or 1e-300 absolute), the rest exactly."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), "{}: keys {} != {}".format(path, list(a), list(b))
        for k in a:
            assert_close(a[k], b[k], rel, path + "." + k)
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), "{}: {} != {}".format(path, a, b)
        for i, (x, y) in enumerate(zip(a, b)):
            assert_close(x, y, rel, "{}[{}]".format(path, i))
    elif isinstance(a, float) or isinstance(b, float):
        assert math.isclose(a, b, rel_tol=rel, abs_tol=1e-300), "{}: {} != {}".format(path, a, b)
    else:
        assert a == b, "{}: {!r} != {!r}".format(path, a, b)


def cli_sweep(tmp_path, *args):
    """`invsim sweep ARGS --out FILE.csv`: the header and the rows (text fields)."""
    out = tmp_path / "sweep.csv"
    run_cli("sweep", *args, "--out", out)
    with open(out, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


# The command line's columns of a model's `[headline]` (the summary's `headline` block).
HEADLINE_COLUMNS = {"l_per_100km", "mpg_us", "mpg_uk", "co2_g_per_km", "kwh_per_100km", "mpgge"}


def assert_rows_equal_cli(df, header, rows, swept):
    """The Python sweep's rows are the command line's: same count and order (variant, cycle), the swept values
    and every figure of the CSV equal bit for bit (the CSV writes floats in shortest round-trip form)."""
    assert len(df) == len(rows)
    integrals = header[header.index("distance_m") + 1 : header.index("input_min")]
    assert integrals  # fuel, fuel_volume, their per-100-km figures and the headline's
    for (_, row), fields in zip(df.iterrows(), rows):
        cli = dict(zip(header, fields))
        assert row["variant"] == int(cli["variant"]) and row["cycle"] == cli["cycle"]
        for name in swept:
            assert row[name] == float(cli[name]), name
        assert cli["status"] == "ok" and row["error"] is None
        assert row["samples"] == int(cli["samples"])
        assert row["distance_m"] == float(cli["distance_m"])
        assert row["lookahead_s"] == float(cli["lookahead_s"])
        for name in integrals:
            if name in HEADLINE_COLUMNS:
                key = "headline." + name
            elif name.endswith("_per_100km"):
                key = "integrals_per_100km." + name[: -len("_per_100km")]
            else:
                key = "integrals." + name
            assert row[key] == float(cli[name]), name
        assert row["input_min"] == float(cli["input_min"]) and row["input_max"] == float(cli["input_max"])
        violations = json.loads(row["input_bound_violations"])
        assert len(violations) == int(cli["violations"])
        assert sum(b - a for a, b in violations) + 0.0 == float(cli["violation_s"])



@pytest.fixture(scope="session")
def si_engine():
    import invsim

    return invsim.Model(SI_ENGINE)
