//! Tests for drive cycles: the built-in NEDC / ECE-15 / EUDC checksums, the CSV loader (contract section 4)
//! and its error messages, and the shared FASTSim cycles when `../shared` is present.

use std::path::{Path, PathBuf};

use invsim_runtime::{Cycle, CycleError};
use proptest::prelude::*;

const KMH: f64 = 1.0 / 3.6;

fn parse_err(text: &str) -> CycleError {
    match Cycle::from_csv_str("bad.csv", text) {
        Ok(c) => panic!(
            "expected an error, got a cycle with {} samples",
            c.time.len()
        ),
        Err(e) => e,
    }
}

/// Asserts the error's message contains every fragment.
fn assert_message(err: &CycleError, fragments: &[&str]) {
    let msg = err.to_string();
    for f in fragments {
        assert!(msg.contains(f), "message {msg:?} lacks {f:?}");
    }
}

fn strictly_increasing(t: &[f64]) -> bool {
    t.windows(2).all(|w| w[1] > w[0])
}

// ---------------------------------------------------------------------------------------------------------
// Built-in cycles

#[test]
fn ece_checksums() {
    let c = Cycle::builtin("ece").expect("built-in ece");
    assert_eq!(c.name, "ece");
    assert_eq!(c.duration(), 195.0);
    assert!((c.distance() - 1014.6).abs() < 0.1, "{}", c.distance());
    assert!((c.max_speed() - 50.0 * KMH).abs() < 1e-12);
    assert!(strictly_increasing(&c.time));
    assert_eq!(c.time.len(), 26);
    assert!(c.grade.is_none());
}

#[test]
fn eudc_checksums() {
    let c = Cycle::builtin("eudc").expect("built-in eudc");
    assert_eq!(c.duration(), 400.0);
    assert!((c.distance() - 6954.9).abs() < 0.1, "{}", c.distance());
    assert!((c.max_speed() - 120.0 * KMH).abs() < 1e-12);
    assert!(strictly_increasing(&c.time));
}

#[test]
fn nedc_checksums() {
    let c = Cycle::builtin("nedc").expect("built-in nedc");
    assert_eq!(c.name, "nedc");
    assert_eq!(c.time[0], 0.0);
    assert_eq!(c.duration(), 1180.0);
    assert!((c.distance() - 11013.0).abs() < 1.0, "{}", c.distance());
    assert!((c.max_speed() * 3.6 - 120.0).abs() < 1e-9);
    assert!(
        strictly_increasing(&c.time),
        "duplicate boundary points must be merged"
    );
    // 4 × 26 ECE points + 22 EUDC points, minus the 4 merged boundaries.
    assert_eq!(c.time.len(), 4 * 26 + 22 - 4);
    assert_eq!(c.speed.len(), c.time.len());
    assert!(c.validate().is_ok());
}

#[test]
fn nedc_is_four_ece_and_an_eudc() {
    let nedc = Cycle::builtin("nedc").unwrap();
    let ece = Cycle::builtin("ece").unwrap();
    let eudc = Cycle::builtin("eudc").unwrap();
    let mut t = 0.0;
    while t <= 1180.0 {
        let expected = if t < 780.0 {
            ece.speed_at(t % 195.0)
        } else {
            eudc.speed_at(t - 780.0)
        };
        assert!((nedc.speed_at(t) - expected).abs() < 1e-12, "t = {t}");
        t += 0.25;
    }
    assert!((nedc.distance() - (4.0 * ece.distance() + eudc.distance())).abs() < 1e-9);
}

#[test]
fn builtin_names_are_case_insensitive() {
    assert_eq!(Cycle::builtin_names(), &["nedc", "ece", "eudc"]);
    for name in Cycle::builtin_names() {
        assert!(Cycle::builtin(name).is_some());
        assert_eq!(
            Cycle::builtin(&name.to_uppercase()),
            Cycle::builtin(name),
            "{name}"
        );
    }
    assert_eq!(Cycle::builtin("Nedc").unwrap().name, "nedc");
    assert!(Cycle::builtin("udds").is_none());
    assert!(Cycle::builtin("").is_none());
}

