//! `invsim sweep`: its rows equal `invsim simulate --set …` of the same variants bit for bit (compiled and
//! interpreted, 1 and 2 threads), failing variants are rows and exit status 3, bad `--grid`/`--table` input
//! exits 2 naming the argument or FILE:LINE:COLUMN.

use crate::common;
use std::collections::HashMap;

use common::{invsim, json_file, num, read_csv, stderr, tmp};

/// Run the sweep with `extra` arguments and compare every row with `simulate --set` of its variant.
fn check_against_simulate(engine: &str, threads: &str) {
    let out = tmp(&format!("sweep-{engine}-{threads}.csv"));
    let o = invsim(&[
        "sweep",
        "models/si_engine.toml",
        "--cycles",
        "ece,hwfet",
        "--dt",
        "0.5",
        "--grid",
        "m=1000:1600:2",
        "--grid",
        "C_d=0.3:0.36:2",
        "--engine",
        engine,
        "--threads",
        threads,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (header, rows) = read_csv(&out);
    assert_eq!(rows.len(), 2 * 2 * 2);
    let col: HashMap<&str, usize> = header
        .iter()
        .enumerate()
        .map(|(i, h)| (h.as_str(), i))
        .collect();
    for row in &rows {
        assert_eq!(row[col["status"]], "ok");
        let (m, cd, cycle) = (&row[col["m"]], &row[col["C_d"]], &row[col["cycle"]]);
        let json = tmp(&format!("single-{engine}-{threads}-{m}-{cd}-{cycle}.json"));
        let single = invsim(&[
            "simulate",
            "models/si_engine.toml",
            "--cycle",
            cycle,
            "--dt",
            "0.5",
            "--set",
            &format!("m={m}"),
            "--set",
            &format!("C_d={cd}"),
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
        // Bit for bit: the same f64 values.
        for name in ["fuel", "fuel_volume"] {
            assert_eq!(
                num(&row[col[name]]),
                s["integrals"][name].as_f64().unwrap(),
                "{name}"
            );
            let per = format!("{name}_per_100km");
            assert_eq!(
                num(&row[col[per.as_str()]]),
                s["integrals_per_100km"][name].as_f64().unwrap()
            );
        }
        for key in ["input_min", "input_max", "distance_m"] {
            assert_eq!(num(&row[col[key]]), s[key].as_f64().unwrap(), "{key}");
        }
        let violations = s["input_bound_violations"].as_array().unwrap();
        assert_eq!(num(&row[col["violations"]]) as usize, violations.len());
    }
}

#[test]
fn compiled_rows_equal_simulate_with_1_and_2_threads() {
    check_against_simulate("compiled", "1");
    check_against_simulate("compiled", "2");
}

#[test]
fn interpreted_rows_equal_simulate_with_1_and_2_threads() {
    check_against_simulate("interpreted", "1");
    check_against_simulate("interpreted", "2");
}

#[test]
fn failing_variants_are_rows_and_exit_3() {
    let out = tmp("sweep-failing.csv");
    let o = invsim(&[
        "sweep",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--grid",
        "i_t=0:5:2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("1 of 2 runs failed"), "{}", stderr(&o));
    let (header, rows) = read_csv(&out);
    let status = header.iter().position(|h| h == "status").unwrap();
    assert_eq!(rows[0][status], "error");
    assert!(rows[0][status + 1].contains("β(ξ, η)"), "{:?}", rows[0]);
    assert_eq!(rows[1][status], "ok");
}

#[test]
fn verify_adds_the_tracking_error() {
    let o = invsim(&[
        "sweep",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--grid",
        "m=1200:1400:2",
        "--verify",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text
        .lines()
        .next()
        .unwrap()
        .ends_with("max_abs_tracking_error,rms_tracking_error"));
    assert_eq!(text.lines().count(), 3);
}

#[test]
fn bad_grid_exits_2_naming_the_argument() {
    for bad in ["m=1:2", "m1:2:3", "m=1:x:3", "m=1:2:0", "mass=1:2:3"] {
        let o = invsim(&[
            "sweep",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--grid",
            bad,
        ]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.contains(bad) || e.contains("unknown parameter `mass`"),
            "{bad}: {e}"
        );
    }
}

#[test]
fn bad_table_exits_2_with_file_line_column() {
    let cases = [
        ("m,C_d\n1200,0.3\n1300,abc\n", ":3:6:"),
        ("m,C_d\n1200\n", ":2:5:"),
        ("m,,C_d\n", ":1:3:"),
        ("m\n1,2\n", ":2:3:"),
    ];
    for (i, (text, at)) in cases.iter().enumerate() {
        let path = tmp(&format!("bad-table-{i}.csv"));
        std::fs::write(&path, text).unwrap();
        let o = invsim(&[
            "sweep",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--table",
            path.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{text:?}: {}", stderr(&o));
        let expected = format!("{}{at}", path.display());
        assert!(stderr(&o).contains(&expected), "{text:?}: {}", stderr(&o));
    }
}

#[test]
fn a_table_runs_one_variant_per_row() {
    let path = tmp("good-table.csv");
    std::fs::write(&path, "m,C_d\n1200,0.3\n\n1500,0.35\n").unwrap();
    let o = invsim(&[
        "sweep",
        "models/si_engine.toml",
        "--cycle",
        "ece",
        "--table",
        path.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert_eq!(text.lines().count(), 3);
    assert!(text
        .lines()
        .nth(2)
        .unwrap()
        .starts_with("1,ece,5.0,1500.0,0.35,ok,"));
}

/// `--threads` far beyond the runs starts one thread per run at most (not ten thousand), says so, and gives
/// the same rows as one thread.
#[test]
fn threads_are_capped_by_the_runs() {
    let run = |threads: &str| {
        let o = invsim(&[
            "sweep",
            "models/si_engine.toml",
            "--cycle",
            "ece",
            "--dt",
            "1",
            "--grid",
            "m=1200:1400:2",
            "--threads",
            threads,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        o
    };
    let many = run("10000");
    assert!(
        stderr(&many).contains("--threads 10000: using 2 worker thread(s)"),
        "{}",
        stderr(&many)
    );
    let one = run("1");
    assert!(!stderr(&one).contains("worker thread"), "{}", stderr(&one));
    assert_eq!(many.stdout, one.stdout);
}

#[test]
fn rows_carry_the_lookahead_each_cycle_ran_with() {
    // `--lookahead auto` chooses per cycle (1 s on UDDS, 1.5 s on the NEDC at dt 0.1, docs/lookahead.md);
    // a given look-ahead is every row's.
    let rows = |lookahead: &str| {
        let o = invsim(&[
            "sweep",
            "models/si_engine.toml",
            "--cycles",
            "udds,nedc",
            "--grid",
            "m=1200:1300:2",
            "--lookahead",
            lookahead,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        let header: Vec<String> = text
            .lines()
            .next()
            .unwrap()
            .split(',')
            .map(String::from)
            .collect();
        assert_eq!(header[..3], ["variant", "cycle", "lookahead_s"]);
        text.lines()
            .skip(1)
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                (f[1].to_string(), f[2].parse::<f64>().unwrap())
            })
            .collect::<Vec<_>>()
    };
    let auto = rows("auto");
    assert_eq!(auto.len(), 4);
    for (cycle, a) in &auto {
        let expected = if cycle == "udds" { 1.0 } else { 1.5 };
        assert_eq!(*a, expected, "{cycle}");
    }
    assert!(rows("2.5").iter().all(|(_, a)| *a == 2.5));
}
