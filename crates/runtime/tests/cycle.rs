//! Tests for drive cycles: the built-in NEDC / ECE-15 / EUDC checksums, the regulation tables (UDDS, HWFET,
//! WLTC class 3b and its phases) against their published figures, the CSV loader (contract section 4)
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
    assert_eq!(
        Cycle::builtin_names(),
        &[
            "nedc",
            "ece",
            "eudc",
            "udds",
            "hwfet",
            "us06",
            "wltc3b",
            "wltc3b-low",
            "wltc3b-medium",
            "wltc3b-high",
            "wltc3b-extra-high"
        ]
    );
    for name in Cycle::builtin_names() {
        assert!(Cycle::builtin(name).is_some());
        assert_eq!(
            Cycle::builtin(&name.to_uppercase()),
            Cycle::builtin(name),
            "{name}"
        );
    }
    assert_eq!(Cycle::builtin("Nedc").unwrap().name, "nedc");
    assert!(Cycle::builtin("wltc").is_none());
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

// ---------------------------------------------------------------------------------------------------------
// Built-in regulation tables (UDDS, HWFET, WLTC class 3b and its phases) against their published figures

const MILE: f64 = 1609.344;
const MPH: f64 = 0.44704;

/// A published figure: what the regulation (or the agency's summary of it) states, with the rounding of the
/// statement as tolerance (half a unit of its last digit).
struct Published {
    name: &'static str,
    /// First and last second.
    start: f64,
    end: f64,
    /// Distance in km and its tolerance.
    km: f64,
    km_tol: f64,
    /// Top speed in km/h and its tolerance.
    top_kmh: f64,
    top_tol: f64,
}

/// - UDDS (40 CFR 86 App. I (a); EPA's summary): 1369 s, 7.45 mi = 11.99 km, top 56.7 mph = 91.2 km/h.
/// - HWFET (40 CFR 600 App. I; EPA's summary): 765 s, 10.26 mi = 16.51 km, top 59.9 mph = 96.4 km/h.
/// - WLTC class 3b (UN GTR 15 Annex 1, the class 3b phase summary): 1800 s, 23 266 m, top 131.3 km/h; Low
///   589 s, 3095 m, 56.5 km/h; Medium 433 s, 4756 m, 76.6 km/h; High 455 s, 7162 m, 97.4 km/h; Extra High
///   323 s, 8254 m, 131.3 km/h.
///
/// The km/h figures of the US cycles are the mph figures converted and rounded to 0.1 km/h (tolerance 0.05);
/// the WLTC speeds are the table's own 0.1 km/h values (tolerance 1e-9).
const PUBLISHED: &[Published] = &[
    Published {
        name: "udds",
        start: 0.0,
        end: 1369.0,
        km: 11.99,
        km_tol: 0.005,
        top_kmh: 91.2,
        top_tol: 0.05,
    },
    Published {
        name: "hwfet",
        start: 0.0,
        end: 765.0,
        km: 16.51,
        km_tol: 0.005,
        top_kmh: 96.4,
        top_tol: 0.05,
    },
    Published {
        name: "wltc3b",
        start: 0.0,
        end: 1800.0,
        km: 23.266,
        km_tol: 0.0005,
        top_kmh: 131.3,
        top_tol: 1e-9,
    },
    Published {
        name: "wltc3b-low",
        start: 0.0,
        end: 589.0,
        km: 3.095,
        km_tol: 0.0005,
        top_kmh: 56.5,
        top_tol: 1e-9,
    },
    Published {
        name: "wltc3b-medium",
        start: 589.0,
        end: 1022.0,
        km: 4.756,
        km_tol: 0.0005,
        top_kmh: 76.6,
        top_tol: 1e-9,
    },
    Published {
        name: "wltc3b-high",
        start: 1022.0,
        end: 1477.0,
        km: 7.162,
        km_tol: 0.0005,
        top_kmh: 97.4,
        top_tol: 1e-9,
    },
    Published {
        name: "wltc3b-extra-high",
        start: 1477.0,
        end: 1800.0,
        km: 8.254,
        km_tol: 0.0005,
        top_kmh: 131.3,
        top_tol: 1e-9,
    },
];

#[test]
fn builtin_regulation_cycles_match_their_published_figures() {
    for p in PUBLISHED {
        let c = Cycle::builtin(p.name).unwrap_or_else(|| panic!("no built-in {}", p.name));
        assert_eq!(c.name, p.name);
        assert!(c.validate().is_ok(), "{}", p.name);
        assert_eq!(
            (c.time[0], *c.time.last().unwrap()),
            (p.start, p.end),
            "{}",
            p.name
        );
        // One sample per second, the regulation tables' rate.
        assert_eq!(c.time.len() as f64, p.end - p.start + 1.0, "{}", p.name);
        assert!(c.time.windows(2).all(|w| w[1] - w[0] == 1.0), "{}", p.name);
        let km = c.distance() / 1000.0;
        assert!(
            (km - p.km).abs() <= p.km_tol,
            "{}: {km} km, published {} km",
            p.name,
            p.km
        );
        let top = c.max_speed() * 3.6;
        assert!(
            (top - p.top_kmh).abs() <= p.top_tol,
            "{}: {top} km/h, published {}",
            p.name,
            p.top_kmh
        );
        // Every phase and cycle starts and ends at a standstill.
        assert_eq!(
            (c.speed[0], *c.speed.last().unwrap()),
            (0.0, 0.0),
            "{}",
            p.name
        );
        assert!(c.grade.is_none());
    }
}