#[test]
fn speed_at_is_linear_and_held_outside() {
    let c = Cycle::builtin("ece").unwrap();
    // (11, 0) → (15, 15 km/h)
    assert!((c.speed_at(13.0) - 7.5 * KMH).abs() < 1e-15);
    assert_eq!(c.speed_at(15.0), 15.0 * KMH);
    assert_eq!(c.speed_at(-10.0), 0.0);
    assert_eq!(c.speed_at(1e9), 0.0);
    assert!(c.speed_at(f64::NAN).is_nan());
    let held = Cycle::from_csv_str("h", "t,mps\n0,2\n10,4\n").unwrap();
    assert_eq!(held.speed_at(-5.0), 2.0);
    assert_eq!(held.speed_at(15.0), 4.0);
    assert_eq!(held.speed_at(2.5), 2.5);
    assert_eq!(held.grade_at(3.0), 0.0);
}

#[test]
fn load_prefers_builtin_names_then_paths() {
    assert_eq!(
        Cycle::load("EUDC").unwrap(),
        Cycle::builtin("eudc").unwrap()
    );
    let path = temp_file("load.csv", b"time_s,speed_kmh\n0,0\n10,36\n");
    let c = Cycle::load(path.to_str().unwrap()).unwrap();
    assert_eq!(c.name, "load");
    assert_eq!(c.speed, vec![0.0, 10.0]);
    remove(&path);
    let err = Cycle::load("no/such/cycle.csv").unwrap_err();
    assert!(matches!(err, CycleError::Io { .. }));
    assert_message(&err, &["no/such/cycle.csv", "nedc, ece, eudc"]);
}

// ---------------------------------------------------------------------------------------------------------
// CSV: accepted layouts

#[test]
fn every_time_and_speed_column_name_is_accepted() {
    for time in ["time_s", "time_seconds", "cycSecs", "t"] {
        for (speed, factor) in [
            ("speed_mps", 1.0),
            ("mps", 1.0),
            ("cycMps", 1.0),
            ("speed_meters_per_second", 1.0),
            ("speed_kmh", 1.0 / 3.6),
            ("speed_mph", 0.44704),
        ] {
            let text = format!("{time},{speed}\n0,0\n1,10\n2,20\n");
            let c =
                Cycle::from_csv_str("x", &text).unwrap_or_else(|e| panic!("{time},{speed}: {e}"));
            assert_eq!(c.time, vec![0.0, 1.0, 2.0]);
            for (v, raw) in c.speed.iter().zip([0.0, 10.0, 20.0]) {
                assert!((v - raw * factor).abs() < 1e-14, "{speed}: {v}");
            }
            assert!(c.grade.is_none());
        }
    }
}

#[test]
fn fastsim_layout_with_grade_bom_crlf_and_padding() {
    let text = "\u{feff} cycSecs , cycMps ,cycGrade,cycRoadType\r\n0,0,0.01,0\r\n1, 1.5 ,0.02,0\r\n\r\n2,3,-0.01,1\r\n";
    let c = Cycle::from_csv_str("fastsim", text).unwrap();
    assert_eq!(c.name, "fastsim");
    assert_eq!(c.time, vec![0.0, 1.0, 2.0]);
    assert_eq!(c.speed, vec![0.0, 1.5, 3.0]);
    assert_eq!(c.grade, Some(vec![0.01, 0.02, -0.01]));
    assert!((c.grade_at(1.5) - 0.005).abs() < 1e-15);
}

#[test]
fn other_columns_are_ignored_and_names_match_any_case() {
    let text = "comment,TIME_S,Speed_KMH,extra\nx,0,0,y\nhello,5,18,\"a,b\"\n";
    let c = Cycle::from_csv_str("mixed", text).unwrap();
    assert_eq!(c.time, vec![0.0, 5.0]);
    assert_eq!(c.speed, vec![0.0, 5.0]);
}

#[test]
fn path_loading_uses_the_file_stem_and_accepts_a_bom() {
    let path = temp_file("bom.csv", "\u{feff}t,mps\n0,1\n1,2\n".as_bytes());
    let c = Cycle::from_csv_path(&path).unwrap();
    assert_eq!(c.name, "bom");
    assert_eq!(c.speed, vec![1.0, 2.0]);
    remove(&path);
}

// ---------------------------------------------------------------------------------------------------------
// CSV: malformed files (each message names the file, the line / data row and the column)

