//! Impossible vehicles are refused: every field of the range table, set just outside its range in each vehicle
//! of the library (Fusion, Leaf, Bolt, Pacifica), is an error naming the field, the value, the range and the line and column of the
//! value; a vehicle name with line breaks, quotes, backslashes or control characters stays one TOML string
//! (the model loads and its description carries the name unchanged).

use crate::common::{vehicle_files, vehicles_dir};
use invsim_import::{describe_range, import_fastsim, parse_yaml, Range, FIELD_RANGES};
use serde_yaml::Value;

/// The node at a dotted path (`a.b[0][3]`), for writing.
fn node_mut<'a>(root: &'a mut Value, path: &str) -> Option<&'a mut Value> {
    let mut node = root;
    for seg in path.split('.') {
        let (key, rest) = seg.split_at(seg.find('[').unwrap_or(seg.len()));
        if !key.is_empty() {
            node = node.as_mapping_mut()?.get_mut(key)?;
        }
        if !rest.is_empty() {
            for i in rest[1..rest.len() - 1].split("][") {
                node = node.as_sequence_mut()?.get_mut(i.parse::<usize>().ok()?)?;
            }
        }
    }
    Some(node)
}

/// Values just outside `r`.
fn outside(r: &Range) -> Vec<f64> {
    let mut v = vec![if r.lo_closed { r.lo - 0.5 } else { r.lo }];
    if r.hi.is_finite() {
        v.push(if r.hi_closed { r.hi + 0.5 } else { r.hi });
    }
    if r.integer {
        v.push(r.lo + 1.5);
    }
    v
}

/// The concrete paths of a table entry in `yaml`: each `[]` as the first and the last index (a 2-D table's
/// corners); a `{Constant: x}` efficiency as its inner number.
fn concrete(yaml: &Value, pattern: &str) -> Vec<String> {
    let lookup = |p: &str| invsim_import::yaml_lookup(yaml, p).cloned();
    if let Some(open) = pattern.find("[]") {
        let (base, rest) = (&pattern[..open], &pattern[open + 2..]);
        let n = lookup(base)
            .and_then(|v| v.as_sequence().map(Vec::len))
            .unwrap_or(0);
        let mut indices = vec![0, n.saturating_sub(1)];
        indices.dedup();
        return match n {
            0 => Vec::new(),
            _ => indices
                .into_iter()
                .flat_map(|i| concrete(yaml, &format!("{base}[{i}]{rest}")))
                .collect(),
        };
    }
    match lookup(pattern) {
        Some(Value::Mapping(m)) if m.contains_key("Constant") => {
            vec![format!("{pattern}.Constant")]
        }
        Some(Value::Mapping(_)) => Vec::new(),
        Some(_) => vec![pattern.to_string()],
        None => Vec::new(),
    }
}

/// Whether the importer reads the field `pattern` of `yaml`: the battery's initial temperature only for its
/// efficiency table (the Bolt's), the fuel cut-off's thresholds only when it is enabled, stop-start's and the
/// hybrid controller's temperature thresholds only with the engine's thermal model.
fn read_in(yaml: &Value, pattern: &str) -> bool {
    let has = |p: &str| invsim_import::yaml_lookup(yaml, p);
    for pt in ["Conv", "HEV"] {
        let thermal = has(&format!("pt_type.{pt}.fc.thrml.FuelConverterThermal")).is_some();
        if pattern.starts_with(&format!("pt_type.{pt}.fc.thrml."))
            || pattern == format!("pt_type.{pt}.pt_cntrl.StartStop.temp_fc_forced_on_kelvin")
            || pattern == format!("pt_type.{pt}.pt_cntrl.RGWDB.temp_fc_forced_on_kelvin")
        {
            return thermal;
        }
    }
    if pattern.ends_with("temperature_kelvin") {
        return has("pt_type.BEV.res.eff_interp.CRateTemperature").is_some();
    }
    if pattern.starts_with("pt_type.Conv.dfco_cntrl.") {
        return has("pt_type.Conv.dfco_cntrl.dfco_enabled").and_then(Value::as_bool) == Some(true);
    }
    true
}

/// The number written at 1-based `line`, `column` of `text`.
fn number_at(text: &str, line: usize, column: usize) -> f64 {
    let l = text.lines().nth(line - 1).unwrap();
    let token: String = l
        .chars()
        .skip(column - 1)
        .take_while(|c| !c.is_whitespace() && *c != ',' && *c != ']')
        .collect();
    token
        .parse()
        .unwrap_or_else(|_| panic!("no number at {line}:{column}: {l}"))
}

#[test]
fn every_field_outside_its_range_is_refused_with_its_position() {
    let mut checked = 0;
    for path in vehicle_files() {
        let file = path.file_name().unwrap().to_str().unwrap();
        let original = parse_yaml(&std::fs::read_to_string(&path).unwrap()).unwrap();
        for (pattern, range, _) in FIELD_RANGES {
            if !read_in(&original, pattern) {
                continue;
            }
            for path in concrete(&original, pattern) {
                for bad in outside(range) {
                    let mut yaml = original.clone();
                    *node_mut(&mut yaml, &path).unwrap() = Value::from(bad);
                    let text = serde_yaml::to_string(&yaml).unwrap();
                    let e = import_fastsim(&text, file)
                        .err()
                        .unwrap_or_else(|| panic!("{file}: {path} = {bad} was imported"));
                    let message = e.message_for("v.yaml");
                    let expected = format!("field `{path}`: {bad} is outside the range of ");
                    assert!(message.contains(&expected), "{message}");
                    assert!(message.ends_with(&describe_range(range)), "{message}");
                    let position: Vec<usize> = message
                        .split(':')
                        .skip(1)
                        .take(2)
                        .map(|n| n.parse().unwrap_or_else(|_| panic!("{message}")))
                        .collect();
                    assert_eq!(number_at(&text, position[0], position[1]), bad, "{message}");
                    checked += 1;
                }
            }
        }
    }
    // Every entry of the table is met in at least one library file.
    assert!(checked >= 100, "{checked} values checked");
}

