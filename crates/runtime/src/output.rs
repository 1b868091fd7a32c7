//! Writing results: the per-sample CSV of `invsim simulate --out` and the JSON summary (contract §3).
//!
//! Numbers are written in full precision: the shortest decimal that reads back as the same `f64`, in positional
//! notation for 1e-5 ≤ |v| < 1e16 and in exponent notation (`1.25e-7`) otherwise; non-finite values (which a
//! successful run never produces) are written as `NaN`, `inf`, `-inf`.

use std::io::{self, BufWriter, Write};

use crate::inverse::{SimulationResult, Summary};

/// Write `result` as CSV: a header row with [`SimulationResult::columns`], then one row per sample.
pub fn write_csv<W: Write>(result: &SimulationResult, w: W) -> io::Result<()> {
    write_table_csv(&result.columns, &result.data, w)
}

/// Write a table stored column by column as CSV (header row, then one row per sample), with the number
/// format of [`write_csv`]; used for the forward simulation's series too.
pub fn write_table_csv<W: Write>(columns: &[String], data: &[Vec<f64>], w: W) -> io::Result<()> {
    let mut w = BufWriter::with_capacity(1 << 16, w);
    for (i, name) in columns.iter().enumerate() {
        if i > 0 {
            w.write_all(b",")?;
        }
        write_field(&mut w, name)?;
    }
    w.write_all(b"\n")?;
    let rows = data.first().map_or(0, Vec::len);
    for k in 0..rows {
        for (i, col) in data.iter().enumerate() {
            if i > 0 {
                w.write_all(b",")?;
            }
            write_f64(&mut w, col[k])?;
        }
        w.write_all(b"\n")?;
    }
    w.flush()
}

/// Write the summary as pretty-printed JSON followed by a newline (`--summary-json`).
pub fn write_summary_json<W: Write>(summary: &Summary, w: W) -> io::Result<()> {
    write_json(summary, w)
}

/// Write any summary (e.g. the forward simulation's) as pretty-printed JSON followed by a newline.
pub fn write_json<T: serde::Serialize + ?Sized, W: Write>(summary: &T, w: W) -> io::Result<()> {
    let mut w = BufWriter::new(w);
    serde_json::to_writer_pretty(&mut w, summary).map_err(io::Error::other)?;
    w.write_all(b"\n")?;
    w.flush()
}

/// A header field, quoted per RFC 4180 if it contains a comma, quote or line break.
fn write_field<W: Write>(w: &mut W, s: &str) -> io::Result<()> {
    if s.contains([',', '"', '\n', '\r']) {
        write!(w, "\"{}\"", s.replace('"', "\"\""))
    } else {
        w.write_all(s.as_bytes())
    }
}

/// Shortest round-trip representation of `v` (Rust's `Display`/`LowerExp` without precision are both exact).
fn write_f64<W: Write>(w: &mut W, v: f64) -> io::Result<()> {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() || (1e-5..1e16).contains(&a) {
        write!(w, "{v}")
    } else {
        write!(w, "{v:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fmt(v: f64) -> String {
        let mut b = Vec::new();
        write_f64(&mut b, v).unwrap();
        String::from_utf8(b).unwrap()
    }

    #[test]
    fn numbers_round_trip() {
        for v in [
            0.1,
            0.3,
            1.0 / 3.0,
            1180.0,
            -2.5e-9,
            1e300,
            5e-324,
            123_456_789.123_456_78,
            -0.0,
        ] {
            let s = fmt(v);
            assert_eq!(
                s.parse::<f64>().unwrap().to_bits(),
                v.to_bits(),
                "{v} → {s}"
            );
        }
        assert_eq!(fmt(0.1), "0.1");
        assert_eq!(fmt(1180.0), "1180");
        assert_eq!(fmt(-2.5e-9), "-2.5e-9");
    }

    #[test]
    fn header_quoting() {
        let mut b = Vec::new();
        write_field(&mut b, "a,\"b\"").unwrap();
        assert_eq!(String::from_utf8(b).unwrap(), "\"a,\"\"b\"\"\"");
    }
}
