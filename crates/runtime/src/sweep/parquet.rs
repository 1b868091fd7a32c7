//! A sweep's rows as an Apache Parquet file: one row group, one uncompressed PLAIN-encoded data page (v1) per
//! column, the metadata in Thrift's compact protocol — the subset of the format
//! (<https://github.com/apache/parquet-format>, `parquet.thrift`) that every reader (pyarrow, polars, DuckDB,
//! Spark) reads, written without a dependency.
//!
//! Columns are those of the CSV ([`SweepResult::header`]): `variant` and the counts as INT64, `cycle`, `status`
//! and `error` as UTF-8 strings (BYTE_ARRAY, converted type UTF8), every figure as DOUBLE. `variant`, `cycle`,
//! the parameters and `status` are REQUIRED; `error` and the figures are OPTIONAL (null where the CSV field
//! is empty: the error of a run that succeeded, the figures of one that failed).

use std::io::Write;

use super::hybrid_columns::{Cell, HybridColumn, HYBRID_COLUMNS};
use super::rows::{SweepResult, SweepRow};

/// Parquet physical types (`Type` in parquet.thrift).
const INT64: i32 = 2;
const DOUBLE: i32 = 5;
const BYTE_ARRAY: i32 = 6;
/// `FieldRepetitionType`.
const REQUIRED: i32 = 0;
const OPTIONAL: i32 = 1;
/// `ConvertedType::UTF8`.
const UTF8: i32 = 0;
/// `Encoding`: PLAIN for values, RLE for definition levels.
const PLAIN: i32 = 0;
const RLE: i32 = 3;

/// Thrift compact-protocol type codes.
const T_I32: u8 = 5;
const T_I64: u8 = 6;
const T_BINARY: u8 = 8;
const T_LIST: u8 = 9;
const T_STRUCT: u8 = 12;

/// One column's values (`None` = null).
enum Values {
    Int(Vec<Option<i64>>),
    Double(Vec<Option<f64>>),
    Text(Vec<Option<String>>),
}

/// A column: its name, whether it may hold nulls, its values.
struct Column {
    name: String,
    optional: bool,
    values: Values,
}

impl Column {
    fn physical_type(&self) -> i32 {
        match self.values {
            Values::Int(_) => INT64,
            Values::Double(_) => DOUBLE,
            Values::Text(_) => BYTE_ARRAY,
        }
    }

    fn len(&self) -> usize {
        match &self.values {
            Values::Int(v) => v.len(),
            Values::Double(v) => v.len(),
            Values::Text(v) => v.len(),
        }
    }

    /// Which rows hold a value (the definition level 1), in row order.
    fn defined(&self) -> Vec<bool> {
        match &self.values {
            Values::Int(v) => v.iter().map(Option::is_some).collect(),
            Values::Double(v) => v.iter().map(Option::is_some).collect(),
            Values::Text(v) => v.iter().map(Option::is_some).collect(),
        }
    }

    /// The non-null values, PLAIN-encoded: 8-byte little-endian numbers, strings as a 4-byte length + bytes.
    fn plain(&self) -> Vec<u8> {
        let mut out = Vec::new();
        match &self.values {
            Values::Int(v) => v.iter().flatten().for_each(|x| out.extend(x.to_le_bytes())),
            Values::Double(v) => v.iter().flatten().for_each(|x| out.extend(x.to_le_bytes())),
            Values::Text(v) => {
                for s in v.iter().flatten() {
                    out.extend((s.len() as u32).to_le_bytes());
                    out.extend(s.as_bytes());
                }
            }
        }
        out
    }

    /// The data page's body: for an OPTIONAL column the definition levels (4-byte length, then the
    /// RLE/bit-packing hybrid with bit width 1, written as RLE runs), then the values.
    fn page_body(&self) -> Vec<u8> {
        let mut body = Vec::new();
        if self.optional {
            let levels = rle_runs(&self.defined());
            body.extend((levels.len() as u32).to_le_bytes());
            body.extend(levels);
        }
        body.extend(self.plain());
        body
    }
}