#[test]
fn error_empty_file() {
    for text in ["", "\u{feff}", "\n\n  \n"] {
        let e = parse_err(text);
        assert!(matches!(e, CycleError::Empty { .. }), "{e:?}");
        assert_message(&e, &["bad.csv", "empty", "header"]);
    }
}

#[test]
fn error_no_header() {
    let e = parse_err("0,0\n1,2\n");
    assert!(matches!(e, CycleError::NoHeader { line: 1, .. }), "{e:?}");
    assert_message(&e, &["bad.csv", "line 1", "header"]);
}

#[test]
fn error_no_time_column_lists_accepted_names() {
    let e = parse_err("seconds,speed_mps\n0,0\n1,1\n");
    assert!(matches!(e, CycleError::NoTimeColumn { .. }), "{e:?}");
    assert_message(
        &e,
        &[
            "bad.csv",
            "no time column",
            "`seconds`",
            "`time_s`",
            "`time_seconds`",
            "`cycSecs`",
            "`t`",
        ],
    );
}

#[test]
fn error_no_speed_column_lists_accepted_names_and_units() {
    let e = parse_err("time_s,velocity\n0,0\n1,1\n");
    assert!(matches!(e, CycleError::NoSpeedColumn { .. }), "{e:?}");
    assert_message(
        &e,
        &[
            "bad.csv",
            "no speed column",
            "`velocity`",
            "`speed_mps`",
            "`mps`",
            "`cycMps`",
            "`speed_meters_per_second`",
            "`speed_kmh` (km/h)",
            "`speed_mph` (mph)",
        ],
    );
}

#[test]
fn error_unparsable_number_names_row_column_and_text() {
    let e = parse_err("time_s,speed_mps\n0,0\n1,1\n2,fast\n");
    match &e {
        CycleError::BadNumber {
            line,
            row,
            column,
            text,
            ..
        } => {
            assert_eq!((*line, *row), (4, 3));
            assert_eq!(column, "speed_mps");
            assert_eq!(text, "fast");
        }
        other => panic!("{other:?}"),
    }
    assert_message(
        &e,
        &[
            "bad.csv",
            "line 4",
            "data row 3",
            "`speed_mps`",
            "`fast`",
            "expected a number",
        ],
    );
    // An empty field is not a number either.
    let e = parse_err("t,mps\n0,0\n,1\n");
    assert_message(&e, &["line 3", "data row 2", "column `t`", "found ``"]);
}

#[test]
fn error_non_finite_values() {
    for (bad, line) in [("inf", 3), ("NaN", 3), ("1e999", 3), ("-infinity", 3)] {
        let e = parse_err(&format!("t,mps\n0,0\n1,{bad}\n2,0\n"));
        assert!(matches!(e, CycleError::NonFinite { .. }), "{bad}: {e:?}");
        assert_message(
            &e,
            &[
                "bad.csv",
                &format!("line {line}"),
                "data row 2",
                "`mps`",
                bad,
                "finite",
            ],
        );
    }
    let e = parse_err("t,mps,grade\n0,0,0\n1,1,nan\n");
    assert_message(&e, &["line 3", "column `grade`", "finite"]);
}

#[test]
fn error_time_not_strictly_increasing() {
    let e = parse_err("cycSecs,cycMps\n0,0\n1,1\n1,2\n");
    match &e {
        CycleError::TimeNotIncreasing {
            line,
            row,
            time,
            previous,
            ..
        } => {
            assert_eq!((*line, *row), (4, 3));
            assert_eq!((*time, *previous), (1.0, 1.0));
        }
        other => panic!("{other:?}"),
    }
    assert_message(
        &e,
        &[
            "bad.csv",
            "line 4",
            "data row 3",
            "`cycSecs`",
            "strictly increasing",
        ],
    );
    let e = parse_err("t,mps\n0,0\n5,1\n6,1\n4,0\n");
    assert_message(
        &e,
        &["line 5", "data row 4", "time 4 s", "previous row's 6 s"],
    );
}

#[test]
fn error_negative_speed() {
    let e = parse_err("t,speed_kmh\n0,0\n1,-3\n");
    assert!(
        matches!(
            e,
            CycleError::NegativeSpeed {
                line: 3,
                row: 2,
                ..
            }
        ),
        "{e:?}"
    );
    assert_message(
        &e,
        &[
            "bad.csv",
            "line 3",
            "data row 2",
            "`speed_kmh`",
            "-3",
            "negative",
        ],
    );
}

