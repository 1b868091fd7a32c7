//! A run's summary JSON read back for `invsim compare` (written by `simulate --summary-json` or
//! `forward --summary-json`, schema `docs/summary.schema.json`): checked to be an invsim summary (an object
//! with the model, the cycle, the duration, the distance and the integrals), and its figures listed as
//! (name, unit, value): every number of the summary's top level and of its objects one level down
//! (`integrals.fuel`, `tolerance_band.samples_outside`), except the histogram, the columns, the provenance
//! and the lists; plus the time spent outside the input's bounds.

use std::io::Read as _;
use std::path::{Path, PathBuf};

use serde_json::{Map, Value};

use crate::error::Failure;
use invsim_runtime::numfmt::num;

/// Largest summary file read, in bytes (a summary with its operating-point histogram is some 100 KB).
pub const MAX_SUMMARY_BYTES: u64 = 16 << 20;

/// Members of a summary that are not figures to compare (text, lists, the histogram, the run's record).
const NOT_FIGURES: &[&str] = &[
    "engine_operating_points",
    "columns",
    "provenance",
    "warnings",
    "integral_units",
    "relative_degree",
];

/// Members every invsim summary has, with the JSON type expected (for the refusal's message).
const REQUIRED: &[(&str, &str)] = &[
    ("model", "a string"),
    ("cycle", "a string"),
    ("duration_s", "a number"),
    ("distance_m", "a number"),
    ("integrals", "an object"),
];

/// One figure of a run: its dotted name, its unit (if known) and its value.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    pub name: String,
    pub unit: Option<String>,
    pub value: f64,
}

/// A summary read from a file.
#[derive(Debug)]
pub struct RunSummary {
    pub path: PathBuf,
    pub json: Map<String, Value>,
}

