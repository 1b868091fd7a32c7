//! The `maps` object of `invsim derive --format json` (contract §6): each map's arguments, grid, values and
//! settings, file-based maps inlined, so that a derivation can be evaluated without the model file.

use crate::model::MapInfo;
use serde_json::{json, Map, Value};

/// `{"NAME": {"args": [...], "x": [...], "y": [...], "values": [[...]], "smooth": …, "extrapolate": …,
/// "interp": …}}` (1-D: no `y`, `values` a flat list), plus `unit` and `doc` when the model gives them.
pub(crate) fn maps_json(maps: &[MapInfo]) -> Value {
    let mut out = Map::new();
    for m in maps {
        let d = &m.data;
        let s = d.settings();
        let mut o = Map::new();
        o.insert("args".into(), json!(m.args));
        o.insert("x".into(), json!(d.x()));
        match d.y() {
            Some(y) => {
                o.insert("y".into(), json!(y));
                let rows: Vec<&[f64]> = d.values().chunks(y.len()).collect();
                o.insert("values".into(), json!(rows));
            }
            None => {
                o.insert("values".into(), json!(d.values()));
            }
        }
        o.insert("smooth".into(), json!(s.smooth));
        o.insert("extrapolate".into(), json!(s.extrapolate.name()));
        o.insert("interp".into(), json!(s.interp.name()));
        if let Some(u) = &m.unit {
            o.insert("unit".into(), json!(u));
        }
        if let Some(doc) = &m.doc {
            o.insert("doc".into(), json!(doc));
        }
        out.insert(m.name.clone(), Value::Object(o));
    }
    Value::Object(out)
}

/// The grid of one axis: `w_e ∈ [50, 700] (8 points)`.
fn axis(name: &str, grid: &[f64]) -> String {
    let (lo, hi) = (grid.first().copied(), grid.last().copied());
    match (lo, hi) {
        (Some(lo), Some(hi)) => format!("{name} ∈ [{lo}, {hi}] ({} points)", grid.len()),
        _ => format!("{name} (no grid)"),
    }
}

/// What one map is, in words: its call, grids, evaluation and continuation outside the grid.
fn describe(m: &MapInfo) -> (String, String, String) {
    let d = &m.data;
    let s = d.settings();
    let call = format!("{}({})", m.name, m.args.join(", "));
    let mut grids = vec![axis(m.args.first().map_or("x", String::as_str), d.x())];
    if let Some(y) = d.y() {
        grids.push(axis(m.args.get(1).map_or("y", String::as_str), y));
    }
    let evaluation = match s.interp.name() {
        "linear" => "(bi)linear, not smooth".to_string(),
        _ => format!(
            "smooth, kernel half-width {} × the smallest spacing per axis",
            s.smooth
        ),
    };
    (
        call,
        grids.join(" × "),
        format!("{evaluation}; outside the grid: {}", s.extrapolate.name()),
    )
}

/// `invsim derive`'s text: one line per map (the values are in the JSON form).
pub(crate) fn maps_text(maps: &[MapInfo]) -> String {
    let mut out = String::new();
    for m in maps {
        let (call, grids, how) = describe(m);
        let unit = m
            .unit
            .as_deref()
            .map(|u| format!(" [{u}]"))
            .unwrap_or_default();
        // The file's name only: the path depends on where the model was read from.
        let from = m
            .file
            .as_ref()
            .and_then(|f| f.file_name())
            .map(|f| format!(", values from {}", f.to_string_lossy()))
            .unwrap_or_default();
        out.push_str(&format!("  {call}{unit}: {grids}; {how}{from}\n"));
    }
    out
}

/// The derived-equation document's table of maps, then each map's values.
pub(crate) fn maps_markdown(maps: &[MapInfo]) -> String {
    let mut out =
        String::from("| map | grid | evaluation | unit | description |\n|---|---|---|---|---|\n");
    for m in maps {
        let (call, grids, how) = describe(m);
        let unit = m.unit.as_deref().unwrap_or("–");
        let doc = m.doc.as_deref().unwrap_or("");
        out.push_str(&format!(
            "| `{call}` | {grids} | {how} | {unit} | {doc} |\n"
        ));
    }
    for m in maps {
        out.push_str(&values_markdown(m));
    }
    out
}

/// One map's values as a table: a row per point of the first grid, a column per point of the second.
fn values_markdown(m: &MapInfo) -> String {
    let d = &m.data;
    let a = m.args.first().map_or("x", String::as_str);
    let mut out = format!("\nValues of `{}`", m.name);
    match d.y() {
        Some(y) => {
            let b = m.args.get(1).map_or("y", String::as_str);
            out.push_str(&format!(" (rows: {a}, columns: {b}):\n\n| {a} \\ {b} |"));
            for v in y {
                out.push_str(&format!(" {v} |"));
            }
            out.push_str(&format!("\n|---|{}\n", "---|".repeat(y.len())));
            for (x, row) in d.x().iter().zip(d.values().chunks(y.len().max(1))) {
                out.push_str(&format!("| {x} |"));
                for v in row {
                    out.push_str(&format!(" {v} |"));
                }
                out.push('\n');
            }
        }
        None => {
            out.push_str(&format!(":\n\n| {a} | value |\n|---|---|\n"));
            for (x, v) in d.x().iter().zip(d.values()) {
                out.push_str(&format!("| {x} | {v} |\n"));
            }
        }
    }
    out
}