#[test]
fn error_fewer_than_two_rows() {
    for (text, found) in [("t,mps\n", 0), ("t,mps\n0,1\n", 1), ("t,mps\n\n0,1\n\n", 1)] {
        let e = parse_err(text);
        assert!(
            matches!(e, CycleError::TooFewRows { found: f, .. } if f == found),
            "{text:?}: {e:?}"
        );
        assert_message(&e, &["bad.csv", &format!("{found} data row"), "at least 2"]);
    }
}

#[test]
fn error_ragged_rows() {
    let e = parse_err("t,mps,grade\n0,0,0\n1,1\n");
    assert!(
        matches!(
            e,
            CycleError::Ragged {
                line: 3,
                row: 2,
                found: 2,
                expected: 3,
                ..
            }
        ),
        "{e:?}"
    );
    assert_message(
        &e,
        &["bad.csv", "line 3", "data row 2", "2 field(s), expected 3"],
    );
    let e = parse_err("t,mps\n0,0\n1,1\n2,2,2\n");
    assert_message(&e, &["line 4", "data row 3", "3 field(s), expected 2"]);
}

#[test]
fn error_line_numbers_count_blank_lines_and_header() {
    // Blank lines are skipped but the line number still points into the file.
    let e = parse_err("\nt,mps\n\n0,0\n\n1,x\n");
    assert_message(&e, &["line 6", "data row 2", "`x`"]);
    let e = parse_err("t,mps\r\n\r\n0,0\r\n\r\n1,x\r\n");
    assert_message(&e, &["line 5", "data row 2", "`x`"]);
    let e = parse_err("\n\n1,2\n");
    assert_message(&e, &["line 3", "looks like data"]);
    // A row of empty fields is reported, not skipped.
    let e = parse_err("t,mps\n0,0\n,\n2,0\n");
    assert_message(
        &e,
        &[
            "line 3",
            "data row 2",
            "column `t`",
            "expected a number, found ``",
        ],
    );
}

#[test]
fn error_duplicate_columns() {
    let e = parse_err("t,time_s,mps\n0,0,0\n1,1,1\n");
    assert!(
        matches!(e, CycleError::DuplicateColumn { kind: "time", .. }),
        "{e:?}"
    );
    assert_message(
        &e,
        &[
            "bad.csv",
            "line 1",
            "two time columns",
            "`t` (column 1)",
            "`time_s` (column 2)",
        ],
    );
    let e = parse_err("t,mps,speed_kmh\n0,0,0\n1,1,1\n");
    assert_message(&e, &["two speed columns", "`mps`", "`speed_kmh`"]);
}

#[test]
fn error_missing_file_names_the_path() {
    let path = std::env::temp_dir().join("invsim-cycle-test-does-not-exist.csv");
    let e = Cycle::from_csv_path(&path).unwrap_err();
    assert!(matches!(e, CycleError::Io { .. }), "{e:?}");
    assert_message(&e, &["invsim-cycle-test-does-not-exist.csv", "cannot read"]);
}

#[test]
fn error_not_utf8_names_file_and_line() {
    let path = temp_file("latin1.csv", b"t,mps\n0,0\n1,\xe9\n");
    let e = Cycle::from_csv_path(&path).unwrap_err();
    remove(&path);
    assert!(matches!(e, CycleError::NotUtf8 { line: 3, .. }), "{e:?}");
    assert_message(&e, &["latin1.csv", "line 3", "UTF-8"]);
}

#[test]
fn errors_from_files_name_the_path() {
    let path = temp_file("negative.csv", b"t,mps\n0,0\n1,-1\n");
    let e = Cycle::from_csv_path(&path).unwrap_err();
    remove(&path);
    assert_message(
        &e,
        &[
            &path.display().to_string(),
            "line 3",
            "data row 2",
            "negative",
        ],
    );
}

