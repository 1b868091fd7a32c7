//! How numbers and user text reach a reader: every float of a run's CSV (`simulate`, `forward`, `sweep`) is
//! written as a float (a decimal point or `NaN`/`inf`: polars typed a column starting with `0` as integers and
//! failed on `0.05`), and control characters of a model's description are escaped in the text summary.

use crate::common;

use common::{invsim, read_csv, stderr, tmp};

/// Is `cell` a float as every CSV reader types it: digits with a decimal point (also in an exponent's
/// mantissa, `1.0e-7`), or a non-finite value?
fn is_float_text(cell: &str) -> bool {
    let mantissa = cell.split(['e', 'E']).next().unwrap_or("");
    matches!(cell, "NaN" | "inf" | "-inf")
        || (mantissa.contains('.') && cell.parse::<f64>().is_ok_and(f64::is_finite))
}

/// Every cell of the columns `floats` (all but the ones named in `not_floats`) of the CSV at `path` is a
/// float; how many cells were checked.
fn check_floats(path: &std::path::Path, not_floats: &[&str]) -> usize {
    let (header, rows) = read_csv(path);
    let mut checked = 0;
    for row in &rows {
        for (name, cell) in header.iter().zip(row) {
            if not_floats.contains(&name.as_str()) || cell.is_empty() {
                continue;
            }
            assert!(
                is_float_text(cell),
                "column `{name}`: `{cell}` is not written as a float"
            );
            checked += 1;
        }
    }
    checked
}

#[test]
fn a_runs_csv_writes_every_number_as_a_float() {
    for command in ["simulate", "forward"] {
        let out = tmp(&format!("floats-{command}.csv"));
        let o = invsim(&[
            command,
            "models/si_engine.toml",
            "--cycle",
            "nedc",
            "--dt",
            "0.05",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let (_, rows) = read_csv(&out);
        assert_eq!(rows[0][0], "0.0", "{command}: t of the first row");
        assert_eq!(rows.len(), 23_601);
        // NEDC starts at rest: the first rows hold whole numbers (0, then the idle's zeros), written `0.0`.
        assert!(
            rows[0].iter().any(|c| c == "0.0"),
            "{command}: {:?}",
            rows[0]
        );
        let checked = check_floats(&out, &[]);
        assert!(checked >= 23_601 * 8, "{command}: {checked} cells");
    }
}

#[test]
fn a_sweeps_csv_writes_its_figures_as_floats() {
    let out = tmp("floats-sweep.csv");
    let o = invsim(&[
        "sweep",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--grid",
        "m=1000:1400:3",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_csv(&out);
    assert_eq!(rows.len(), 3);
    let m = header.iter().position(|h| h == "m").unwrap();
    let masses: Vec<&str> = rows.iter().map(|r| r[m].as_str()).collect();
    assert_eq!(masses, ["1000.0", "1200.0", "1400.0"]);
    let counts = [
        "variant",
        "cycle",
        "status",
        "error",
        "samples",
        "violations",
    ];
    assert!(check_floats(&out, &counts) >= 3 * 8);
    let samples = header.iter().position(|h| h == "samples").unwrap();
    assert_eq!(rows[0][samples], "1951", "a count stays an integer");
}

#[test]
fn the_text_summary_escapes_control_characters() {
    let model = std::fs::read_to_string(common::root().join("models/si_engine.toml")).unwrap();
    let hostile = model.replacen(
        "description = \"One-gear",
        "description = \"\\u001b[2J\\u001b]0;owned\\u0007One-gear",
        1,
    );
    assert_ne!(hostile, model);
    let path = tmp("escape-description.toml");
    std::fs::write(&path, hostile).unwrap();
    let o = invsim(&[
        "simulate",
        path.to_str().unwrap(),
        "--cycle",
        "ece",
        "--dt",
        "1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("description: \\u{1b}[2J\\u{1b}]0;owned\\u{7}One-gear SI-engine car"),
        "{text}"
    );
    assert!(
        !text.contains('\u{1b}') && !text.contains('\u{7}'),
        "{text:?}"
    );
}
