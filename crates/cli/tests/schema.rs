//! Every shipped model's `simulate` and `forward` summaries and `sweep` rows validate against
//! `docs/summary.schema.json` (one schema for single-mode models and models with modes), checked by a small
//! validator of the part of JSON Schema (draft 2020-12) the schema uses: `type`, `enum`, `required`,
//! `properties`, `patternProperties`, `additionalProperties`, `items`, `minItems`, `maxItems`, `anyOf`, `not`
//! and local `$ref`s;
//! any other keyword is refused, so the schema cannot silently use one this validator ignores.

use crate::common;
use common::*;

use serde_json::Value;

/// Keywords that only annotate.
const ANNOTATIONS: [&str; 4] = ["$schema", "title", "description", "$defs"];

/// Where `value` (at `path`) breaks `schema`, appended to `errors`; `root` resolves `$ref`s.
fn check(root: &Value, schema: &Value, value: &Value, path: &str, errors: &mut Vec<String>) {
    let Some(schema) = schema.as_object() else {
        match schema {
            Value::Bool(true) => {}
            _ => errors.push(format!("{path}: not allowed")),
        }
        return;
    };
    for (key, arg) in schema {
        match key.as_str() {
            "$ref" => {
                let r = arg.as_str().expect("$ref is a string");
                let target = r
                    .strip_prefix('#')
                    .and_then(|p| root.pointer(p))
                    .unwrap_or_else(|| panic!("unresolved $ref {r}"));
                check(root, target, value, path, errors);
            }
            "type" => {
                let types: Vec<&str> = match arg {
                    Value::String(t) => vec![t.as_str()],
                    Value::Array(ts) => ts.iter().filter_map(Value::as_str).collect(),
                    _ => panic!("bad type {arg}"),
                };
                if !types.iter().any(|t| has_type(value, t)) {
                    errors.push(format!("{path}: {value} is not of type {arg}"));
                }
            }
            "enum" => {
                if !arg.as_array().expect("enum list").contains(value) {
                    errors.push(format!("{path}: {value} is not one of {arg}"));
                }
            }
            "required" => {
                if let Some(o) = value.as_object() {
                    for k in arg.as_array().expect("required list") {
                        let k = k.as_str().expect("required name");
                        if !o.contains_key(k) {
                            errors.push(format!("{path}: `{k}` is missing"));
                        }
                    }
                }
            }
            "properties" => {
                if let Some(o) = value.as_object() {
                    for (k, sub) in arg.as_object().expect("properties object") {
                        if let Some(v) = o.get(k) {
                            check(root, sub, v, &format!("{path}.{k}"), errors);
                        }
                    }
                }
            }
            "patternProperties" => {
                if let Some(o) = value.as_object() {
                    for (k, v) in o {
                        for (pattern, sub) in arg.as_object().expect("patternProperties object") {
                            if matches_pattern(pattern, k) {
                                check(root, sub, v, &format!("{path}.{k}"), errors);
                            }
                        }
                    }
                }
            }
            "additionalProperties" => {
                if let Some(o) = value.as_object() {
                    let known = schema.get("properties").and_then(Value::as_object);
                    let patterns = schema.get("patternProperties").and_then(Value::as_object);
                    for (k, v) in o {
                        let named = known.is_some_and(|p| p.contains_key(k));
                        let matched =
                            patterns.is_some_and(|p| p.keys().any(|pat| matches_pattern(pat, k)));
                        if !named && !matched {
                            check(root, arg, v, &format!("{path}.{k}"), errors);
                        }
                    }
                }
            }
            "items" => {
                if let Some(a) = value.as_array() {
                    for (i, v) in a.iter().enumerate() {
                        check(root, arg, v, &format!("{path}[{i}]"), errors);
                    }
                }
            }
            "minItems" | "maxItems" => {
                if let Some(a) = value.as_array() {
                    let n = arg.as_u64().expect("item count") as usize;
                    let ok = if key == "minItems" {
                        a.len() >= n
                    } else {
                        a.len() <= n
                    };
                    if !ok {
                        errors.push(format!("{path}: {} items break {key} {n}", a.len()));
                    }
                }
            }
            "anyOf" => {
                let branches = arg.as_array().expect("anyOf list");
                let mut why = Vec::new();
                let any = branches.iter().any(|b| {
                    let mut e = Vec::new();
                    check(root, b, value, path, &mut e);
                    why.push(e.join("; "));
                    e.is_empty()
                });
                if !any {
                    errors.push(format!("{path}: no branch of anyOf holds: {why:?}"));
                }
            }
            "not" => {
                let mut e = Vec::new();
                check(root, arg, value, path, &mut e);
                if e.is_empty() {
                    errors.push(format!("{path}: holds the schema under `not`: {arg}"));
                }
            }
            k if ANNOTATIONS.contains(&k) => {}
            k => panic!("docs/summary.schema.json uses `{k}`, which this validator does not check"),
        }
    }
}