#[test]
fn validate_rejects_hand_built_cycles() {
    let base = Cycle::builtin("ece").unwrap();
    let mut c = base.clone();
    c.speed.pop();
    assert_message(&c.validate().unwrap_err(), &["cycle `ece`", "speeds"]);
    let mut c = base.clone();
    c.time[3] = c.time[2];
    assert_message(
        &c.validate().unwrap_err(),
        &["sample 3", "strictly increasing"],
    );
    let mut c = base.clone();
    c.speed[1] = f64::NAN;
    assert_message(&c.validate().unwrap_err(), &["sample 1"]);
    let mut c = base;
    c.time.truncate(1);
    c.speed.truncate(1);
    assert_message(&c.validate().unwrap_err(), &["at least 2"]);
}

proptest! {
    /// Writing a cycle with `{}` (shortest round-trip formatting) and reading it back is lossless.
    #[test]
    fn csv_round_trip(steps in prop::collection::vec((1e-3f64..100.0, 0.0f64..60.0, -0.1f64..0.1), 2..60)) {
        let mut text = String::from("time_s,speed_mps,grade\n");
        let mut t = 0.0;
        let mut expected = (Vec::new(), Vec::new(), Vec::new());
        for (dt, v, g) in steps {
            t += dt;
            text.push_str(&format!("{t},{v},{g}\n"));
            expected.0.push(t);
            expected.1.push(v);
            expected.2.push(g);
        }
        let c = Cycle::from_csv_str("rt", &text).unwrap();
        prop_assert_eq!(c.time, expected.0);
        prop_assert_eq!(c.speed, expected.1);
        prop_assert_eq!(c.grade, Some(expected.2));
    }

    /// Arbitrary text never panics the loader.
    #[test]
    fn loader_never_panics(text in "\\PC{0,200}") {
        let _ = Cycle::from_csv_str("fuzz", &text);
    }

    /// Arbitrary comma-separated numbers under a valid header either load or give a typed error.
    #[test]
    fn loader_never_panics_on_numeric_rows(rows in prop::collection::vec(prop::collection::vec(-10.0f64..10.0, 1..4), 0..10)) {
        let mut text = String::from("t,mps\n");
        for r in rows {
            let cells: Vec<String> = r.iter().map(|x| x.to_string()).collect();
            text.push_str(&cells.join(","));
            text.push('\n');
        }
        if let Ok(c) = Cycle::from_csv_str("fuzz", &text) {
            prop_assert!(c.validate().is_ok());
        }
    }
}

// ---------------------------------------------------------------------------------------------------------
// Shared cycles (present in the development checkout only)

fn shared_cycles() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/cycles");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipping: ../shared not found");
        None
    }
}

fn check_shared(file: &str, duration: f64, distance: f64, top: f64) {
    let Some(dir) = shared_cycles() else { return };
    let c = Cycle::from_csv_path(&dir.join(file)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(c.name, file.trim_end_matches(".csv"));
    assert!(
        (c.duration() - duration).abs() < 1e-9,
        "{file}: {}",
        c.duration()
    );
    assert!(
        (c.distance() - distance).abs() < 1.0,
        "{file}: {}",
        c.distance()
    );
    assert!(
        (c.max_speed() - top).abs() < 0.006,
        "{file}: {}",
        c.max_speed()
    );
    assert!(c.grade.is_some());
    assert!(c.validate().is_ok());
    assert_eq!(Cycle::load(dir.join(file).to_str().unwrap()).unwrap(), c);
}

#[test]
fn shared_udds() {
    check_shared("udds.csv", 1369.0, 11990.0, 25.35);
}

#[test]
fn shared_hwfet() {
    check_shared("hwfet.csv", 765.0, 16507.0, 26.78);
}

#[test]
fn shared_wltc_3b_with_bom() {
    let Some(dir) = shared_cycles() else { return };
    let bytes = std::fs::read(dir.join("wltc_3b.csv")).unwrap();
    assert!(
        bytes.starts_with(&[0xEF, 0xBB, 0xBF]),
        "the file is expected to keep its BOM"
    );
    check_shared("wltc_3b.csv", 1800.0, 23266.0, 36.47);
}

// ---------------------------------------------------------------------------------------------------------

/// A file in a per-process temporary directory (so parallel test runs do not collide).
fn temp_file(name: &str, contents: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("invsim-cycle-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("create temp dir");
    let path = dir.join(name);
    std::fs::write(&path, contents).expect("write temp file");
    path
}

fn remove(path: &Path) {
    let _ = std::fs::remove_file(path);
}