impl RunSummary {
    /// Read and check `path` (at most [`MAX_SUMMARY_BYTES`]); a file that is no invsim summary is a user
    /// error naming the file and what was expected.
    pub fn read(path: &Path) -> Result<RunSummary, Failure> {
        let shown = path.display();
        let not_summary = |why: String| {
            Failure::user(format!(
                "{shown} is not an invsim summary: {why}; expected the JSON that `invsim simulate` or `invsim \
                 forward` writes with --summary-json"
            ))
        };
        let file = std::fs::File::open(path)
            .map_err(|e| Failure::user(format!("cannot read the summary {shown}: {e}")))?;
        let mut bytes = Vec::new();
        file.take(MAX_SUMMARY_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(|e| Failure::user(format!("cannot read the summary {shown}: {e}")))?;
        if bytes.len() as u64 > MAX_SUMMARY_BYTES {
            return Err(not_summary(format!(
                "the file is larger than {MAX_SUMMARY_BYTES} bytes"
            )));
        }
        let value: Value = serde_json::from_slice(&bytes)
            .map_err(|e| not_summary(format!("it is not JSON ({e})")))?;
        let Value::Object(json) = value else {
            return Err(not_summary("it is not a JSON object".to_string()));
        };
        check_required(&json).map_err(not_summary)?;
        Ok(RunSummary {
            path: path.to_path_buf(),
            json,
        })
    }

    /// A string member (empty if absent).
    pub fn text(&self, key: &str) -> &str {
        self.json.get(key).and_then(Value::as_str).unwrap_or("")
    }

    /// The command that wrote the summary (`simulate`, `forward`), from its provenance, if recorded.
    pub fn command(&self) -> Option<&str> {
        self.json.get("provenance")?.get("command")?.as_str()
    }

    /// The CSV series the run wrote (`--out`, as recorded in its provenance), if any.
    pub fn series_path(&self) -> Option<&str> {
        self.json
            .get("provenance")?
            .get("options")?
            .get("out")?
            .as_str()
    }

    /// The CSV column names the summary lists.
    pub fn column_names(&self) -> Vec<&str> {
        let columns = self.json.get("columns").and_then(Value::as_array);
        columns
            .into_iter()
            .flatten()
            .filter_map(|c| c.get("name").and_then(Value::as_str))
            .collect()
    }

    /// Every figure of the run, in the summary's order (see the module docs).
    pub fn figures(&self) -> Vec<Figure> {
        let mut out = Vec::new();
        for (key, value) in &self.json {
            if NOT_FIGURES.contains(&key.as_str()) {
                continue;
            }
            match value {
                Value::Number(n) => push(&mut out, key.clone(), self.unit_of(key, None), n),
                Value::Object(inner) => {
                    for (k, v) in inner {
                        if let Value::Number(n) = v {
                            let unit = self.unit_of(key, Some(k));
                            push(&mut out, format!("{key}.{k}"), unit, n);
                        }
                    }
                }
                _ => {}
            }
        }
        // The results first: per 100 km, then the integrals, then the rest in the summary's order.
        out.sort_by_key(|f| match f.name.split('.').next() {
            Some("integrals_per_100km") => 0,
            Some("integrals") => 1,
            _ => 2,
        });
        if let Some(t) = self.time_outside_bounds() {
            out.push(Figure {
                name: "time outside the input's bounds".to_string(),
                unit: Some("s".to_string()),
                value: t,
            });
        }
        out
    }

    /// The unit of member `key` (`inner` of an object): an integral's from `integral_units`, per 100 km for
    /// `integrals_per_100km`, else by the name's suffix (`_s`, `_m`, `_mps`, `_kmh`), the input's and
    /// output's units for their extremes and deviations.
    fn unit_of(&self, key: &str, inner: Option<&str>) -> Option<String> {
        let integral = |k: &str| {
            self.json
                .get("integral_units")
                .and_then(|u| u.get(k))
                .and_then(Value::as_str)
                .map(str::to_string)
        };
        match (key, inner) {
            ("integrals", Some(k)) => integral(k),
            ("integrals_per_100km", Some(k)) => integral(k).map(|u| format!("{u}/100 km")),
            (_, Some(k)) => unit_by_suffix(k),
            ("input_min" | "input_max" | "input_lower_bound" | "input_upper_bound", None) => {
                self.json.get("input_unit")?.as_str().map(str::to_string)
            }
            (k, None) if k.contains("deviation") || k.contains("tracking_error") => {
                self.json.get("output_unit")?.as_str().map(str::to_string)
            }
            (k, None) => unit_by_suffix(k),
        }
    }

    /// Seconds of the input outside its bounds: the sum of the intervals `input_bound_violations` lists.
    fn time_outside_bounds(&self) -> Option<f64> {
        let list = self.json.get("input_bound_violations")?.as_array()?;
        let span = |i: &Value| -> Option<f64> {
            let pair = i.as_array()?;
            Some(pair.get(1)?.as_f64()? - pair.first()?.as_f64()?)
        };
        list.iter().map(span).sum()
    }
}

/// The run's result in one line for its figure: the per-100-km figures (those in litres first: l/100 km is
/// what a driver reads), else the integrals, then the distance and duration; `None` without integrals.
pub fn headline(json: &Map<String, Value>) -> Option<String> {
    let units = json.get("integral_units").and_then(Value::as_object);
    let unit = |k: &str| {
        units
            .and_then(|u| u.get(k))
            .and_then(Value::as_str)
            .unwrap_or("")
    };
    let (map, per) = match json.get("integrals_per_100km").and_then(Value::as_object) {
        Some(m) if !m.is_empty() => (m, "/100 km"),
        _ => (json.get("integrals")?.as_object()?, ""),
    };
    let mut items: Vec<(bool, String)> = map
        .iter()
        .filter_map(|(k, v)| {
            let u = unit(k);
            let text = format!("{} {u}{per} {k}", four_digits(v.as_f64()?));
            Some((u != "l", text.replace("  ", " ")))
        })
        .collect();
    if items.is_empty() {
        return None;
    }
    items.sort_by_key(|(litres_last, _)| *litres_last);
    // Two figures at most: the line stays within the figure's width.
    let list: Vec<String> = items.into_iter().take(2).map(|(_, t)| t).collect();
    let km = json
        .get("distance_m")
        .and_then(Value::as_f64)
        .unwrap_or(0.0)
        / 1000.0;
    let s = json
        .get("duration_s")
        .and_then(Value::as_f64)
        .unwrap_or(0.0);
    Some(format!(
        "result: {} over {} km in {} s",
        list.join(", "),
        num((km * 1000.0).round() / 1000.0),
        num(s)
    ))
}

/// `v` with four significant digits, as the text summary prints its results (trailing zeros dropped; an
/// exponent for very large or small magnitudes).
pub fn four_digits(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return num(v);
    }
    let mag = v.abs().log10().floor() as i32;
    if !(-4..6).contains(&mag) {
        return format!("{v:.3e}");
    }
    let s = format!("{v:.*}", (3 - mag).max(0) as usize);
    match s.contains('.') {
        true => s.trim_end_matches('0').trim_end_matches('.').to_string(),
        false => s,
    }
}

