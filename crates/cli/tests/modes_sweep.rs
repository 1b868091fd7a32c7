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

/// A gear ratio is set per gear by the gearbox: sweeping it whole is refused, naming the parameter and its
/// per-gear names.
#[test]
fn a_gearbox_parameter_is_not_swept_whole() {
    let o = invsim(&[
        "sweep",
        "models/si_engine_5speed.toml",
        "--cycle",
        "ece",
        "--grid",
        "i_g=3:4:2",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("i_g[1] … i_g[5]"), "{}", stderr(&o));
}

/// One gear's ratio swept by its per-gear name (`--grid 'i_g[3]=…'`): every row's fuel equals `simulate` of
/// a copy of the model file whose [gearbox] lists that ratio for third gear (no `--set`: the file itself);
/// a gear the gearbox does not have is an unknown name listing the per-gear ones.
#[test]
fn one_gear_s_ratio_is_swept_by_its_per_gear_name() {
    let model = "models/si_engine_5speed.toml";
    let out = tmp("modal-sweep-i_g3.csv");
    let o = invsim(&[
        "sweep",
        model,
        "--cycle",
        "ece",
        "--dt",
        "0.5",
        "--grid",
        "i_g[3]=1.2:1.5:2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_csv(&out);
    let col = |name: &str| header.iter().position(|h| h == name).expect(name);
    let text = std::fs::read_to_string(common::root().join(model)).unwrap();
    let ratios = "i_g = [3.58, 2.02, 1.35, 1.03, 0.81]";
    assert!(text.contains(ratios), "the model's [gearbox] ratios");
    let mut fuels = Vec::new();
    for row in &rows {
        let third = &row[col("i_g[3]")];
        let copy = tmp(&format!("si_engine_5speed_i_g3_{third}.toml"));
        let edited = text.replace(ratios, &format!("i_g = [3.58, 2.02, {third}, 1.03, 0.81]"));
        std::fs::write(&copy, edited).unwrap();
        let summary = tmp(&format!("si_engine_5speed_i_g3_{third}.json"));
        let s = invsim(&[
            "simulate",
            copy.to_str().unwrap(),
            "--cycle",
            "ece",
            "--dt",
            "0.5",
            "--summary-json",
            summary.to_str().unwrap(),
        ]);
        assert!(s.status.success(), "{}", stderr(&s));
        let expected = json_file(&summary)["integrals"]["fuel"].as_f64().unwrap();
        let swept = num(&row[col("fuel")]);
        assert!(
            (swept - expected).abs() <= 1e-9 * expected,
            "i_g[3] = {third}: sweep {swept}, simulate {expected}"
        );
        fuels.push(swept);
    }
    assert_eq!(rows.len(), 2);
    assert!(
        fuels[1] > fuels[0],
        "a shorter third gear burns more: {fuels:?}"
    );
    let o = invsim(&["sweep", model, "--cycle", "ece", "--grid", "i_g[6]=1:2:2"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("unknown parameter `i_g[6]`"),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains("i_g[5]"), "{}", stderr(&o));
}