#[test]
fn the_reported_impossible_vehicles_are_refused() {
    let fusion = std::fs::read_to_string(vehicles_dir().join("ford_fusion_2012.yaml")).unwrap();
    for (from, to, field) in [
        (
            "eff_interp: 0.875",
            "eff_interp: 5",
            "`pt_type.Conv.transmission.eff_interp`: 5 is",
        ),
        (
            "eff_interp: 0.875",
            "eff_interp: 0",
            "`pt_type.Conv.transmission.eff_interp`: 0 is",
        ),
        (
            "pwr_aux_base_watts: 700.0",
            "pwr_aux_base_watts: -700.0",
            "`pwr_aux_base_watts`: -700 is",
        ),
        (
            "specific_energy_joules_per_kilogram: 43200000.0",
            "specific_energy_joules_per_kilogram: -43200000.0",
            "`pt_type.Conv.fs.specific_energy_joules_per_kilogram`: -43200000 is",
        ),
    ] {
        let text = fusion.replace(from, to);
        assert_ne!(text, fusion);
        let e = import_fastsim(&text, "f.yaml").unwrap_err();
        let line = 1 + text[..text.find(to).unwrap()].matches('\n').count();
        let column =
            to.find(' ').unwrap() + 2 + text.lines().nth(line - 1).unwrap().find(to).unwrap();
        let message = e.message_for("f.yaml");
        assert!(
            message.starts_with(&format!("f.yaml:{line}:{column}: field {field}")),
            "{message}"
        );
    }
}

#[test]
fn a_hostile_vehicle_name_stays_one_string() {
    let fusion = std::fs::read_to_string(vehicles_dir().join("ford_fusion_2012.yaml")).unwrap();
    let name = "Ford \"Fusion\" \\ 2012\nname = \"x\"\r\n[parameters]\u{1}\u{7f}\u{85} end";
    let mut yaml = parse_yaml(&fusion).unwrap();
    *node_mut(&mut yaml, "name").unwrap() = Value::from(name);
    let text = serde_yaml::to_string(&yaml).unwrap();
    let imported = import_fastsim(&text, "bad\nname = 1.yaml").unwrap();
    let model: toml::Table = imported.model.parse().unwrap();
    let description = model["description"].as_str().unwrap();
    assert!(
        description.starts_with(&format!("{name} (conventional)")),
        "{description}"
    );
    assert_eq!(
        model["name"].as_str(),
        Some("ford_fusion_2012_name_x_parameters_end")
    );
    let first = imported.model.lines().next().unwrap();
    assert!(
        first.starts_with("# Ford \"Fusion\" \\ 2012\\u000aname = \"x\"\\u000d\\u000a"),
        "{first}"
    );
    assert!(imported
        .model
        .lines()
        .all(|l| !l.starts_with("name = \"x\"")));
    let m = invsim_inversion::Model::from_bytes(
        std::path::Path::new("m.toml"),
        imported.model.as_bytes(),
    )
    .unwrap();
    invsim_inversion::Derivation::new(m).unwrap();
}

#[test]
fn an_engine_efficiency_of_zero_is_allowed_only_at_zero_load() {
    // The Pacifica's table starts at (0, 0): it imports. A 0 at a positive load divides the fuel power by
    // zero, and so does a step-wise table's 0 at zero load (it holds up to the next grid point).
    let pacifica =
        std::fs::read_to_string(vehicles_dir().join("chrysler_pacifica_2026.yaml")).unwrap();
    assert!(import_fastsim(&pacifica, "p.yaml").is_ok());
    let second = pacifica.replacen("- 0.09338201", "- 0.0", 1);
    assert_ne!(second, pacifica);
    let e = import_fastsim(&second, "p.yaml").unwrap_err().to_string();
    assert!(
        e.contains(
            "eff_interp_from_pwr_out.data.values[1]`: an efficiency of 0 at load 0.005 divides"
        ),
        "{e}"
    );
    let step = pacifica.replacen("strategy: Linear", "strategy:\n          Step: Lower", 1);
    assert_ne!(step, pacifica);
    let e = import_fastsim(&step, "p.yaml").unwrap_err().to_string();
    assert!(
        e.contains("values[0]`: an efficiency of 0 at load 0 divides"),
        "{e}"
    );
}

#[test]
fn every_table_entry_is_met_in_the_library() {
    // The out-of-range test above reaches a field only where a library file has it: each entry must occur.
    let files: Vec<Value> = vehicle_files()
        .iter()
        .map(|p| parse_yaml(&std::fs::read_to_string(p).unwrap()).unwrap())
        .collect();
    for (pattern, _, _) in FIELD_RANGES {
        assert!(
            files.iter().any(|y| !concrete(y, pattern).is_empty()),
            "no library vehicle has `{pattern}`"
        );
    }
}
