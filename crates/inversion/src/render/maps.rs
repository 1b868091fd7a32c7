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