/// Runs of equal bits as RLE runs: header varint(run length << 1), then the value in one byte.
fn rle_runs(bits: &[bool]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < bits.len() {
        let run = bits[i..].iter().take_while(|&&b| b == bits[i]).count();
        varint(&mut out, (run as u64) << 1);
        out.push(u8::from(bits[i]));
        i += run;
    }
    out
}

/// Unsigned LEB128.
fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// A Thrift compact-protocol struct being written: field headers carry the delta to the previous field id.
struct Thrift<'a> {
    out: &'a mut Vec<u8>,
    last: i16,
}

impl<'a> Thrift<'a> {
    fn new(out: &'a mut Vec<u8>) -> Self {
        Thrift { out, last: 0 }
    }

    fn header(&mut self, id: i16, ty: u8) {
        let delta = id - self.last;
        if (1..=15).contains(&delta) {
            self.out.push(((delta as u8) << 4) | ty);
        } else {
            self.out.push(ty);
            varint(self.out, zigzag(i64::from(id)));
        }
        self.last = id;
    }

    fn i32(&mut self, id: i16, v: i32) -> &mut Self {
        self.header(id, T_I32);
        varint(self.out, zigzag(i64::from(v)));
        self
    }

    fn i64(&mut self, id: i16, v: i64) -> &mut Self {
        self.header(id, T_I64);
        varint(self.out, zigzag(v));
        self
    }

    fn string(&mut self, id: i16, s: &str) -> &mut Self {
        self.header(id, T_BINARY);
        binary(self.out, s.as_bytes());
        self
    }

    /// A nested struct written by `body`.
    fn strukt(&mut self, id: i16, body: impl FnOnce(&mut Thrift)) -> &mut Self {
        self.header(id, T_STRUCT);
        body(&mut Thrift::new(self.out));
        self
    }

    /// A list of `n` elements of type `ty`, each written by `item`.
    fn list(
        &mut self,
        id: i16,
        ty: u8,
        n: usize,
        mut item: impl FnMut(usize, &mut Vec<u8>),
    ) -> &mut Self {
        self.header(id, T_LIST);
        if n < 15 {
            self.out.push(((n as u8) << 4) | ty);
        } else {
            self.out.push(0xf0 | ty);
            varint(self.out, n as u64);
        }
        for k in 0..n {
            item(k, self.out);
        }
        self
    }

    fn stop(&mut self) {
        self.out.push(0);
    }
}

fn zigzag(v: i64) -> u64 {
    ((v << 1) ^ (v >> 63)) as u64
}

fn binary(out: &mut Vec<u8>, bytes: &[u8]) {
    varint(out, bytes.len() as u64);
    out.extend(bytes);
}

/// A list element that is a struct written by `body` (elements of a list carry no field header).
fn element(out: &mut Vec<u8>, body: impl FnOnce(&mut Thrift)) {
    let mut t = Thrift::new(out);
    body(&mut t);
    t.stop();
}

/// `PageHeader` of a v1 data page (parquet.thrift: type DATA_PAGE = 0, sizes, `DataPageHeader`).
fn page_header(rows: usize, body_len: usize) -> Vec<u8> {
    let mut out = Vec::new();
    let mut t = Thrift::new(&mut out);
    t.i32(1, 0).i32(2, body_len as i32).i32(3, body_len as i32);
    t.strukt(5, |d| {
        d.i32(1, rows as i32).i32(2, PLAIN).i32(3, RLE).i32(4, RLE);
        d.stop();
    });
    t.stop();
    out
}

/// Where a column chunk was written.
struct Chunk {
    offset: usize,
    size: usize,
}

/// `FileMetaData`: version 1, the schema (a root with one leaf per column), the row count, one row group.
fn file_metadata(columns: &[Column], chunks: &[Chunk], rows: usize) -> Vec<u8> {
    let mut out = Vec::new();
    let mut t = Thrift::new(&mut out);
    t.i32(1, 1);
    t.list(2, T_STRUCT, columns.len() + 1, |k, out| {
        element(out, |s| {
            if k == 0 {
                s.string(4, "schema").i32(5, columns.len() as i32);
                return;
            }
            let c = &columns[k - 1];
            s.i32(1, c.physical_type());
            s.i32(3, if c.optional { OPTIONAL } else { REQUIRED });
            s.string(4, &c.name);
            if c.physical_type() == BYTE_ARRAY {
                s.i32(6, UTF8);
            }
        })
    });
    t.i64(3, rows as i64);
    let total: usize = chunks.iter().map(|c| c.size).sum();
    t.list(4, T_STRUCT, 1, |_, out| {
        element(out, |g| {
            g.list(1, T_STRUCT, columns.len(), |k, out| {
                element(out, |cc| column_chunk(cc, &columns[k], &chunks[k], rows));
            });
            g.i64(2, total as i64).i64(3, rows as i64);
        })
    });
    t.string(6, concat!("invsim ", env!("CARGO_PKG_VERSION")));
    t.stop();
    out
}

