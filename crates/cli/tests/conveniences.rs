//! The first-hour conveniences of the `invsim` command: `invsim cycles` (text and JSON), shell completions,
//! `--version` with the git revision, the built-in regulation cycles by name, and the model's description in
//! the summary.

use crate::common;
use common::*;

use serde_json::Value;

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn cycles_lists_every_builtin_with_duration_distance_and_top_speed() {
    let o = invsim(&["cycles"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let header = text.lines().next().unwrap();
    for column in ["name", "duration", "distance", "top speed", "description"] {
        assert!(header.contains(column), "{header}");
    }
    // Published figures (see crates/runtime/tests/cycle.rs for their sources), as the table prints them.
    for (name, figures) in [
        ("nedc", ["1180 s", "11.013 km", "120.0 km/h"]),
        ("ece", ["195 s", "1.015 km", "50.0 km/h"]),
        ("eudc", ["400 s", "6.955 km", "120.0 km/h"]),
        ("udds", ["1369 s", "11.990 km", "91.2 km/h"]),
        ("hwfet", ["765 s", "16.507 km", "96.4 km/h"]),
        ("us06", ["600 s", "12.888 km", "129.2 km/h"]),
        ("wltc3b", ["1800 s", "23.266 km", "131.3 km/h"]),
        ("wltc3b-low", ["589 s", "3.095 km", "56.5 km/h"]),
        ("wltc3b-medium", ["433 s", "4.756 km", "76.6 km/h"]),
        ("wltc3b-high", ["455 s", "7.162 km", "97.4 km/h"]),
        ("wltc3b-extra-high", ["323 s", "8.254 km", "131.3 km/h"]),
    ] {
        let line = text
            .lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap_or_else(|| panic!("no line for {name} in\n{text}"));
        for f in figures {
            assert!(line.contains(f), "{name}: {line:?} lacks {f:?}");
        }
    }
    assert_eq!(text.lines().count(), 12);
}

#[test]
fn cycles_json_has_the_figures_in_si_units() {
    let o = invsim(&["cycles", "--format", "json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let list: Value = serde_json::from_slice(&o.stdout).unwrap();
    let list = list.as_array().unwrap();
    assert_eq!(list.len(), 11);
    let udds = list.iter().find(|c| c["name"] == "udds").unwrap();
    assert_eq!(udds["duration_s"], 1369.0);
    assert!((udds["distance_m"].as_f64().unwrap() - 11_990.0).abs() < 5.0);
    assert!((udds["top_speed_kmh"].as_f64().unwrap() - 91.2).abs() < 0.05);
    let medium = list.iter().find(|c| c["name"] == "wltc3b-medium").unwrap();
    assert_eq!(medium["start_s"], 589.0);
    for c in list {
        assert!(c["description"].as_str().is_some_and(|d| !d.is_empty()));
        assert!(c["top_speed_mps"].as_f64().unwrap() > 0.0);
    }
}

#[test]
fn completions_for_bash_zsh_and_fish_mention_every_command() {
    for shell in ["bash", "zsh", "fish"] {
        let o = invsim(&["completions", shell]);
        assert!(o.status.success(), "{shell}: {}", stderr(&o));
        let script = stdout(&o);
        assert!(!script.trim().is_empty(), "{shell}: empty script");
        for word in ["simulate", "derive", "forward", "cycles", "lookahead"] {
            assert!(script.contains(word), "{shell}: the script lacks {word}");
        }
    }
    let o = invsim(&["completions", "tcsh"]);
    assert_eq!(o.status.code(), Some(2), "an unknown shell is a user error");
}

#[test]
fn version_prints_the_package_version_and_a_revision() {
    let o = invsim(&["--version"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let line = stdout(&o);
    let want = format!("invsim {} (rev ", env!("CARGO_PKG_VERSION"));
    assert!(line.starts_with(&want), "{line:?}");
    let rev = line
        .trim_end()
        .trim_start_matches(&want)
        .trim_end_matches(')');
    // A short git hash when built in a checkout, `unknown` otherwise.
    assert!(
        rev == "unknown" || (rev.len() >= 7 && rev.chars().all(|c| c.is_ascii_hexdigit())),
        "{rev:?}"
    );
}

#[test]
fn regulation_cycles_run_by_name_and_phases_keep_their_time() {
    let csv = tmp("wltc3b-medium.csv");
    let o = invsim(&[
        "simulate",
        "models/si_engine.toml",
        "--cycle",
        "wltc3b-medium",
        "--dt",
        "1",
        "--out",
        csv.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("cycle: wltc3b-medium"), "{text}");
    assert!(text.contains("duration: 433 s"), "{text}");
    let table = std::fs::read_to_string(&csv).unwrap();
    let first_row = table.lines().nth(1).unwrap();
    assert!(first_row.starts_with("589.0,"), "{first_row}");
    for cycle in ["udds", "HWFET", "wltc3b"] {
        let o = invsim(&[
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            cycle,
            "--dt",
            "1",
        ]);
        assert!(o.status.success(), "{cycle}: {}", stderr(&o));
    }
}

#[test]
fn the_summary_says_what_the_model_is() {
    let o = invsim(&["simulate", "models/si_engine.toml", "--cycle", "ece"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let mut lines = text.lines();
    // The model's answer first (its [headline]), then what the model is.
    assert!(lines.next().is_some_and(|l| l.starts_with("headline: ")));
    assert_eq!(lines.next(), Some("model: si_engine"));
    assert_eq!(
        lines.next(),
        Some("description: One-gear SI-engine car without brake or idle (Fröberg & Nielsen 2004)")
    );
    let o = invsim(&["forward", "models/si_engine.toml", "--cycle", "ece"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("\ndescription: One-gear SI-engine car without brake or idle"));
}

#[test]
fn an_unknown_cycle_lists_the_builtins() {
    let o = invsim(&["simulate", "models/si_engine.toml", "--cycle", "wltc"]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("udds, hwfet, us06, wltc3b"), "{err}");
}

#[test]
fn a_built_in_cycle_exports_as_a_cycle_file_that_reads_back_the_same() {
    // `cycles --export us06` writes the table's samples; simulating the file gives the built-in's figures bit
    // for bit (the numbers are written in shortest round-trip form).
    let o = invsim(&["cycles", "--export", "us06"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_eq!(text.lines().next(), Some("time_s,speed_mps"));
    assert_eq!(text.lines().count(), 602);
    let path = tmp("us06_export.csv");
    std::fs::write(&path, &text).unwrap();
    let figures = |cycle: &str, tag: &str| {
        let json = tmp(tag);
        let j = json.to_str().unwrap();
        let o = invsim(&[
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            cycle,
            "--summary-json",
            j,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let s: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        (s["distance_m"].clone(), s["integrals"].clone())
    };
    assert_eq!(
        figures("us06", "us06_builtin.json"),
        figures(path.to_str().unwrap(), "us06_file.json")
    );
    let bad = invsim(&["cycles", "--export", "us07"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("not a built-in cycle; expected one of nedc"));
}