#[test]
fn us_cycles_match_their_published_figures_in_miles() {
    // 40 CFR 86 App. I (a) and (g) and 40 CFR 600 App. I tabulate mph; EPA states 7.45 mi / 56.7 mph (UDDS),
    // 10.26 mi / 59.9 mph (HWFET) and 8.01 mi / 80.3 mph (US06). Tolerance: half a unit of the last digit
    // stated.
    for (name, miles, top_mph) in [
        ("udds", 7.45, 56.7),
        ("hwfet", 10.26, 59.9),
        ("us06", 8.01, 80.3),
    ] {
        let c = Cycle::builtin(name).unwrap();
        let mi = c.distance() / MILE;
        assert!(
            (mi - miles).abs() <= 0.005,
            "{name}: {mi} mi, published {miles}"
        );
        let top = c.max_speed() / MPH;
        assert!(
            (top - top_mph).abs() < 1e-9,
            "{name}: {top} mph, published {top_mph}"
        );
    }
}

#[test]
fn wltc3b_phases_cut_the_whole_cycle_at_the_regulation_boundaries() {
    let whole = Cycle::builtin("wltc3b").unwrap();
    let phases = [
        "wltc3b-low",
        "wltc3b-medium",
        "wltc3b-high",
        "wltc3b-extra-high",
    ];
    let mut distance = 0.0;
    for name in phases {
        let p = Cycle::builtin(name).unwrap();
        let first = p.time[0] as usize;
        // Each phase keeps the regulation's time: its samples are those of the whole cycle at the same seconds.
        assert_eq!(
            p.time[..],
            whole.time[first..first + p.time.len()],
            "{name}"
        );
        assert_eq!(
            p.speed[..],
            whole.speed[first..first + p.time.len()],
            "{name}"
        );
        distance += p.distance();
    }
    assert!((distance - whole.distance()).abs() < 1e-9);
}

#[test]
fn builtin_list_names_every_builtin_once_with_a_description() {
    let names = Cycle::builtin_names();
    let listed: Vec<&str> = Cycle::builtins().iter().map(|b| b.name).collect();
    assert_eq!(listed, names);
    for b in Cycle::builtins() {
        assert!(!b.description.is_empty());
        let c =
            Cycle::builtin(&b.name.to_ascii_uppercase()).unwrap_or_else(|| panic!("{}", b.name));
        assert_eq!(c.name, b.name);
        assert_eq!(Cycle::load(b.name).unwrap(), c);
    }
    let err = Cycle::load("no-such-cycle.csv").unwrap_err().to_string();
    assert!(
        err.contains("udds, hwfet, us06, wltc3b, wltc3b-low"),
        "{err}"
    );
}

/// The built-ins equal FASTSim's copies of the same tables sample by sample. FASTSim stores the US cycles in m/s
/// converted with 1 mph ≈ 0.44704725 m/s instead of the exact 0.44704 m/s (1.6e-5 relative), and the WLTC
/// in m/s rounded to 9 decimals, so the speeds agree to 2e-5 relative plus 1e-8 m/s; the times exactly.
#[test]
fn builtins_equal_the_shared_fastsim_files_sample_by_sample() {
    let Some(dir) = shared_cycles() else { return };
    for (file, name) in [
        ("udds.csv", "udds"),
        ("hwfet.csv", "hwfet"),
        ("wltc_3b.csv", "wltc3b"),
    ] {
        let shared = Cycle::from_csv_path(&dir.join(file)).unwrap_or_else(|e| panic!("{e}"));
        let builtin = Cycle::builtin(name).unwrap();
        assert_eq!(shared.time, builtin.time, "{name}");
        for (i, (a, b)) in shared.speed.iter().zip(&builtin.speed).enumerate() {
            assert!(
                (a - b).abs() <= 2e-5 * b + 1e-8,
                "{name} at {i} s: file {a} m/s, built-in {b} m/s"
            );
        }
        assert!(shared.grade.as_ref().unwrap().iter().all(|&g| g == 0.0));
    }
}

// ---------------------------------------------------------------------------------------------------------
// Plausibility warnings (a column whose values do not fit its declared unit)

/// `cycle` as CSV text under `header` (time, speed), its times multiplied by `time_factor` and its speeds (m/s)
/// by `speed_factor`.
fn written(cycle: &Cycle, header: &str, time_factor: f64, speed_factor: f64) -> String {
    let mut s = format!("{header}\n");
    for (t, v) in cycle.time.iter().zip(&cycle.speed) {
        s.push_str(&format!("{},{}\n", t * time_factor, v * speed_factor));
    }
    s
}