/// `ColumnChunk` with its `ColumnMetaData`.
fn column_chunk(cc: &mut Thrift, c: &Column, chunk: &Chunk, rows: usize) {
    cc.i64(2, chunk.offset as i64);
    cc.strukt(3, |m| {
        m.i32(1, c.physical_type());
        m.list(2, T_I32, 2, |k, out| {
            varint(out, zigzag(i64::from([PLAIN, RLE][k])))
        });
        m.list(3, T_BINARY, 1, |_, out| binary(out, c.name.as_bytes()));
        m.i32(4, 0); // UNCOMPRESSED
        m.i64(5, rows as i64);
        m.i64(6, chunk.size as i64).i64(7, chunk.size as i64);
        m.i64(9, chunk.offset as i64);
        m.stop();
    });
}

/// The columns of `result`, in the CSV's order.
fn columns(result: &SweepResult) -> Vec<Column> {
    let rows = &result.rows;
    let ok = |r: &SweepRow| r.outcome.as_ref().ok().cloned();
    let int = |name: &str, optional, f: &dyn Fn(&SweepRow) -> Option<i64>| Column {
        name: name.to_string(),
        optional,
        values: Values::Int(rows.iter().map(f).collect()),
    };
    let dbl = |name: String, optional, f: &dyn Fn(&SweepRow) -> Option<f64>| Column {
        name,
        optional,
        values: Values::Double(rows.iter().map(f).collect()),
    };
    let text = |name: &str, optional, f: &dyn Fn(&SweepRow) -> Option<String>| Column {
        name: name.to_string(),
        optional,
        values: Values::Text(rows.iter().map(f).collect()),
    };
    let mut cols = vec![
        int("variant", false, &|r| Some(r.variant as i64)),
        text("cycle", false, &|r| Some(r.cycle.clone())),
        dbl("lookahead_s".into(), false, &|r| Some(r.lookahead_s)),
    ];
    for (j, p) in result.parameters.iter().enumerate() {
        cols.push(dbl(p.clone(), false, &|r| r.params.get(j).copied()));
    }
    cols.push(text("status", false, &|r| {
        Some(if r.outcome.is_ok() { "ok" } else { "error" }.to_string())
    }));
    cols.push(text("error", true, &|r| r.outcome.as_ref().err().cloned()));
    cols.push(int("samples", true, &|r| ok(r).map(|f| f.samples as i64)));
    cols.push(dbl("distance_m".into(), true, &|r| {
        ok(r).map(|f| f.distance_m)
    }));
    for (j, n) in result.integrals.iter().enumerate() {
        cols.push(dbl(n.clone(), true, &|r| ok(r).map(|f| f.integrals[j])));
    }
    for (j, n) in result.integrals.iter().enumerate() {
        let name = format!("{n}_per_100km");
        cols.push(dbl(name, true, &|r| {
            ok(r).map(|f| f.integrals_per_100km[j])
        }));
    }
    for (j, n) in result.headline.iter().enumerate() {
        cols.push(dbl(n.clone(), true, &|r| {
            ok(r).map(|f| f.headline.get(j).copied().unwrap_or(f64::NAN))
        }));
    }
    cols.push(dbl("input_min".into(), true, &|r| {
        ok(r).map(|f| f.input_min)
    }));
    cols.push(dbl("input_max".into(), true, &|r| {
        ok(r).map(|f| f.input_max)
    }));
    cols.push(int("violations", true, &|r| {
        ok(r).map(|f| f.violations as i64)
    }));
    cols.push(dbl("violation_s".into(), true, &|r| {
        ok(r).map(|f| f.violation_s)
    }));
    if result.verify {
        let max = |r: &SweepRow| ok(r).and_then(|f| f.max_abs_tracking_error);
        let rms = |r: &SweepRow| ok(r).and_then(|f| f.rms_tracking_error);
        cols.push(dbl("max_abs_tracking_error".into(), true, &max));
        cols.push(dbl("rms_tracking_error".into(), true, &rms));
    }
    if !result.modes.is_empty() {
        let modes = |r: &SweepRow| ok(r).and_then(|f| f.modes);
        cols.push(int("switches", true, &|r| {
            modes(r).map(|m| m.switches as i64)
        }));
        cols.push(dbl("max_transition_deviation".into(), true, &|r| {
            modes(r).map(|m| m.max_transition_deviation)
        }));
        for (j, m) in result.modes.iter().enumerate() {
            cols.push(dbl(format!("time_{m}_s"), true, &|r| {
                modes(r).and_then(|m| m.time_s.get(j).copied())
            }));
        }
    }
    if result.hybrid {
        cols.extend(HYBRID_COLUMNS.iter().map(|c| hybrid_column(rows, c)));
    }
    for c in &result.gradient {
        cols.push(dbl(format!("d({})/d({})", c.0, c.1), true, &|r| {
            ok(r).map(|f| super::rows::derivative(&f, c))
        }));
    }
    cols
}