fn push(out: &mut Vec<Figure>, name: String, unit: Option<String>, n: &serde_json::Number) {
    if let Some(value) = n.as_f64() {
        out.push(Figure { name, unit, value });
    }
}

/// A unit from a name's suffix: `_s` seconds, `_m` metres, `_mps` m/s, `_kmh` km/h.
fn unit_by_suffix(name: &str) -> Option<String> {
    let unit = [("_mps", "m/s"), ("_kmh", "km/h"), ("_s", "s"), ("_m", "m")]
        .into_iter()
        .find(|(suffix, _)| name.ends_with(suffix))?
        .1;
    Some(unit.to_string())
}

/// The first member of [`REQUIRED`] that is missing or of another type, as a sentence.
fn check_required(json: &Map<String, Value>) -> Result<(), String> {
    for &(key, expected) in REQUIRED {
        let ok = match json.get(key) {
            Some(Value::String(_)) => expected == "a string",
            Some(Value::Number(_)) => expected == "a number",
            Some(Value::Object(_)) => expected == "an object",
            _ => false,
        };
        if !ok {
            return Err(format!("its member `{key}` is missing or not {expected}"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn summary(json: &str) -> RunSummary {
        let Value::Object(json) = serde_json::from_str(json).unwrap() else {
            panic!("not an object")
        };
        RunSummary {
            path: PathBuf::from("a.json"),
            json,
        }
    }

    #[test]
    fn figures_carry_their_units() {
        let s = summary(
            r#"{"model":"m","cycle":"c","duration_s":10.0,"distance_m":100.0,"samples":11,
                "integrals":{"fuel":0.5},"integrals_per_100km":{"fuel":5.0},"integral_units":{"fuel":"kg"},
                "input_unit":"kg/s","input_max":0.04,"input_bound_violations":[[1.0,2.5],[4.0,4.5]]}"#,
        );
        let f = s.figures();
        let get = |n: &str| f.iter().find(|x| x.name == n).unwrap().clone();
        assert_eq!(get("duration_s").unit.as_deref(), Some("s"));
        assert_eq!(get("integrals.fuel").unit.as_deref(), Some("kg"));
        assert_eq!(
            get("integrals_per_100km.fuel").unit.as_deref(),
            Some("kg/100 km")
        );
        assert_eq!(get("input_max").unit.as_deref(), Some("kg/s"));
        assert_eq!(get("samples").unit, None);
        assert_eq!(get("time outside the input's bounds").value, 2.0);
    }

    #[test]
    fn the_headline_leads_with_litres() {
        let s = summary(
            r#"{"model":"m","cycle":"c","duration_s":1180.0,"distance_m":11013.2,"integrals":{"fuel":0.56},
                "integrals_per_100km":{"fuel":5.1,"fuel_volume":6.846},"integral_units":{"fuel":"kg","fuel_volume":"l"}}"#,
        );
        assert_eq!(
            headline(&s.json).unwrap(),
            "result: 6.846 l/100 km fuel_volume, 5.1 kg/100 km fuel over 11.013 km in 1180 s"
        );
        assert_eq!(four_digits(8.35993), "8.36");
        assert_eq!(four_digits(0.00465408), "0.004654");
        assert_eq!(four_digits(12345.6), "12346");
    }

    #[test]
    fn a_file_without_the_summary_members_is_refused_naming_the_member() {
        let Value::Object(j) = serde_json::json!({"model": "m", "cycle": 3}) else {
            panic!()
        };
        let e = check_required(&j).unwrap_err();
        assert_eq!(e, "its member `cycle` is missing or not a string");
    }
}
