//! The figures of several runs side by side (`invsim compare`): one row per figure any run has, the first
//! run's value, then for every other run its value, its difference to the first run and that difference
//! relative to the first run's value; as a text table or as JSON.

use std::fmt::Write as _;

use invsim_runtime::numfmt::num;
use serde_json::{json, Value};

use crate::run_summary::{Figure, RunSummary};

/// One figure across the runs: its name, unit and the value of each run (`None`: the run has no such
/// figure).
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub name: String,
    pub unit: Option<String>,
    pub values: Vec<Option<f64>>,
}

impl Row {
    /// Run `k`'s value minus the first run's.
    pub fn difference(&self, k: usize) -> Option<f64> {
        Some(self.values.get(k).copied()?? - self.values.first().copied()??)
    }

    /// [`Row::difference`] relative to the first run's value (`None` where that is 0).
    pub fn relative(&self, k: usize) -> Option<f64> {
        let base = self.values.first().copied()??;
        (base != 0.0)
            .then(|| self.difference(k))
            .flatten()
            .map(|d| d / base.abs())
    }
}

/// The label of run `k`: A, B, C, …
pub fn label(k: usize) -> String {
    char::from(b'A' + (k % 26) as u8).to_string()
}

/// The rows of `runs`' figures, in the order they first appear (the first run's order, then the others').
pub fn rows(figures: &[Vec<Figure>]) -> Vec<Row> {
    let mut rows: Vec<Row> = Vec::new();
    for (k, run) in figures.iter().enumerate() {
        for f in run {
            let i = match rows.iter().position(|r| r.name == f.name) {
                Some(i) => i,
                None => {
                    rows.push(Row {
                        name: f.name.clone(),
                        unit: f.unit.clone(),
                        values: vec![None; figures.len()],
                    });
                    rows.len() - 1
                }
            };
            rows[i].values[k] = Some(f.value);
        }
    }
    rows
}

fn value(v: Option<f64>) -> String {
    v.map_or_else(|| "—".to_string(), num)
}

fn signed(v: Option<f64>) -> String {
    match v {
        Some(d) if d > 0.0 => format!("+{}", num(d)),
        _ => value(v),
    }
}

fn percent(v: Option<f64>) -> String {
    v.map_or_else(|| "—".to_string(), |r| format!("{:+.2} %", 100.0 * r))
}

/// The text table: a line naming each run, then the header and one line per figure.
pub fn text(runs: &[RunSummary], rows: &[Row]) -> String {
    let mut s = String::new();
    for (k, r) in runs.iter().enumerate() {
        let command = r.command().map_or(String::new(), |c| format!(" ({c})"));
        let _ = writeln!(
            s,
            "run {}: {} — {} on {}{command}",
            label(k),
            r.path.display(),
            r.text("model"),
            r.text("cycle")
        );
    }
    s.push('\n');
    let mut table = vec![header(runs.len())];
    table.extend(rows.iter().map(|row| cells(row, runs.len())));
    let widths: Vec<usize> = (0..table[0].len())
        .map(|c| {
            table
                .iter()
                .map(|l| l[c].chars().count())
                .max()
                .unwrap_or(0)
        })
        .collect();
    for line in &table {
        let mut out = String::new();
        for (c, (cell, w)) in line.iter().zip(&widths).enumerate() {
            let pad = w - cell.chars().count();
            match c {
                0 | 1 => out.push_str(&format!("{cell}{}  ", " ".repeat(pad))),
                _ => out.push_str(&format!("{}{cell}  ", " ".repeat(pad))),
            }
        }
        s.push_str(out.trim_end());
        s.push('\n');
    }
    s
}

fn header(n: usize) -> Vec<String> {
    let mut h = vec!["figure".to_string(), "unit".to_string(), label(0)];
    for k in 1..n {
        let l = label(k);
        h.extend([l.clone(), format!("{l} − A"), format!("({l} − A)/|A|")]);
    }
    h
}

fn cells(row: &Row, n: usize) -> Vec<String> {
    let mut c = vec![
        row.name.clone(),
        row.unit.clone().unwrap_or_default(),
        value(row.values[0]),
    ];
    for k in 1..n {
        c.extend([
            value(row.values[k]),
            signed(row.difference(k)),
            percent(row.relative(k)),
        ]);
    }
    c
}

/// The comparison as JSON: the runs (label, file, model, cycle, command) and the figures, each with the
/// runs' values and the differences to the first run (absolute and relative, aligned with the runs; null
/// where a run has no such figure or the first run's value is 0).
pub fn json(runs: &[RunSummary], rows: &[Row]) -> Value {
    let runs: Vec<Value> = runs
        .iter()
        .enumerate()
        .map(|(k, r)| {
            json!({
                "label": label(k),
                "file": r.path.display().to_string(),
                "model": r.text("model"),
                "cycle": r.text("cycle"),
                "command": r.command(),
            })
        })
        .collect();
    let figures: Vec<Value> = rows
        .iter()
        .map(|row| {
            let n = row.values.len();
            json!({
                "name": row.name,
                "unit": row.unit,
                "values": row.values,
                "differences": (0..n).map(|k| row.difference(k)).collect::<Vec<_>>(),
                "relative_differences": (0..n).map(|k| row.relative(k)).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({ "runs": runs, "figures": figures })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_are_to_the_first_run() {
        let f = |v: f64| Figure {
            name: "fuel".into(),
            unit: Some("kg".into()),
            value: v,
        };
        let rows = rows(&[vec![f(0.5)], vec![f(0.55)], vec![]]);
        assert_eq!(rows.len(), 1);
        let d = rows[0].difference(1).unwrap();
        assert!((d - 0.05).abs() < 1e-15);
        assert!((rows[0].relative(1).unwrap() - 0.1).abs() < 1e-12);
        assert_eq!(rows[0].difference(2), None);
        assert_eq!(percent(rows[0].relative(1)), "+10.00 %");
        assert_eq!(signed(Some(0.05)), "+0.05");
    }
}