fn warnings_of(text: &str) -> Vec<String> {
    let (_, warnings) = Cycle::from_csv_str_checked("c.csv", text).expect("a valid cycle");
    warnings.iter().map(ToString::to_string).collect()
}

/// Every built-in cycle written in m/s, km/h and mph, and the shared FASTSim cycles, raise no warning.
#[test]
fn plausible_cycles_raise_no_warning() {
    for name in Cycle::builtin_names() {
        let c = Cycle::builtin(name).unwrap();
        for (header, factor) in [
            ("time_s,speed_mps", 1.0),
            ("t,speed_kmh", 3.6),
            ("cycSecs,speed_mph", 1.0 / 0.44704),
        ] {
            let w = warnings_of(&written(&c, header, 1.0, factor));
            assert!(w.is_empty(), "{name} as {header}: {w:?}");
        }
    }
    if let Some(dir) = shared_cycles() {
        for file in ["udds.csv", "hwfet.csv", "wltc_3b.csv"] {
            let (_, w) = Cycle::load_checked(dir.join(file).to_str().unwrap(), 1 << 26).unwrap();
            assert!(w.is_empty(), "{file}: {w:?}");
        }
    }
}

/// UDDS written in km/h under `speed_mps`: its top speed 91.2 km/h read as 91.2 m/s (on the line of its
/// top speed) names the column, the likely units and the fix.
#[test]
fn kmh_in_an_mps_column_warns() {
    let udds = Cycle::builtin("udds").unwrap();
    // The first sample at the top speed, on the line after the header.
    let top = udds.max_speed();
    let line = 2 + udds.speed.iter().position(|&v| v == top).unwrap();
    let w = warnings_of(&written(&udds, "time_s,speed_mps", 1.0, 3.6));
    assert_eq!(w.len(), 1, "{w:?}");
    assert_eq!(
        w[0],
        format!(
            "c.csv: line {line}, column `speed_mps`: top speed 91.2 m/s (328.5 km/h) is beyond any drive \
             cycle (invsim's plausibility limit is 70 m/s = 252 km/h); as km/h it would be 25.3 m/s and as mph \
             40.8 m/s: the column probably holds km/h (or mph); name it `speed_kmh` (or `speed_mph`), or \
             convert its values to m/s"
        )
    );
    // The same in mph under `speed_kmh` is not detectable (a slow cycle), and is not reported.
    assert!(warnings_of(&written(&udds, "time_s,speed_kmh", 1.0, 1.0)).is_empty());
}

/// NEDC (waypoints, a median step of 8 s) with its time column in milliseconds: the median step and span,
/// and the fix.
#[test]
fn milliseconds_in_a_seconds_column_warn() {
    let nedc = Cycle::builtin("nedc").unwrap();
    let w = warnings_of(&written(&nedc, "time_s,speed_mps", 1000.0, 1.0));
    assert_eq!(
        w,
        vec![
            "c.csv: column `time_s`: the median time step is 8000 and the times span 1.18e6 (13.7 days if \
             seconds); the column probably holds milliseconds: divide its times by 1000 (invsim reads time \
             columns in seconds)"
                .to_string()
        ]
    );
    // The 1 Hz UDDS in ms: steps of 1000 over 15.8 days.
    let udds = Cycle::builtin("udds").unwrap();
    let w = warnings_of(&written(&udds, "t,speed_kmh", 1000.0, 3.6));
    assert_eq!(w.len(), 1);
    assert!(
        w[0].contains("median time step is 1000 and the times span 1.369e6 (15.8 days"),
        "{w:?}"
    );
}

/// A launch at 15 m/s² over three seconds, from line 3 at t = 1 s, exceeds what tyres allow; a single
/// sample's jump does not.
#[test]
fn accelerations_beyond_a_car_warn() {
    let w = warnings_of("time_s,speed_mps\n0,0\n1,0\n2,15\n3,30\n4,45\n5,45\n6,45\n");
    assert_eq!(
        w,
        vec![
            "c.csv: line 3, column `speed_mps`: the speed changes by 15 m/s² over 3 intervals from t = 1 s (1 \
             such stretch(es) in the file), beyond what a car's tyres allow (invsim's plausibility limit is 10 \
             m/s², about 1 g); as km/h the speeds would change 3.6 times slower: check whether the column holds \
             km/h (name it `speed_kmh`) and whether the time column is in seconds"
                .to_string()
        ]
    );
    assert!(warnings_of("time_s,speed_mps\n0,0\n1,0\n2,15\n3,15\n4,15\n").is_empty());
    // Braking at 40 m/s² in km/h (11 m/s²) has no likely other unit.
    let w = warnings_of("time_s,speed_kmh\n0,100\n1,60\n2,20\n3,0\n");
    assert_eq!(w.len(), 1);
    assert!(
        w[0].contains("changes by -11.11 m/s² over 2 intervals from t = 0 s"),
        "{w:?}"
    );
    assert!(w[0]
        .ends_with("check the speed column's unit (km/h) and that the time column is in seconds"));
}