/// The hybrid column `c` of `rows`: counts as INT64, figures as DOUBLE, null where a run failed or its block
/// has null.
fn hybrid_column(rows: &[SweepRow], c: &HybridColumn) -> Column {
    let cells = rows.iter().map(|r| {
        let block = r.outcome.as_ref().ok().and_then(|f| f.hybrid.as_deref());
        block.map(|b| (c.cell)(b))
    });
    let values = if c.is_count() {
        Values::Int(
            cells
                .map(|v| match v {
                    Some(Cell::Count(n)) => Some(n as i64),
                    _ => None,
                })
                .collect(),
        )
    } else {
        Values::Double(
            cells
                .map(|v| match v {
                    Some(Cell::Float(x)) => x,
                    _ => None,
                })
                .collect(),
        )
    };
    Column {
        name: c.name.to_string(),
        optional: true,
        values,
    }
}

impl SweepResult {
    /// Write the rows as a Parquet file (columns as [`SweepResult::header`]; see the module docs).
    pub fn write_parquet<W: Write>(&self, mut w: W) -> std::io::Result<()> {
        let columns = columns(self);
        let rows = self.rows.len();
        let mut file = b"PAR1".to_vec();
        let mut chunks = Vec::with_capacity(columns.len());
        for c in &columns {
            debug_assert_eq!(c.len(), rows);
            let body = c.page_body();
            let header = page_header(rows, body.len());
            chunks.push(Chunk {
                offset: file.len(),
                size: header.len() + body.len(),
            });
            file.extend(header);
            file.extend(body);
        }
        let meta = file_metadata(&columns, &chunks, rows);
        file.extend(&meta);
        file.extend((meta.len() as u32).to_le_bytes());
        file.extend(b"PAR1");
        w.write_all(&file)?;
        w.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rle_runs_encode_lengths_and_values() {
        // 3 × 1 then 2 × 0: headers 3 << 1 = 6 and 2 << 1 = 4, each followed by its bit in one byte.
        assert_eq!(
            rle_runs(&[true, true, true, false, false]),
            vec![6, 1, 4, 0]
        );
        // A run of 200: varint(400) = 0x90 0x03.
        assert_eq!(rle_runs(&[true; 200]), vec![0x90, 0x03, 1]);
    }

    #[test]
    fn thrift_field_headers_use_deltas_and_zigzag() {
        let mut out = Vec::new();
        let mut t = Thrift::new(&mut out);
        // Field 1 (delta 1, i32) = 1 → zigzag 2; field 20 (delta 19 > 15: long form) = -1 → zigzag 1.
        t.i32(1, 1).i32(20, -1);
        t.stop();
        assert_eq!(out, vec![0x15, 2, 0x05, 40, 1, 0]);
    }
}
