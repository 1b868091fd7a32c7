//! `invsim sweep` of models with operating modes (si_engine_5speed, the 6-speed dynamic Fusion): every row
//! equals `invsim simulate --set …` of its variant bit for bit (compiled and interpreted, 1 and 2 threads),
//! with the time in each mode, the switches and the largest transition deviation as columns.

use crate::common;
use std::collections::HashMap;

use common::{invsim, json_file, num, read_csv, stderr, tmp};

/// Sweep `model` over two masses on ece and hwfet with `engine` and `threads`, and compare every row with
/// `simulate --set m=…` of its variant.
fn check_against_simulate(model: &str, engine: &str, threads: &str) {
    let stem = std::path::Path::new(model)
        .file_stem()
        .unwrap()
        .to_string_lossy()
        .to_string();
    let out = tmp(&format!("modal-sweep-{stem}-{engine}-{threads}.csv"));
    let o = invsim(&[
        "sweep",
        model,
        "--cycles",
        "ece,hwfet",
        "--dt",
        "0.5",
        "--grid",
        "m=1300:1700:2",
        "--engine",
        engine,
        "--threads",
        threads,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{model}: {}", stderr(&o));
    let (header, rows) = read_csv(&out);
    assert_eq!(rows.len(), 2 * 2, "{model}");
    let col: HashMap<&str, usize> = header
        .iter()
        .enumerate()
        .map(|(i, h)| (h.as_str(), i))
        .collect();
    for row in &rows {
        assert_eq!(row[col["status"]], "ok", "{model}: {}", row[col["error"]]);
        let (m, cycle) = (&row[col["m"]], &row[col["cycle"]]);
        let json = tmp(&format!(
            "modal-single-{stem}-{engine}-{threads}-{m}-{cycle}.json"
        ));
        let single = invsim(&[
            "simulate",
            model,
            "--cycle",
            cycle,
            "--dt",
            "0.5",
            "--set",
            &format!("m={m}"),
            "--engine",
            engine,
            "--summary-json",
            json.to_str().unwrap(),
        ]);
        assert!(single.status.success(), "{}", stderr(&single));
        let s = json_file(&json);
        assert_eq!(s["engine"], engine);
        assert_eq!(
            num(&row[col["samples"]]) as u64,
            s["samples"].as_u64().unwrap()
        );
        assert_eq!(
            num(&row[col["distance_m"]]),
            s["distance_m"].as_f64().unwrap()
        );
        // Bit for bit: the same f64 values.
        let integrals = s["integrals"].as_object().expect("integrals");
        assert!(integrals.contains_key("fuel"), "{model}");
        let per_100km = &s["integrals_per_100km"];
        for (name, v) in integrals {
            assert_eq!(
                num(&row[col[name.as_str()]]),
                v.as_f64().unwrap(),
                "{model} {name}"
            );
            let per = format!("{name}_per_100km");
            assert_eq!(
                num(&row[col[per.as_str()]]),
                per_100km[name].as_f64().unwrap(),
                "{per}"
            );
        }
        assert_eq!(
            num(&row[col["switches"]]) as u64,
            s["modes"]["switches"].as_u64().unwrap()
        );
        assert!(
            s["modes"]["switches"].as_u64().unwrap() > 0,
            "{model} on {cycle} switches"
        );
        assert_eq!(
            num(&row[col["max_transition_deviation"]]),
            s["modes"]["max_transition_deviation"].as_f64().unwrap()
        );
        let modes = s["modes"]["per_mode"].as_array().expect("modes");
        let mut total = 0.0;
        for mode in modes {
            let name = format!("time_{}_s", mode["name"].as_str().unwrap());
            let t = num(&row[col[name.as_str()]]);
            assert_eq!(t, mode["time_s"].as_f64().unwrap(), "{name}");
            total += t;
        }
        assert!(
            (total - s["duration_s"].as_f64().unwrap()).abs() < 1e-6,
            "{model}: {total}"
        );
        for key in ["input_min", "input_max"] {
            assert_eq!(num(&row[col[key]]), s[key].as_f64().unwrap(), "{key}");
        }
        let violations = s["input_bound_violations"].as_array().unwrap();
        assert_eq!(num(&row[col["violations"]]) as usize, violations.len());
    }
}

#[test]
fn five_speed_rows_equal_simulate() {
    for (engine, threads) in [
        ("compiled", "1"),
        ("compiled", "2"),
        ("interpreted", "1"),
        ("interpreted", "2"),
    ] {
        check_against_simulate("models/si_engine_5speed.toml", engine, threads);
    }
}

#[test]
fn six_speed_fusion_rows_equal_simulate() {
    for (engine, threads) in [
        ("compiled", "1"),
        ("compiled", "2"),
        ("interpreted", "1"),
        ("interpreted", "2"),
    ] {
        check_against_simulate(
            "models/ford_fusion_2012_dynamic_6speed.toml",
            engine,
            threads,
        );
    }
}

/// A gear ratio is set per gear by the gearbox: sweeping it is refused, naming the parameter.
#[test]
fn a_gearbox_parameter_is_not_swept() {
    let o = invsim(&[
        "sweep",
        "models/si_engine_5speed.toml",
        "--cycle",
        "ece",
        "--grid",
        "i_g=3:4:2",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("i_g"), "{}", stderr(&o));
}
