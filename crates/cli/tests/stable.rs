//! `invsim` with unstable zero dynamics: the classification in `derive`, stable (non-causal) inversion selected
//! automatically in `simulate` with pre-actuation and forward replay, `--causal`, `--include-extension`, and the
//! built-in `diesel_gasflow` (non-minimum phase) and `driveline` (minimum phase, lightly damped) models.

use crate::common;
use common::*;

use serde_json::Value;

/// (s − 0.5)/((s + 0.5)(s + 2)) in a model file: x1' = −3 x1 + x2 + u, x2' = 0.5 x2 − 2.5 x1, y = x1.
const LINEAR_NMP: &str = r#"name = "linear_nmp"
[states]
x1 = { rhs = "-3*x1 + x2 + u" }
x2 = { rhs = "0.5*x2 - 2.5*x1" }
[input]
name = "u"
[output]
name = "y"
h = "x1"
"#;

/// A cycle that starts moving at once, so the stable inverse must act before t = 0.
const RAMPS: &str = "time_s,speed_mps\n0,0\n10,5\n20,5\n30,8\n40,8\n50,0\n60,0\n";

#[test]
fn derive_reports_the_class_of_the_zero_dynamics() {
    for (model, class) in [
        ("models/diesel_gasflow.toml", "non_minimum_phase"),
        ("models/driveline.toml", "minimum_phase"),
        ("models/si_engine.toml", "none"),
    ] {
        let o = invsim(&["derive", model, "--format", "json"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let j: Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(j["zero_dynamics_class"], class, "{model}");
        let eigs = j["zero_dynamics_eigenvalues"].as_array().unwrap();
        assert_eq!(eigs.len(), j["eta"].as_array().unwrap().len(), "{model}");
        for e in eigs {
            assert_eq!(e.as_array().unwrap().len(), 2, "[re, im] pairs");
        }
        let o = invsim(&["derive", model]);
        let text = String::from_utf8_lossy(&o.stdout);
        if class != "none" {
            assert!(text.contains(&format!("class: {class}")), "{text}");
        }
    }
}

#[test]
fn diesel_gasflow_is_inverted_stably_and_replays_within_1e_3() {
    let summary = tmp("diesel.json");
    let o = invsim(&[
        "simulate",
        "models/diesel_gasflow.toml",
        "--cycle",
        "nedc",
        "--dt",
        "0.01",
        "--verify",
        "--summary-json",
        summary.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = json_file(&summary);
    assert_eq!(s["engine"], "compiled");
    assert_eq!(s["inversion"], "stable");
    assert_eq!(s["zero_dynamics_class"], "non_minimum_phase");
    assert!(s["zero_dynamics_eigenvalues"][0][0].as_f64().unwrap() > 0.0);
    assert_eq!(s["samples"], 118_001);
    let err = s["max_abs_tracking_error"].as_f64().unwrap();
    // The boost demand reaches 1.3 bar + 40 mbar per m/s × 33.3 m/s.
    assert!(
        err / 2.63e5 < 1e-3,
        "relative tracking error {}",
        err / 2.63e5
    );
    assert!(s["stable_inversion"]["nodes"].as_u64().unwrap() > 1000);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("zero dynamics: non_minimum_phase") && text.contains("inversion: stable"),
        "{text}"
    );

    // --causal integrates forward and is refused with the eigenvalue.
    let o = invsim(&[
        "simulate",
        "models/diesel_gasflow.toml",
        "--cycle",
        "nedc",
        "--causal",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("unstable zero dynamics") && e.contains("non-minimum phase"),
        "{e}"
    );

    // The interpreter gives the same inverse.
    let o = invsim(&[
        "simulate",
        "models/diesel_gasflow.toml",
        "--cycle",
        "ece",
        "--engine",
        "interpreted",
        "--verify",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("inversion: stable"));
}

#[test]
fn driveline_on_nedc_is_causal_and_replays_within_1e_3() {
    let summary = tmp("driveline.json");
    let csv = tmp("driveline.csv");
    let o = invsim(&[
        "simulate",
        "models/driveline.toml",
        "--cycle",
        "nedc",
        "--dt",
        "0.01",
        "--verify",
        "--summary-json",
        summary.to_str().unwrap(),
        "--out",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = json_file(&summary);
    assert_eq!(s["inversion"], "causal");
    assert_eq!(s["zero_dynamics_class"], "minimum_phase");
    assert_eq!(s["pre_actuation_s"], 0.0);
    let err = s["max_abs_tracking_error"].as_f64().unwrap();
    assert!(err / (120.0 / 3.6) < 1e-3, "relative tracking error {err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().next().unwrap();
    assert_eq!(
        header,
        "t,yd_0,yd_1,yd_2,T_e,w_e,th_s,w_w,d_t,v,eta1,eta2,eta3,T_s,F_t,n_e,E_e"
    );
}

#[test]
fn a_model_file_with_an_unstable_zero_gets_pre_actuation() {
    let model = tmp("linear_nmp.toml");
    std::fs::write(&model, LINEAR_NMP).unwrap();
    let cycle = tmp("ramps.csv");
    std::fs::write(&cycle, RAMPS).unwrap();
    let (model, cycle) = (model.to_str().unwrap(), cycle.to_str().unwrap());

    let o = invsim(&["derive", model, "--format", "json"]);
    let j: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["zero_dynamics_class"], "non_minimum_phase");
    assert!((j["zero_dynamics_eigenvalues"][0][0].as_f64().unwrap() - 0.5).abs() < 1e-8);

    let (summary, csv) = (tmp("nmp.json"), tmp("nmp.csv"));
    let args = |extension: bool| {
        let mut a = vec![
            "simulate",
            model,
            "--cycle",
            cycle,
            "--lookahead",
            "2",
            "--dt",
            "0.01",
            "--verify",
            "--summary-json",
            summary.to_str().unwrap(),
            "--out",
            csv.to_str().unwrap(),
        ];
        if extension {
            a.push("--include-extension");
        }
        a
    };
    let o = invsim(&args(false));
    assert!(o.status.success(), "{}", stderr(&o));
    let s = json_file(&summary);
    assert_eq!(s["inversion"], "stable");
    let pre = s["pre_actuation_s"].as_f64().unwrap();
    assert!(pre > 38.0 && pre < 40.0, "{pre}");
    let before = &s["input_before_start"];
    assert!(before["t_start"].as_f64().unwrap() < -38.0);
    assert!(before["max_deviation"].as_f64().unwrap() > 0.1);
    assert!(before["departs_at"].as_f64().unwrap() < -2.0);
    let rel = s["max_abs_tracking_error"].as_f64().unwrap() / 8.0;
    assert!(rel < 1e-3, "relative tracking error {rel}");
    // Without --include-extension the CSV covers the cycle, t = 0 … 60 s.
    let text = std::fs::read_to_string(&csv).unwrap();
    let first: f64 = text
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(first, 0.0);
    assert_eq!(text.lines().count(), 6002);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("pre-actuation: ") && stdout.contains("u before t0"),
        "{stdout}"
    );

    // With it, the rows before t = 0 are there and the input already moves.
    let o = invsim(&args(true));
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert!(rows[0][0] < -38.0);
    let at_minus_1 = rows.iter().find(|r| r[0] >= -1.0).unwrap();
    assert!(at_minus_1[3].abs() > 0.05, "u(−1 s) = {}", at_minus_1[3]);
    assert_eq!(
        json_file(&summary)["samples"].as_u64().unwrap() as usize,
        rows.len()
    );

    // --causal refuses it.
    let o = invsim(&["simulate", model, "--cycle", cycle, "--causal"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("unstable zero dynamics"));
}

#[test]
fn zero_dynamics_that_change_type_along_the_cycle_are_a_clear_error() {
    // q = −2 η + s ξ1 (…) with s = −1: ∂q/∂η = −2 + ξ1, unstable above 2 m/s.
    let model = tmp("changing.toml");
    std::fs::write(
        &model,
        "[states]\nx1 = { f = \"x2\", g = \"0\" }\nx2 = { f = \"-sin(x1) - x2 + x3\", g = \"1\" }\n\
         x3 = { f = \"-2*x3\", g = \"-x1\" }\n[input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"x1\"\n",
    )
    .unwrap();
    let o = invsim(&["simulate", model.to_str().unwrap(), "--cycle", "ece"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains("change type") && e.contains("--causal"), "{e}");
}
