//! The `invsim` command line as a user meets it: exit codes, the contract's JSON and CSV layouts, and
//! error messages for bad models, cycles and options (contract §3).

use crate::common;
use common::*;

use serde_json::Value;

#[test]
fn derive_json_has_the_contract_fields() {
    let o = invsim(&["derive", "models/si_engine.toml", "--format", "json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["name"], "si_engine");
    assert_eq!(j["states"], serde_json::json!(["v", "p_i"]));
    assert_eq!(j["input"], "m_at");
    assert_eq!(j["output"], "v");
    assert_eq!(j["relative_degree"], 2);
    assert_eq!(j["parameters"]["m"], 1300.0);
    assert_eq!(j["lie_derivatives"].as_array().unwrap().len(), 3);
    assert_eq!(j["lie_derivatives"][0], "v");
    assert_eq!(j["xi"][0], "v");
    assert_eq!(j["eta"], serde_json::json!([]));
    assert_eq!(j["zero_dynamics"], serde_json::json!([]));
    assert_eq!(j["psi_inv"]["v"], "xi1");
    assert!(j["psi_inv"]["p_i"].as_str().unwrap().contains("xi2"));
    for key in ["decoupling", "alpha", "beta"] {
        assert!(j[key].is_string(), "{key}");
    }
    assert!(j["singular"].is_array() && j["warnings"].is_array());
    // Every printed expression parses back in the contract's language.
    let mut pool = invsim_expr::Pool::new();
    for e in j["lie_derivatives"].as_array().unwrap() {
        pool.parse(e.as_str().unwrap()).unwrap();
    }
    pool.parse(j["alpha"].as_str().unwrap()).unwrap();
}

#[test]
fn derive_text_and_markdown() {
    let o = invsim(&["derive", "models/si_engine.toml"]);
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("relative degree r = 2"));
    let o = invsim(&["derive", "models/si_engine.toml", "--format", "markdown"]);
    assert!(o.status.success());
    let md = String::from_utf8_lossy(&o.stdout);
    assert!(md.contains("$$") && md.contains("**r = 2**"));
}

#[test]
fn shared_bad_models_exit_2_with_their_errors() {
    for (name, needle) in [
        ("bad_no_relative_degree", "does not depend on the input"),
        (
            "bad_unknown_symbol",
            "bad_unknown_symbol.toml:8:23: unknown name `c9`",
        ),
    ] {
        let Some(p) = shared(&format!("models/{name}.toml")) else {
            return;
        };
        let o = invsim(&["derive", &p]);
        assert_eq!(o.status.code(), Some(2), "{name}");
        let e = stderr(&o);
        assert!(e.contains(needle), "{name}: {e}");
        assert!(!e.contains("panicked"), "{name}: {e}");
    }
}

#[test]
fn missing_model_file_is_a_user_error() {
    let o = invsim(&["derive", "no/such/model.toml"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no/such/model.toml"));
}

#[test]
fn bad_options_exit_2() {
    for args in [
        vec!["simulate", "models/si_engine.toml"],
        vec![
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "nedc",
            "--dt",
            "-1",
        ],
        vec![
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "nedc",
            "--lookahead",
            "0",
        ],
        vec![
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "nedc",
            "--set",
            "m",
        ],
        vec![
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "nedc",
            "--set",
            "nope=3",
        ],
        vec![
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "nedc",
            "--set",
            "m=abc",
        ],
        vec![
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "no_such_cycle",
        ],
        vec!["derive", "models/si_engine.toml", "--format", "yaml"],
        vec!["frobnicate"],
    ] {
        let o = invsim(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"), "{args:?}");
    }
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "nedc",
        "--set",
        "nope=3",
    ]);
    assert!(
        stderr(&o).contains("unknown parameter `nope`"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn simulate_writes_csv_and_summary() {
    let csv = tmp("si.csv");
    let json = tmp("si.json");
    let svg = tmp("si.svg");
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "nedc",
        "--out",
        csv.to_str().unwrap(),
        "--summary-json",
        json.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t,yd_0,yd_1,yd_2,m_at,v,p_i,fuel,fuel_volume,n_e,T_e"
    );
    assert_eq!(text.lines().count(), 1 + 11_801);
    let s: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(s["cycle"], "nedc");
    assert_eq!(s["samples"], 11_801);
    assert_eq!(s["relative_degree"], 2);
    assert!((s["duration_s"].as_f64().unwrap() - 1180.0).abs() < 1e-9);
    assert!((s["distance_m"].as_f64().unwrap() - 11_013.0).abs() < 1.0);
    let per_100km = s["integrals_per_100km"]["fuel_volume"].as_f64().unwrap();
    assert!((4.0..9.0).contains(&per_100km), "{per_100km} l/100 km");
    assert!(s["integrals"]["fuel"].as_f64().unwrap() > 0.0);
    // The model has no brake: hard decelerations need m_at < 0, reported as bound violations.
    assert!(!s["input_bound_violations"].as_array().unwrap().is_empty());
    assert!(s["engine"] == "compiled" || s["engine"] == "interpreted");
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<svg"));
}

#[test]
fn simulate_parameter_override_changes_fuel() {
    let run = |extra: &[&str]| -> f64 {
        let json = tmp(&format!("set{}.json", extra.len()));
        let mut args = vec![
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--summary-json",
            json.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = invsim(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        let s: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        s["integrals"]["fuel"].as_f64().unwrap()
    };
    let base = run(&[]);
    let heavy = run(&["--set", "m=1800"]);
    assert!(
        heavy > base * 1.05,
        "heavier car must burn more: {heavy} vs {base}"
    );
}

#[test]
fn simulate_each_shared_cycle() {
    for name in ["udds", "hwfet", "wltc_3b"] {
        let Some(p) = shared(&format!("cycles/{name}.csv")) else {
            return;
        };
        let o = invsim(&["simulate", "models/si_engine.toml", "--cycle", &p]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert!(String::from_utf8_lossy(&o.stdout).contains(&format!("cycle: {name}")));
    }
}

#[test]
fn malformed_cycle_files_exit_2_naming_the_row() {
    let cases = [
        ("empty.csv", "", "empty"),
        ("nospeed.csv", "time_s,foo\n0,1\n1,2\n", "speed"),
        ("decreasing.csv", "time_s,speed_mps\n0,0\n2,1\n1,2\n", "row"),
        ("negative.csv", "time_s,speed_kmh\n0,0\n1,-3\n", "row"),
        ("nan.csv", "t,mps\n0,0\n1,abc\n", "row"),
    ];
    for (file, body, needle) in cases {
        let p = tmp(file);
        std::fs::write(&p, body).unwrap();
        let o = invsim(&[
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            p.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{file}");
        let e = stderr(&o);
        assert!(e.to_lowercase().contains(needle), "{file}: {e}");
        assert!(!e.contains("panicked"));
    }
}

#[test]
fn verify_warns_when_an_unstable_model_makes_the_open_loop_replay_stray() {
    // x'' = x + u is unstable (eigenvalues ±1): the inverse is exact, but an open-loop replay of it amplifies
    // every error by e^t, so the summary must say what the number means.
    let model = tmp("unstable.toml");
    std::fs::write(
        &model,
        "[states]\nx1 = { rhs = \"x2\" }\nx2 = { rhs = \"x1 + u\" }\n[input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"x1\"\n",
    )
    .unwrap();
    let o = invsim(&[
        "simulate",
        model.to_str().unwrap(),
        "--cycle",
        "ece",
        "--verify",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("open-loop replay strays"), "{out}");
    // The stable si_engine gives no such warning.
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--verify",
    ]);
    assert!(!String::from_utf8_lossy(&o.stdout).contains("strays"));
}

#[test]
fn a_model_read_from_a_pipe_is_read_once() {
    // `invsim simulate <(cat m.toml)`: the file is a pipe, readable once. A model that is not a built-in's
    // bytes (here si_engine with another name) used to be read a second time for its derivation and found
    // empty ("missing [states] section").
    use std::io::Write;
    let text = std::fs::read_to_string(root().join("models/si_engine.toml"))
        .unwrap()
        .replacen("name = \"si_engine\"", "name = \"si_engine_piped\"", 1);
    assert!(text.contains("si_engine_piped"));
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_invsim"))
        .args(["simulate", "/dev/stdin", "--cycle", "ece", "--dt", "1"])
        .current_dir(root())
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run invsim");
    child
        .stdin
        .take()
        .unwrap()
        .write_all(text.as_bytes())
        .unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("model: si_engine_piped") && out.contains("engine: interpreted"),
        "{out}"
    );
}
