//! Writing results: the per-sample CSV of `invsim simulate --out` and the JSON summary (contract §3).
//!
//! Numbers are written in full precision: the shortest decimal that reads back as the same `f64`, in positional
//! notation for 1e-5 ≤ |v| < 1e16 and in exponent notation (`1.25e-7`) otherwise, and always as a float —
//! with a decimal point in the digits (`0.0`, `1180.0`, `1.0e-7`), so that every reader (polars, pandas,
//! numpy, spreadsheets) types a column as floating point whatever its first rows hold (polars typed a column
//! starting with `0` as integers and then failed on `0.05`); non-finite values (which a successful run never
//! produces) are written as `NaN`, `inf`, `-inf`.

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

/// Shortest round-trip representation of `v` (Rust's `Display`/`LowerExp` without precision are both exact),
/// always with a decimal point (see the module's doc): a whole number gets `.0` (`Display` writes none), an
/// exponent's mantissa too (`1e-7` → `1.0e-7`).
fn write_f64<W: Write>(w: &mut W, v: f64) -> io::Result<()> {
    let a = v.abs();
    if !v.is_finite() {
        return write!(w, "{v}");
    }
    if v == 0.0 {
        // The commonest value of a run's series (a vehicle at rest): no formatting at all.
        return w.write_all(if v.is_sign_negative() {
            b"-0.0"
        } else {
            b"0.0"
        });
    }
    if a < 1e16 && v == v.trunc() {
        // Whole numbers below 1e16 are exact as i64 and written as its digits (faster than the float's
        // `Display`, which writes the same digits), then `.0`.
        return write!(w, "{}.0", v as i64);
    }
    if (1e-5..1e16).contains(&a) {
        // Not whole: `Display` writes a decimal point.
        return write!(w, "{v}");
    }
    let mut text = NumText::default();
    let _ = std::fmt::Write::write_fmt(&mut text, format_args!("{v:e}"));
    let digits = text.as_bytes();
    match digits.iter().position(|&b| b == b'e') {
        Some(e) if !digits[..e].contains(&b'.') => {
            w.write_all(&digits[..e])?;
            w.write_all(b".0")?;
            w.write_all(&digits[e..])
        }
        _ => w.write_all(digits),
    }
}

/// `v` as [`write_csv`] writes it (`0.0`, `1180.0`, `0.05`, `1.0e-7`): for other tables of results (the
/// sweep's rows).
pub fn float_text(v: f64) -> String {
    let mut b = Vec::with_capacity(24);
    // Writing to a `Vec` cannot fail.
    let _ = write_f64(&mut b, v);
    String::from_utf8_lossy(&b).into_owned()
}

/// The text of one number, on the stack (the longest `{:e}` of an `f64` is 24 bytes: `-2.2250738585072014e-308`).
#[derive(Default)]
struct NumText {
    buf: [u8; 32],
    len: usize,
}

impl NumText {
    fn as_bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }
}

impl std::fmt::Write for NumText {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        let end = self.len + s.len();
        let slot = self.buf.get_mut(self.len..end).ok_or(std::fmt::Error)?;
        slot.copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
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
        assert_eq!(fmt(1180.0), "1180.0");
        assert_eq!(fmt(-2.5e-9), "-2.5e-9");
    }

    #[test]
    fn every_number_is_written_as_a_float() {
        let cases = [
            (0.0, "0.0"),
            (-0.0, "-0.0"),
            (2.0, "2.0"),
            (-1180.0, "-1180.0"),
            (0.05, "0.05"),
            (1e-5, "0.00001"),
            (1e-7, "1.0e-7"),
            (-3e-300, "-3.0e-300"),
            (1e16, "1.0e16"),
            (1.5e20, "1.5e20"),
            (9_007_199_254_740_992.0, "9007199254740992.0"),
            (f64::MAX, "1.7976931348623157e308"),
            (5e-324, "5.0e-324"),
            (f64::NAN, "NaN"),
            (f64::INFINITY, "inf"),
        ];
        for (v, text) in cases {
            assert_eq!(fmt(v), text, "{v:e}");
            assert_eq!(float_text(v), text);
            if v.is_finite() {
                assert_eq!(text.parse::<f64>().unwrap().to_bits(), v.to_bits());
            }
        }
    }

    #[test]
    fn header_quoting() {
        let mut b = Vec::new();
        write_field(&mut b, "a,\"b\"").unwrap();
        assert_eq!(String::from_utf8(b).unwrap(), "\"a,\"\"b\"\"\"");
    }
}
