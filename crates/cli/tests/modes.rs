//! `invsim derive` and `invsim simulate` on a model with operating modes (`models/si_engine_5speed.toml`):
//! every mode in the derivation, the summary's time per mode and switches, the CSV's mode and gear columns,
//! the quasi-static option, `forward` through the modes (time per mode, switches, tracking error, the CSV's
//! mode, gear and input columns), the plots (every input and the gear panel), `sweep` running such a model,
//! and a gearbox parameter refused by `--set`.

use crate::common::{invsim, json_file, root, stderr, tmp};

fn model() -> String {
    root()
        .join("models/si_engine_5speed.toml")
        .display()
        .to_string()
}

#[test]
fn derive_shows_every_mode() {
    let o = invsim(&["derive", &model(), "--format", "json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    let modes = v["modes"].as_array().expect("modes");
    assert_eq!(modes.len(), 16, "5 gears × drive, coast, overrun + idle");
    assert_eq!(v["inputs"], serde_json::json!(["m_at", "F_b"]));
    let idle = modes.iter().find(|m| m["name"] == "idle").expect("idle");
    assert_eq!(idle["free_input"], "F_b");
    assert_eq!(idle["derivation"]["relative_degree"], 1);
    assert_eq!(modes[0]["derivation"]["relative_degree"], 2);
    let text = invsim(&["derive", &model()]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("== mode overrun_3"));
}

/// `derive --format markdown` of a model with modes (the CLI's rendering) is byte for byte the generated
/// document `docs/models/<name>.md` (the code generator's rendering, kept fresh by the docs test).
#[test]
fn derive_markdown_equals_the_generated_document() {
    for name in ["si_engine_5speed", "ford_fusion_2012_dynamic_6speed"] {
        // Relative to the repository root (where the tests run), as the document names it.
        let model = format!("models/{name}.toml");
        let o = invsim(&["derive", &model, "--format", "markdown"]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let doc = std::fs::read(root().join(format!("docs/models/{name}.md"))).expect("document");
        assert!(
            o.stdout == doc,
            "{name}: derive --format markdown differs from its document"
        );
    }
}

#[test]
fn simulate_reports_time_per_mode_and_writes_mode_columns() {
    let (csv, json) = (tmp("modes-nedc.csv"), tmp("modes-nedc.json"));
    let o = invsim(&[
        "simulate",
        &model(),
        "--cycle",
        "nedc",
        "--out",
        csv.to_str().expect("utf-8"),
        "--summary-json",
        json.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let s = json_file(&json);
    let total: f64 = s["modes"]["per_mode"]
        .as_array()
        .expect("modes")
        .iter()
        .map(|m| m["time_s"].as_f64().unwrap_or(0.0))
        .sum();
    assert!((total - 1180.0).abs() < 1e-9, "{total}");
    assert!(s["modes"]["switches"].as_u64().expect("switches") > 50);
    assert_eq!(s["input_bound_violations"], serde_json::json!([]));
    let text = std::fs::read_to_string(&csv).expect("CSV");
    assert!(
        text.starts_with("t,mode,gear,yd_0,yd_1,yd_2,m_at,F_b,v,p_i,fuel"),
        "{}",
        &text[..80]
    );
    let qs = invsim(&[
        "simulate",
        &model(),
        "--cycle",
        "ece",
        "--switching",
        "quasi-static",
    ]);
    assert!(qs.status.success(), "{}", stderr(&qs));
    assert!(String::from_utf8_lossy(&qs.stdout).contains("switching: quasi_static"));
}

#[test]
fn forward_and_sweep_run_the_modes_and_gear_overrides_are_refused() {
    let (csv, json) = (tmp("modes-fwd-ece.csv"), tmp("modes-fwd-ece.json"));
    let o = invsim(&[
        "forward",
        &model(),
        "--cycle",
        "ece",
        "--out",
        csv.to_str().expect("utf-8"),
        "--summary-json",
        json.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    for line in [
        "time per mode:",
        "idle",
        "switches: ",
        "max abs tracking error: ",
        "fuel_volume: ",
    ] {
        assert!(text.contains(line), "`{line}` in {text}");
    }
    let s = json_file(&json);
    let total: f64 = s["modes"]["per_mode"]
        .as_array()
        .expect("modes")
        .iter()
        .map(|m| m["time_s"].as_f64().unwrap_or(0.0))
        .sum();
    assert!((total - 195.0).abs() < 1e-6, "{total}");
    assert!(s["modes"]["switches"].as_u64().expect("switches") > 10);
    assert_eq!(
        s["modes"]["transitions"].as_array().map(Vec::len),
        s["modes"]["switches"].as_u64().map(|n| n as usize)
    );
    assert!(s["max_abs_tracking_error"].as_f64().expect("tracking") > 0.0);
    assert_eq!(s["inputs"][1]["name"], "F_b");
    assert_eq!(s["provenance"]["command"], "forward");
    let table = std::fs::read_to_string(&csv).expect("CSV");
    assert!(
        table.starts_with("t,yc,mode,gear,m_at,F_b,v,p_i,fuel"),
        "{}",
        &table[..80]
    );
    // The sweep runs the modes too (its rows are checked against `simulate` in `modes_sweep`).
    let o = invsim(&[
        "sweep",
        &model(),
        "--cycle",
        "ece",
        "--grid",
        "m=1200:1400:2",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("time_idle_s"));
    let o = invsim(&["simulate", &model(), "--cycle", "ece", "--set", "i_g=2"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("[gearbox]"), "{}", stderr(&o));
    let o = invsim(&["forward", &model(), "--cycle", "ece", "--set", "i_g=2"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("[gearbox]"), "{}", stderr(&o));
}

#[test]
fn simulate_and_forward_plot_the_inputs_and_the_gear() {
    for command in ["simulate", "forward"] {
        let svg = tmp(&format!("modes-{command}.svg"));
        let o = invsim(&[
            command,
            &model(),
            "--cycle",
            "ece",
            "--plot",
            svg.to_str().expect("utf-8"),
        ]);
        assert!(o.status.success(), "{command}: {}", stderr(&o));
        let text = std::fs::read_to_string(&svg).expect("SVG");
        for var in [
            "reference",
            "m_at",
            "F_b",
            "gear",
            "cum:fuel_volume",
            "engine",
        ] {
            assert!(
                text.contains(&format!("data-var=\"{var}\"")),
                "{command}: panel {var}"
            );
        }
        assert!(text.contains("gear [-]") && text.contains("F_b [N]"));
    }
    let svg = tmp("modes-vars.svg");
    let o = invsim(&[
        "simulate",
        &model(),
        "--cycle",
        "ece",
        "--plot",
        svg.to_str().expect("utf-8"),
        "--plot-vars",
        "speed",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("unknown panel `speed`"),
        "{}",
        stderr(&o)
    );
    assert!(!svg.exists(), "no plot written");
}

/// What a model with modes cannot take is refused before the run, naming it: a start value of an internal
/// state (`--initial`) and a transition time that is not positive.
#[test]
fn initial_states_and_a_bad_transition_time_are_refused() {
    let o = invsim(&[
        "simulate",
        &model(),
        "--cycle",
        "ece",
        "--initial",
        "p_i=50000",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("p_i") && stderr(&o).contains("models without modes"),
        "{}",
        stderr(&o)
    );
    let o = invsim(&[
        "simulate",
        &model(),
        "--cycle",
        "ece",
        "--transition-time",
        "0",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("transition time 0 s"), "{}", stderr(&o));
}

/// The look-ahead is checked against the cycle and the step for a model with modes as for any other: far
/// below dt (the samples would miss the smoothed transitions) and longer than a quarter of the cycle are
/// refused, naming the bound.
#[test]
fn a_lookahead_outside_its_bounds_is_refused_with_modes_too() {
    for (model, what) in [
        (model(), "modes"),
        ("models/si_engine.toml".to_string(), "single"),
    ] {
        let o = invsim(&[
            "simulate",
            &model,
            "--cycle",
            "nedc",
            "--lookahead",
            "0.001",
        ]);
        assert_eq!(o.status.code(), Some(2), "{what}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("at least 0.05 s"),
            "{what}: {}",
            stderr(&o)
        );
        let o = invsim(&["simulate", &model, "--cycle", "ece", "--lookahead", "60"]);
        assert_eq!(o.status.code(), Some(2), "{what}: {}", stderr(&o));
        assert!(stderr(&o).contains("too long"), "{what}: {}", stderr(&o));
    }
    // Half the step is enough.
    let o = invsim(&[
        "simulate",
        &model(),
        "--cycle",
        "ece",
        "--lookahead",
        "0.05",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}