/// Does `key` match the JSON Schema `pattern` (an ECMA-262 regular expression; the ones the schema uses are
/// also the syntax of Rust's `regex-lite`)?
fn matches_pattern(pattern: &str, key: &str) -> bool {
    regex_lite::Regex::new(pattern)
        .unwrap_or_else(|e| panic!("pattern `{pattern}`: {e}"))
        .is_match(key)
}

fn has_type(v: &Value, t: &str) -> bool {
    match t {
        "object" => v.is_object(),
        "array" => v.is_array(),
        "string" => v.is_string(),
        "number" => v.is_number(),
        "integer" => v.is_u64() || v.is_i64(),
        "boolean" => v.is_boolean(),
        "null" => v.is_null(),
        _ => panic!("unknown type {t}"),
    }
}

fn schema() -> Value {
    json_file(&root().join("docs/summary.schema.json"))
}

/// The errors of `value` against the schema's `$defs/<def>` (empty: valid).
fn errors_of(schema: &Value, def: &str, value: &Value) -> Vec<String> {
    let mut errors = Vec::new();
    check(schema, &schema["$defs"][def], value, def, &mut errors);
    errors
}

/// Every shipped model file: `models/*.toml` and `models/vehicles/*.toml`, relative to the repository root.
fn shipped_models() -> Vec<String> {
    let mut models = Vec::new();
    for dir in ["models", "models/vehicles"] {
        for entry in std::fs::read_dir(root().join(dir)).expect("models directory") {
            let name = entry
                .expect("entry")
                .file_name()
                .into_string()
                .expect("utf-8");
            if name.ends_with(".toml") {
                models.push(format!("{dir}/{name}"));
            }
        }
    }
    models.sort();
    assert!(models.len() >= 9, "{models:?}");
    models
}

/// A model with a `[hybrid]` table: `simulate` runs it with `--strategy ecms`; `forward` takes no strategy.
fn is_hybrid(model: &str) -> bool {
    let text = std::fs::read_to_string(root().join(model)).expect("model file");
    text.lines().any(|l| l.trim() == "[hybrid]")
}

fn is_modal(model: &str) -> bool {
    let text = std::fs::read_to_string(root().join(model)).expect("model file");
    text.lines()
        .any(|l| l.trim() == "[modes]" || l.starts_with("[modes."))
}

/// `forward` of a model whose output is not the vehicle's speed may find no state to start from at the
/// cycle's standstill (`diesel_gasflow`: its output is a boost pressure); such a run writes no summary.
const NO_FORWARD_START: &str = "cannot find the initial state at t0";

/// Run `invsim COMMAND MODEL [EXTRA…]` on the ECE at dt = 1 s, returning its summary JSON and the CSV's
/// header, or `None` for a forward run that finds no initial state (see [`NO_FORWARD_START`]).
fn run(command: &str, model: &str, extra: &[&str]) -> Option<(Value, Vec<String>)> {
    let tag = format!("{command}-{}{}", model.replace('/', "-"), extra.join(""));
    let (json, csv) = (tmp(&format!("{tag}.json")), tmp(&format!("{tag}.csv")));
    let mut args = vec![command, model, "--cycle", "ece", "--dt", "1"];
    args.extend(extra);
    args.extend([
        "--summary-json",
        json.to_str().expect("utf-8"),
        "--out",
        csv.to_str().expect("utf-8"),
    ]);
    let o = invsim(&args);
    if command == "forward" && !o.status.success() && stderr(&o).contains(NO_FORWARD_START) {
        eprintln!("skipping forward of {model}: it finds no initial state at the ECE's standstill");
        return None;
    }
    assert!(o.status.success(), "{command} {model}: {}", stderr(&o));
    let text = std::fs::read_to_string(&csv).expect("CSV");
    let header = text
        .lines()
        .next()
        .unwrap_or("")
        .split(',')
        .map(String::from);
    Some((json_file(&json), header.collect()))
}

