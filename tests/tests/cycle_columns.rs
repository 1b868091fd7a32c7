//! A signal read from any column of the cycle file (contract §5: the cycle file's column `column`): an
//! `aux_power` column of a cycle CSV feeding si_engine_grade's `P_aux` gives exactly the run with the same
//! samples given as `--signal P_aux=FILE.csv`; a column no signal uses may hold text; a cell that is not a
//! finite number in a column a signal uses is an error naming file, line and column.

use invsim_inversion::{Derivation, Interpreter, Model};
use invsim_runtime::signal_file::parse_signal_file;
use invsim_runtime::{simulate, Cycle, SignalError, SignalInput, SimulationOptions};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// si_engine_grade with its auxiliary load read from the cycle column `aux_power`.
fn aux_model() -> Derivation {
    let text = std::fs::read_to_string(root().join("models/si_engine_grade.toml")).unwrap();
    let from = r#"P_aux = { default = 500.0, unit = "W""#;
    assert!(text.contains(from));
    let text = text.replace(
        from,
        r#"P_aux = { default = 500.0, column = "aux_power", unit = "W""#,
    );
    Derivation::new(Model::from_str(Path::new("aux.toml"), &text).unwrap()).unwrap()
}

/// The auxiliary load at time t: 300 W to 1.5 kW, varying over a minute.
fn aux_power(t: f64) -> f64 {
    900.0 + 600.0 * (t / 60.0).sin()
}

/// The NEDC at 1 Hz as a CSV with an `aux_power` column and a text column `phase` no signal uses.
fn nedc_csv() -> (String, String) {
    let nedc = Cycle::builtin("nedc").unwrap();
    let (mut cycle, mut signal) = (
        String::from("time_s,speed_kmh,phase,aux_power\n"),
        String::from("t,P_aux\n"),
    );
    for i in 0..=1180 {
        let t = i as f64;
        let phase = if t < 780.0 { "urban" } else { "extra-urban" };
        let v = nedc.speed_at(t) * 3.6;
        let _ = writeln!(cycle, "{t},{v},{phase},{}", aux_power(t));
        let _ = writeln!(signal, "{t},{}", aux_power(t));
    }
    (cycle, signal)
}

fn opts(signals: Vec<SignalInput>) -> SimulationOptions {
    SimulationOptions {
        dt: 0.1,
        signals,
        engine: "interpreted".into(),
        ..SimulationOptions::default()
    }
}

#[test]
fn a_cycle_column_feeds_a_signal_as_a_signal_file_does() {
    let interp = Interpreter::new(&aux_model()).unwrap();
    let (cycle_text, signal_text) = nedc_csv();
    let cycle = Cycle::from_csv_str("nedc_aux.csv", &cycle_text).unwrap();
    let names: Vec<&str> = cycle.columns.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["phase", "aux_power"]);
    let from_column = simulate(&interp, &cycle, &opts(Vec::new())).unwrap();
    let given = SignalInput {
        name: "P_aux".into(),
        value: parse_signal_file("aux.csv", &signal_text, "P_aux").unwrap(),
    };
    let from_file = simulate(&interp, &cycle, &opts(vec![given])).unwrap();
    assert_eq!(
        from_column.summary.signals[1].source,
        "cycle column aux_power"
    );
    assert_eq!(
        from_file.summary.signals[1].source,
        "command line (aux.csv)"
    );
    for c in ["P_aux", "P_aux_d1", "P_aux_d2", "v", "p_i"] {
        assert_eq!(from_column.column(c), from_file.column(c), "column {c}");
    }
    assert_eq!(from_column.input(), from_file.input());
    // The signal is used: the default 500 W gives another input.
    let p_aux = from_column.column("P_aux").unwrap();
    let k = p_aux.len() / 3;
    assert!((p_aux[k] - 500.0).abs() > 100.0, "P_aux = {}", p_aux[k]);
}

#[test]
fn a_bad_cell_in_a_used_column_names_file_line_and_column() {
    let interp = Interpreter::new(&aux_model()).unwrap();
    let mut text = String::from("time_s,speed_mps,note,aux_power\n0,0,start,500\n\n1,1,-,n/a\n");
    for t in 2..60 {
        let _ = writeln!(text, "{t},{},x,500", (t as f64 / 10.0).sin().abs());
    }
    text.push_str("60,0,stop,inf\n");
    let cycle = Cycle::from_csv_str("bad.csv", &text).unwrap();
    let err = simulate(&interp, &cycle, &opts(Vec::new())).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("bad.csv:4:7:"), "{msg}");
    assert!(msg.contains("`n/a`") && msg.contains("aux_power"), "{msg}");
    let resolved = invsim_runtime::signals::resolve(interp_info(&interp), &cycle, &[]);
    let Err(SignalError::BadCell { cell, .. }) = resolved else {
        panic!("expected a bad cell, got {resolved:?}")
    };
    assert_eq!((cell.line, cell.column), (4, 7));
    // The same file with the load given on the command line: the column is not used, the run goes through.
    let given = SignalInput {
        name: "P_aux".into(),
        value: invsim_runtime::SignalValue::Constant(700.0),
    };
    assert!(simulate(&interp, &cycle, &opts(vec![given])).is_ok());
}

fn interp_info(m: &Interpreter) -> &invsim_model_api::ModelInfo {
    invsim_model_api::InverseModel::info(m)
}
