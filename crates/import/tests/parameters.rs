//! The importer carries every parameter over: for the imported conventional (Fusion) and battery-electric
//! (Leaf) vehicles, each parameter's value equals the YAML field its doc names (FASTSim `path`), or FASTSim's
//! physical constant, each map the table its doc names; and the model derives with relative degree 1
//! (state v, input F_t).

use crate::common::vehicles_dir;
use invsim_import::{import_fastsim, parse_yaml, yaml_lookup, Powertrain, AIR_DENSITY, GRAVITY};

/// Check every parameter of the model imported from `file`; returns the number checked against the YAML.
fn check(file: &str, expected: Powertrain) -> usize {
    let text = std::fs::read_to_string(vehicles_dir().join(file)).unwrap();
    let yaml = parse_yaml(&text).unwrap();
    let imported = import_fastsim(&text, file).unwrap();
    assert_eq!(imported.powertrain, expected);
    let model: toml::Table = imported.model.parse().unwrap();
    let params = model["parameters"].as_table().unwrap();
    let mut from_yaml = 0;
    for (name, p) in params {
        let value = p["value"].as_float().unwrap();
        let doc = p["doc"].as_str().unwrap();
        assert!(!p["unit"].as_str().unwrap().is_empty(), "{name} has a unit");
        let path = doc
            .split("FASTSim `")
            .nth(1)
            .and_then(|s| s.split('`').next());
        match (name.as_str(), path) {
            ("rho_a", _) => assert_eq!(value, AIR_DENSITY),
            ("g_0", _) => assert_eq!(value, GRAVITY),
            (_, Some(path)) => {
                let field =
                    yaml_lookup(&yaml, path).unwrap_or_else(|| panic!("{name}: no field {path}"));
                assert_eq!(Some(value), field.as_f64(), "{name} = {value} vs {path}");
                from_yaml += 1;
            }
            (_, None) => panic!("{name}: doc names no FASTSim field: {doc}"),
        }
    }
    assert_eq!(model["signals"]["grade"]["default"].as_float(), Some(0.0));
    from_yaml += check_maps(&model, &yaml);
    let m =
        invsim_inversion::Model::from_bytes(std::path::Path::new(file), imported.model.as_bytes())
            .unwrap();
    let d = invsim_inversion::Derivation::new(m).unwrap();
    assert_eq!(d.relative_degree, 1);
    from_yaml
}

/// Every `[maps.NAME]` holds the grid and values of the FASTSim table its doc names; the number of maps.
fn check_maps(model: &toml::Table, yaml: &serde_yaml::Value) -> usize {
    let Some(maps) = model.get("maps").and_then(|m| m.as_table()) else {
        return 0;
    };
    let floats = |v: &toml::Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_float().unwrap())
            .collect()
    };
    let yaml_floats = |path: &str| -> Vec<f64> {
        let v = yaml_lookup(yaml, path).unwrap_or_else(|| panic!("no field {path}"));
        v.as_sequence()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    for (name, m) in maps {
        let doc = m["doc"].as_str().unwrap();
        let path = doc
            .split("FASTSim `")
            .nth(1)
            .and_then(|s| s.split('`').next())
            .unwrap();
        assert_eq!(
            floats(&m["x"]),
            yaml_floats(&format!("{path}.data.grid[0]")),
            "{name}.x"
        );
        assert_eq!(
            floats(&m["values"]),
            yaml_floats(&format!("{path}.data.values")),
            "{name}.values"
        );
        assert_eq!(m["interp"].as_str(), Some("linear"), "{name}");
    }
    maps.len()
}

#[test]
fn conventional_parameters_equal_the_vehicle_file() {
    // chassis (8) + engine (5) + the efficiency map (grid and values)
    assert_eq!(
        check("ford_fusion_2012.yaml", Powertrain::Conventional),
        8 + 5 + 1
    );
}

#[test]
fn battery_electric_parameters_equal_the_vehicle_file() {
    // chassis (8) + powertrain (5) + 11 grid points and 11 efficiencies
    assert_eq!(
        check("nissan_leaf_2016.yaml", Powertrain::BatteryElectric),
        8 + 5 + 22
    );
}

#[test]
fn unused_fields_are_listed_in_a_warning() {
    let text = std::fs::read_to_string(vehicles_dir().join("ford_fusion_2012.yaml")).unwrap();
    let imported = import_fastsim(&text, "f.yaml").unwrap();
    let all = imported.warnings.join("\n");
    for field in [
        "pt_type.Conv.fc.pwr_ramp_lag_seconds",
        "chassis.wheel_fric_coef",
        "pt_type.Conv.fs.energy_capacity_joules",
    ] {
        assert!(all.contains(field), "{field} not listed: {all}");
    }
    // and nothing that the model uses
    assert!(
        !all.contains("drag_coef") && !all.contains("eff_interp_from_pwr_out"),
        "{all}"
    );
}

#[test]
fn battery_electric_with_a_linear_motor_map_derives() {
    // The Leaf's motor table made linear (as the Zoe's is): a map, regeneration at the map's zero-load value.
    let text = std::fs::read_to_string(vehicles_dir().join("nissan_leaf_2016.yaml")).unwrap();
    let text = text.replacen("strategy:\n          Step: Lower", "strategy: Linear", 1);
    let imported = import_fastsim(&text, "linear.yaml").unwrap();
    assert!(
        imported.model.contains("[maps.em_map]"),
        "{}",
        imported.model
    );
    assert!(imported.model.contains("min(P_em, 0)*em_map(0)"));
    let m = invsim_inversion::Model::from_bytes(
        std::path::Path::new("linear.yaml"),
        imported.model.as_bytes(),
    )
    .unwrap();
    assert_eq!(
        invsim_inversion::Derivation::new(m)
            .unwrap()
            .relative_degree,
        1
    );
}
