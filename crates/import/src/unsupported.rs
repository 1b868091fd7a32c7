//! Fields of the vehicle file the model does not use: every leaf (a scalar, or a whole list) that is set, not
//! read by the importer and not bookkeeping (`state`, `history`, `save_interval`, descriptive fields) is
//! listed in a warning, so that nothing is dropped silently.

use crate::yaml::Doc;
use serde_yaml::Value;

/// Keys whose subtrees are FASTSim's run-time bookkeeping, never vehicle data.
const BOOKKEEPING: [&str; 3] = ["state", "history", "save_interval"];
/// Descriptive top-level fields (carried into the header, not physics).
const DESCRIPTIVE: [&str; 7] = [
    "name",
    "min_fastsim_version",
    "doc",
    "year",
    "make",
    "model",
    "trim",
];

/// The dotted paths of the set leaves that were not used.
pub fn unused(doc: &Doc) -> Vec<String> {
    let mut out = Vec::new();
    walk(doc, &doc.root, "", &mut out);
    out
}

fn walk(doc: &Doc, node: &Value, path: &str, out: &mut Vec<String>) {
    let leaf = !matches!(node, Value::Mapping(_));
    if !path.is_empty() && doc.was_used(path) && (leaf || doc.was_marked(path)) {
        return;
    }
    match node {
        Value::Mapping(m) => {
            for (k, v) in m {
                let key = match k.as_str() {
                    Some(k) => k.to_string(),
                    None => format!("{k:?}"),
                };
                if BOOKKEEPING.contains(&key.as_str())
                    || (path.is_empty() && DESCRIPTIVE.contains(&key.as_str()))
                {
                    continue;
                }
                let child = if path.is_empty() {
                    key
                } else {
                    format!("{path}.{key}")
                };
                walk(doc, v, &child, out);
            }
        }
        Value::Null => {}
        Value::String(s) if s == "None" => {}
        Value::Number(n) if n.as_f64().is_some_and(f64::is_nan) => {}
        _ => out.push(path.to_string()),
    }
}
