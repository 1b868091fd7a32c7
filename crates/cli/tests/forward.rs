//! `invsim forward` and `invsim simulate --verify` as a user meets them: exit codes, the CSV and JSON layouts,
//! the tracking and fuel figures of the paper's SI-engine car on the NEDC.

use crate::common;
use common::*;

use serde_json::Value;

fn summary(args: &[&str], name: &str) -> Value {
    let json = tmp(name);
    let mut all = args.to_vec();
    all.extend(["--summary-json", json.to_str().unwrap()]);
    let o = invsim(&all);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap()
}

#[test]
fn forward_writes_csv_and_summary() {
    let csv = tmp("fwd.csv");
    let s = summary(
        &[
            "forward",
            "models/si_engine.toml",
            "--cycle",
            "nedc",
            "--out",
            csv.to_str().unwrap(),
        ],
        "fwd.json",
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(
        text.lines().next().unwrap(),
        "t,yc,m_at,v,p_i,fuel,fuel_volume,n_e,T_e"
    );
    assert_eq!(text.lines().count(), 1 + 11_801);
    assert_eq!(s["cycle"], "nedc");
    assert_eq!(s["samples"], 11_801);
    assert_eq!(s["bounds"], "ignore");
    assert_eq!(s["driver"]["kp"], 2.0);
    assert_eq!(s["driver"]["feedforward"], true);
    assert_eq!(s["integrator"]["method"], "dopri5");
    assert!(s["trace_misses"].as_array().unwrap().is_empty());
    assert!(s["max_abs_tracking_error"].as_f64().unwrap() * 3.6 < 1.0);
    assert!(s["integrals"]["fuel"].as_f64().unwrap() > 0.0);
    assert!(s["engine"] == "compiled" || s["engine"] == "interpreted");
}

/// Forward (PI driver, bounds ignored) and inverse simulation of the same car burn the same fuel within 2 %.
#[test]
fn forward_and_inverse_fuel_agree() {
    let fwd = summary(
        &[
            "forward",
            "models/si_engine.toml",
            "--cycle",
            "nedc",
            "--dt",
            "0.01",
        ],
        "f.json",
    );
    let inv = summary(
        &[
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "nedc",
            "--dt",
            "0.01",
        ],
        "i.json",
    );
    let (a, b) = (
        fwd["integrals"]["fuel"].as_f64().unwrap(),
        inv["integrals"]["fuel"].as_f64().unwrap(),
    );
    assert!(((a - b) / b).abs() < 0.02, "forward {a} kg, inverse {b} kg");
}

#[test]
fn forward_with_bounds_enforced_reports_trace_misses() {
    let s = summary(
        &[
            "forward",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--bounds",
            "enforce",
        ],
        "enf.json",
    );
    assert_eq!(s["bounds"], "enforce");
    let misses = s["trace_misses"].as_array().unwrap();
    assert!(!misses.is_empty());
    assert!(s["input_min"].as_f64().unwrap() >= 0.0);
    let o = invsim(&[
        "forward",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--bounds",
        "enforce",
    ]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("trace misses: ") && text.contains("bounds enforce"),
        "{text}"
    );
}

#[test]
fn forward_options_and_engines() {
    let s = summary(
        &[
            "forward",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--kp",
            "1",
            "--ki",
            "0.5",
            "--no-feedforward",
            "--method",
            "rosenbrock23",
            "--rtol",
            "1e-6",
            "--engine",
            "interpreted",
            "--set",
            "m=1500",
        ],
        "opts.json",
    );
    assert_eq!(s["driver"]["kp"], 1.0);
    assert_eq!(s["driver"]["ki"], 0.5);
    assert_eq!(s["driver"]["feedforward"], false);
    assert_eq!(s["integrator"]["method"], "rosenbrock23");
    assert_eq!(s["engine"], "interpreted");
}

#[test]
fn forward_bad_options_exit_2() {
    for (args, needle) in [
        (vec!["--kp", "-1"], "kp"),
        (vec!["--dt", "0"], "dt"),
        (vec!["--response", "0"], "response"),
        (vec!["--bounds", "sometimes"], "sometimes"),
        (vec!["--set", "nope=3"], "unknown parameter `nope`"),
    ] {
        let mut all = vec!["forward", "models/si_engine.toml", "--cycle", "ece"];
        all.extend(args.iter().copied());
        let o = invsim(&all);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
    let o = invsim(&["forward", "models/no_such_model.toml", "--cycle", "ece"]);
    assert_eq!(o.status.code(), Some(2));
}

/// `simulate --verify`: the original model replays the inverse's sampled input within 1e-4 m/s of y_d at
/// dt = 0.01 s and within 1e-2 m/s at dt = 0.1 s, on either engine.
#[test]
fn simulate_verify_meets_the_tolerances() {
    for engine in ["auto", "interpreted"] {
        for (dt, tol) in [("0.01", 1e-4), ("0.1", 1e-2)] {
            let s = summary(
                &[
                    "simulate",
                    "models/si_engine.toml",
                    "--cycle",
                    "nedc",
                    "--dt",
                    dt,
                    "--verify",
                    "--engine",
                    engine,
                ],
                &format!("verify-{engine}-{dt}.json"),
            );
            let max = s["max_abs_tracking_error"].as_f64().unwrap();
            let rms = s["rms_tracking_error"].as_f64().unwrap();
            assert!(
                max < tol && rms <= max,
                "{engine}, dt = {dt}: max {max:e}, rms {rms:e}"
            );
        }
    }
}

#[test]
fn forward_trace_misses_use_the_cycles_own_band() {
    // The ECE's regulation band is UNECE's ±2 km/h, ±1 s; `--tolerance 10,2` widens it to ±10 km/h, ±2 s, which
    // leaves fewer (here: shorter) misses; a cycle file keeps the EPA's ±2 mph.
    let run = |extra: &[&str], tag: &str| {
        let mut args = vec![
            "forward",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--bounds",
            "enforce",
        ];
        args.extend_from_slice(extra);
        summary(&args, tag)
    };
    let missed = |s: &serde_json::Value| -> f64 {
        let misses = s["trace_misses"].as_array().unwrap();
        misses
            .iter()
            .map(|m| m[1].as_f64().unwrap() - m[0].as_f64().unwrap())
            .sum()
    };
    let unece = run(&[], "band_unece.json");
    assert!((unece["trace_miss_speed_tolerance"].as_f64().unwrap() - 2.0 / 3.6).abs() < 1e-15);
    assert_eq!(unece["trace_miss_time_tolerance_s"], 1.0);
    let wide = run(&["--tolerance", "10,2"], "band_wide.json");
    assert!((wide["trace_miss_speed_tolerance"].as_f64().unwrap() - 10.0 / 3.6).abs() < 1e-15);
    assert_eq!(wide["trace_miss_time_tolerance_s"], 2.0);
    assert!(
        missed(&wide) < missed(&unece),
        "{} vs {}",
        missed(&wide),
        missed(&unece)
    );
    let warning = |s: &serde_json::Value| {
        s["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|w| w.as_str())
            .find(|w| w.contains("misses the cycle's trace"))
            .map(String::from)
    };
    let w = warning(&unece).expect("a trace-miss warning");
    assert!(
        w.contains("± 0.5556 m/s around the cycle within ± 1 s, UNECE band"),
        "{w}"
    );
    let bad = invsim(&[
        "forward",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--tolerance",
        "2",
    ]);
    assert_eq!(bad.status.code(), Some(2));
}
