"""`invsim sweep --out FILE.parquet`: the Parquet file holds the CSV's rows, read by independent readers."""

import math

import polars as pl
import pytest

from conftest import run_cli

SWEEP = ["sweep", "models/si_engine.toml", "--cycles", "ece,eudc", "--grid", "i_t=0:5:3", "--verify"]


def _both(tmp_path):
    csv, parquet = tmp_path / "rows.csv", tmp_path / "rows.parquet"
    for out in (csv, parquet):
        p = run_cli(*SWEEP, "--out", out, check=False)
        # i_t = 0 makes beta vanish: those rows fail, and the sweep exits 3.
        assert p.returncode == 3, p.stderr
    return pl.read_csv(csv), pl.read_parquet(parquet)


def test_parquet_equals_csv_with_types_and_nulls(tmp_path):
    csv, pq = _both(tmp_path)
    assert pq.columns == csv.columns
    assert pq.height == csv.height == 6
    assert pq.schema["variant"] == pl.Int64 and pq.schema["samples"] == pl.Int64
    assert pq.schema["cycle"] == pl.String and pq.schema["fuel"] == pl.Float64
    failed = pq.filter(pl.col("status") == "error")
    assert failed.height == 2
    assert failed["fuel"].null_count() == 2 and failed["error"].null_count() == 0
    assert pq.filter(pl.col("status") == "ok")["error"].null_count() == 4
    for name in pq.columns:
        for a, b in zip(pq[name].to_list(), csv[name].to_list()):
            if isinstance(a, float) and isinstance(b, float):
                # The CSV holds Rust's shortest round-trip form: the same double.
                assert a == b or (math.isnan(a) and math.isnan(b)), (name, a, b)
            else:
                assert a == b or (a is None and b in (None, "")), (name, a, b)


def test_parquet_reads_with_pyarrow_when_installed(tmp_path):
    pq = pytest.importorskip("pyarrow.parquet", reason="pyarrow is not installed: polars alone checked it")
    _, rows = _both(tmp_path)
    table = pq.read_table(tmp_path / "rows.parquet")
    assert table.num_rows == rows.height
    assert table.column("fuel").to_pylist() == rows["fuel"].to_list()