#[test]
fn every_model_s_simulate_and_forward_summaries_follow_the_schema() {
    let schema = schema();
    let mut failures = Vec::new();
    let (mut checked, mut modal) = (0, 0);
    let models = shipped_models();
    for model in &models {
        for (command, def) in [("simulate", "simulate"), ("forward", "forward")] {
            let hybrid = is_hybrid(model);
            if hybrid && command == "forward" {
                continue;
            }
            let extra: &[&str] = if hybrid { &["--strategy", "ecms"] } else { &[] };
            let Some((s, header)) = run(command, model, extra) else {
                continue;
            };
            if hybrid && s.get("hybrid").is_none() {
                failures.push(format!("{command} {model}: no `hybrid` block"));
            }
            checked += 1;
            modal += usize::from(is_modal(model));
            let mut errors = summary_errors(&schema, (command, def), &s, &header);
            if is_modal(model) != s.get("modes").is_some() {
                errors.push(format!("`modes` block: {:?}", s.get("modes")));
            }
            failures.extend(
                errors
                    .into_iter()
                    .map(|e| format!("{command} {model}: {e}")),
            );
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // Every model's simulate, every forward but diesel_gasflow's and the hybrids'; both commands of both
    // models with modes.
    let hybrids = models.iter().filter(|m| is_hybrid(m)).count();
    assert!(
        checked >= 2 * models.len() - 1 - hybrids,
        "{checked} runs checked"
    );
    assert!(modal >= 4, "{modal} runs of models with modes checked");
}

/// Where the summary `s` of `command` (validated against `$defs/<def>` and the whole schema) breaks the
/// schema, lists other columns than the CSV's `header`, or has no provenance of `command`.
fn summary_errors(
    schema: &Value,
    (command, def): (&str, &str),
    s: &Value,
    header: &[String],
) -> Vec<String> {
    let mut errors = errors_of(schema, def, s);
    // The whole schema (either kind of summary) holds too.
    check(schema, schema, s, "summary", &mut errors);
    let columns: Vec<&str> = s["columns"]
        .as_array()
        .map(|c| c.iter().filter_map(|c| c["name"].as_str()).collect())
        .unwrap_or_default();
    if columns != header {
        errors.push(format!("columns {columns:?} are not the CSV's {header:?}"));
    }
    if s["provenance"]["command"] != command {
        errors.push(format!("provenance: {}", s["provenance"]));
    }
    errors
}

/// The optional blocks follow the schema too: tracking errors (`--verify`), the quasi-static switching's
/// impulses, coupling resets, a stable inversion's numbers, `forward` with the bounds enforced, the
/// parameter gradients (`--gradient`) of a fuel headline (r = n) and an electric one (causal).
#[test]
fn summaries_with_their_optional_blocks_follow_the_schema() {
    let schema = schema();
    let mut failures = Vec::new();
    let runs: [(&str, &str, &[&str], &[&str]); 8] = [
        (
            "simulate",
            "models/si_engine.toml",
            &["--gradient", "all"],
            &["gradient"],
        ),
        (
            "simulate",
            "models/bev.toml",
            &["--gradient", "m,C_d"],
            &["gradient"],
        ),
        (
            "simulate",
            "models/si_engine.toml",
            &["--verify"],
            &["max_abs_tracking_error", "rms_tracking_error"],
        ),
        (
            "simulate",
            "models/diesel_gasflow.toml",
            &["--verify"],
            &["stable_inversion", "max_abs_tracking_error"],
        ),
        (
            "simulate",
            "models/si_engine_5speed.toml",
            &["--verify", "--switching", "quasi-static"],
            &["max_abs_tracking_error", "rms_tracking_error"],
        ),
        (
            "simulate",
            "models/ford_fusion_2012_dynamic_6speed.toml",
            &["--verify"],
            &["signals", "max_abs_tracking_error"],
        ),
        (
            "forward",
            "models/si_engine_5speed.toml",
            &["--bounds", "enforce", "--method", "rosenbrock23"],
            &["trace_misses"],
        ),
        (
            "forward",
            "models/ford_fusion_2012_dynamic_6speed.toml",
            &["--bounds", "enforce"],
            &["signals"],
        ),
    ];
    for (command, model, extra, present) in runs {
        let (s, header) = run(command, model, extra).expect("a summary");
        let mut errors = summary_errors(&schema, (command, command), &s, &header);
        errors.extend(
            present
                .iter()
                .filter(|k| s.get(**k).is_none())
                .map(|k| format!("`{k}` is missing")),
        );
        if extra.contains(&"quasi-static") {
            let impulses = s["modes"]["impulses"].as_array().map_or(0, Vec::len);
            if impulses == 0 || s["modes"]["switching"] != "quasi_static" {
                errors.push(format!("quasi-static: {}", s["modes"]));
            }
        }
        failures.extend(
            errors
                .into_iter()
                .map(|e| format!("{command} {model} {extra:?}: {e}")),
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A parameter of `model` and its value (a modal model: its first mode's), from `invsim derive`.
fn some_parameter(model: &str) -> (String, f64) {
    let o = invsim(&["derive", model, "--format", "json"]);
    assert!(o.status.success(), "derive {model}: {}", stderr(&o));
    let d: Value = serde_json::from_slice(&o.stdout).expect("derive JSON");
    let params = d["parameters"]
        .as_object()
        .or_else(|| d["modes"][0]["derivation"]["parameters"].as_object())
        .expect("parameters");
    let (name, value) = params
        .iter()
        .find(|(_, v)| v.as_f64().is_some_and(|v| v != 0.0))
        .expect("a non-zero parameter");
    (name.clone(), value.as_f64().expect("number"))
}

#[test]
fn every_model_s_sweep_rows_follow_the_schema() {
    let schema = schema();
    let mut failures = Vec::new();
    // A hybrid's sweep runs with a strategy and has the hybrid columns.
    for model in shipped_models() {
        let (name, value) = some_parameter(&model);
        let csv = tmp(&format!("sweep-{}.csv", model.replace('/', "-")));
        let grid = format!("{name}={}:{}:2", value, value * 1.01);
        let mut args = vec![
            "sweep",
            &model,
            "--cycle",
            "ece",
            "--dt",
            "1",
            "--threads",
            "1",
            "--grid",
            &grid,
            "--out",
            csv.to_str().expect("utf-8"),
        ];
        if is_hybrid(&model) {
            args.extend(["--strategy", "ecms"]);
        }
        let o = invsim(&args);
        assert!(o.status.success(), "sweep {model}: {}", stderr(&o));
        let mut reader = csv::Reader::from_path(&csv).expect("sweep CSV");
        let header: Vec<String> = reader
            .headers()
            .expect("header")
            .iter()
            .map(String::from)
            .collect();
        // A model with modes has its modes' columns, named by the schema (not merely allowed as numbers).
        // (A hybrid's standstill mode is its own: no `idle`.)
        let idle = if is_hybrid(&model) {
            "time_stop_s"
        } else {
            "time_idle_s"
        };
        let modal_columns = ["switches", "max_transition_deviation", idle];
        for c in modal_columns.iter().filter(|_| is_modal(&model)) {
            assert!(
                header.iter().any(|h| h == c),
                "sweep {model}: no column {c}"
            );
        }
        let hybrid_columns = ["fuel_energy_corrected_j", "delta_soc", "engine_starts"];
        for c in hybrid_columns.iter().filter(|_| is_hybrid(&model)) {
            assert!(
                header.iter().any(|h| h == c),
                "sweep {model}: no column {c}"
            );
        }
        let mut rows = 0;
        for record in reader.records() {
            let record = record.expect("row");
            let row: serde_json::Map<String, Value> = header
                .iter()
                .zip(record.iter())
                .map(|(k, v)| (k.clone(), cell(v)))
                .collect();
            let row = Value::Object(row);
            failures.extend(
                errors_of(&schema, "sweep_row", &row)
                    .into_iter()
                    .map(|e| format!("sweep {model}: {e}")),
            );
            if row["status"] != "ok" {
                failures.push(format!("sweep {model}: a run failed: {}", row["error"]));
            }
            rows += 1;
        }
        assert_eq!(rows, 2, "sweep {model}: one row per variant");
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A CSV field as JSON: empty → null, an integer or a number → that number (NaN → null), else the text.
fn cell(field: &str) -> Value {
    if field.is_empty() {
        return Value::Null;
    }
    if let Ok(i) = field.parse::<i64>() {
        return Value::from(i);
    }
    match field.parse::<f64>() {
        Ok(x) => serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number),
        Err(_) => Value::String(field.to_string()),
    }
}

#[test]
fn the_validator_catches_what_the_schema_forbids() {
    let schema = schema();
    let good = serde_json::json!({"name": "v", "unit": null});
    assert!(errors_of(&schema, "column", &good).is_empty());
    for bad in [
        serde_json::json!({"name": "v"}),
        serde_json::json!({"name": 1, "unit": null}),
        serde_json::json!({"name": "v", "unit": null, "extra": 0}),
    ] {
        assert!(!errors_of(&schema, "column", &bad).is_empty(), "{bad}");
    }
    let interval = |v: Value| errors_of(&schema, "interval", &v).len();
    assert_eq!(interval(serde_json::json!([0.0, 1.0])), 0);
    assert_eq!(interval(serde_json::json!([0.0])), 1);
    assert_eq!(interval(serde_json::json!([0.0, "1"])), 1);
    // A modal summary's old key `per_100km` is not in the schema.
    let mut s = serde_json::Map::new();
    s.insert("per_100km".into(), serde_json::json!({}));
    let errors = errors_of(&schema, "simulate", &Value::Object(s));
    assert!(errors.iter().any(|e| e.contains("per_100km")), "{errors:?}");
}
