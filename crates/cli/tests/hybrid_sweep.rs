//! `invsim sweep --strategy …` of `models/hev_p2.toml`: every row's hybrid columns (fuel, fuel corrected to
//! ΔSOC = 0, ΔSOC, starts, engine on, s, time per mode) equal `invsim simulate --strategy … --set …` of its
//! variant bit for bit, on 1 and 2 threads and for ECMS, DP and the rules; a sizing sweep over the battery's
//! capacity follows the model's scaling law; a strategy the model or the options cannot run is exit 2, and
//! so is `forward` of a hybrid.

use std::collections::HashMap;

use crate::common::{invsim, json_file, num, read_csv, stderr, tmp};

const MODEL: &str = "models/hev_p2.toml";

/// The hybrid columns and their keys in the summary's `hybrid` block (the same names).
const HYBRID: [&str; 9] = [
    "fuel_energy_j",
    "fuel_energy_corrected_j",
    "delta_soc",
    "soc_end",
    "battery_energy_j",
    "engine_starts",
    "engine_on_s",
    "equivalence_factor",
    "search_runs",
];

/// Runs `invsim sweep MODEL --cycle ece --dt 1` with `extra`, returning the CSV's header index and rows.
fn sweep(extra: &[&str], tag: &str) -> (HashMap<String, usize>, Vec<Vec<String>>) {
    let out = tmp(&format!("hybrid-sweep-{tag}.csv"));
    let mut args = vec!["sweep", MODEL, "--cycle", "ece", "--dt", "1"];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out", out.to_str().unwrap()]);
    let o = invsim(&args);
    assert!(o.status.success(), "{tag}: {}", stderr(&o));
    let (header, rows) = read_csv(&out);
    let col = header
        .into_iter()
        .enumerate()
        .map(|(i, h)| (h, i))
        .collect();
    (col, rows)
}

/// The summary of `invsim simulate MODEL --cycle ece --dt 1` with `strategy` and `--set` of every `sets`.
fn single(strategy: &[&str], sets: &[String], tag: &str) -> serde_json::Value {
    let json = tmp(&format!("hybrid-single-{tag}.json"));
    let mut args = vec!["simulate", MODEL, "--cycle", "ece", "--dt", "1"];
    args.extend_from_slice(strategy);
    for s in sets {
        args.extend_from_slice(&["--set", s]);
    }
    args.extend_from_slice(&["--summary-json", json.to_str().unwrap()]);
    let o = invsim(&args);
    assert!(o.status.success(), "{tag}: {}", stderr(&o));
    json_file(&json)
}

/// A JSON number or null as the sweep writes it: the number, or NaN for null (an empty field).
fn field(row: &[String], col: &HashMap<String, usize>, name: &str) -> Option<f64> {
    let s = &row[col[name]];
    (!s.is_empty()).then(|| num(s))
}

/// Every row of a sweep with `strategy` over `params` equals the single run of its variant: the hybrid block's
/// figures, the integrals and the time in each mode, as the same f64 values.
fn check_rows_equal_single(strategy: &[&str], params: &[&str], threads: &str, tag: &str) {
    let mut extra = strategy.to_vec();
    extra.extend_from_slice(&["--threads", threads]);
    let grids: Vec<String> = params.iter().map(|g| g.to_string()).collect();
    for g in &grids {
        extra.extend_from_slice(&["--grid", g]);
    }
    let (col, rows) = sweep(&extra, &format!("{tag}-{threads}"));
    let names: Vec<&str> = params
        .iter()
        .map(|g| g.split('=').next().unwrap())
        .collect();
    let expected: usize = params
        .iter()
        .map(|g| g.rsplit(':').next().unwrap().parse::<usize>().unwrap())
        .product();
    assert_eq!(rows.len(), expected, "{tag}");
    for row in &rows {
        assert_eq!(row[col["status"]], "ok", "{tag}: {}", row[col["error"]]);
        let sets: Vec<String> = names
            .iter()
            .map(|n| format!("{n}={}", row[col[*n]]))
            .collect();
        let s = single(
            strategy,
            &sets,
            &format!("{tag}-{threads}-{}", sets.join("-")),
        );
        let h = &s["hybrid"];
        for key in HYBRID {
            assert_eq!(
                field(row, &col, key),
                h[key].as_f64(),
                "{tag} {sets:?}: {key}"
            );
        }
        for (name, v) in s["integrals"].as_object().expect("integrals") {
            assert_eq!(field(row, &col, name), v.as_f64(), "{tag}: {name}");
        }
        for mode in s["modes"]["per_mode"].as_array().expect("modes") {
            let name = format!("time_{}_s", mode["name"].as_str().unwrap());
            assert_eq!(field(row, &col, &name), mode["time_s"].as_f64(), "{name}");
        }
        assert_eq!(
            field(row, &col, "switches"),
            s["modes"]["switches"].as_f64()
        );
    }
}

#[test]
fn ecms_rows_equal_single_runs_on_one_and_two_threads() {
    // The equivalence factor searched for each variant: the battery's capacity and the motor's copper losses.
    for threads in ["1", "2"] {
        check_rows_equal_single(
            &["--strategy", "ecms"],
            &["Q=12000:24000:2", "k_c=0.02:0.04:2"],
            threads,
            "ecms",
        );
    }
}

#[test]
fn dp_and_rule_based_rows_equal_single_runs() {
    let dp = [
        "--strategy",
        "dp",
        "--soc-grid",
        "21",
        "--split-grid",
        "11",
        "--soc-window",
        "0.05",
    ];
    check_rows_equal_single(&dp, &["P_aux=300:600:2"], "2", "dp");
    let rules = ["--strategy", "rule-based", "--rb-engine-power", "12000"];
    check_rows_equal_single(&rules, &["Q=12000:24000:2"], "2", "rules");
    // DP has no equivalence factor: its column is empty (null), as the summary's.
    let (col, rows) = sweep(
        &[&dp[..], &["--grid", "P_aux=300:300:1"]].concat(),
        "dp-null",
    );
    assert_eq!(field(&rows[0], &col, "equivalence_factor"), None);
}

/// soc' = −I_b/Q with I_b a function of the motor's power alone (hev_p2's battery has a constant open-circuit
/// voltage and resistance): at a given equivalence factor ECMS's choices do not depend on the charge, so the
/// fuel and the battery's energy are the same for every capacity and ΔSOC · Q is the same charge.
#[test]
fn a_capacity_sweep_at_a_given_equivalence_factor_scales_the_charge_by_one_over_q() {
    let (col, rows) = sweep(
        &[
            "--strategy",
            "ecms",
            "--equivalence",
            "3.4",
            "--grid",
            "Q=8666.5:34666:4",
        ],
        "capacity",
    );
    assert_eq!(rows.len(), 4);
    let get = |r: &Vec<String>, k: &str| field(r, &col, k).expect(k);
    let first = &rows[0];
    let charge = get(first, "delta_soc") * get(first, "Q");
    assert!(
        charge < -1.0,
        "the run at s = 3.4 drains the battery: {charge} C"
    );
    for row in &rows {
        for key in [
            "fuel_energy_j",
            "battery_energy_j",
            "engine_starts",
            "engine_on_s",
        ] {
            let (a, b) = (get(row, key), get(first, key));
            assert!(
                (a - b).abs() <= 1e-9 * b.abs().max(1.0),
                "{key}: {a} vs {b}"
            );
        }
        let q = get(row, "Q");
        let c = get(row, "delta_soc") * q;
        assert!(
            (c - charge).abs() <= 1e-9 * charge.abs(),
            "Q = {q}: {c} C vs {charge} C"
        );
        assert!((get(row, "soc_end") - (0.6 + charge / q)).abs() < 1e-12);
    }
}

#[test]
fn strategies_a_sweep_cannot_run_are_exit_2_naming_the_option() {
    let cases: [(&[&str], &str); 3] = [
        (
            &[
                "sweep",
                "models/si_engine.toml",
                "--cycle",
                "ece",
                "--grid",
                "m=1200:1300:2",
                "--strategy",
                "ecms",
            ],
            "--strategy ecms needs a model with modes and a [hybrid] table",
        ),
        (
            &[
                "sweep",
                MODEL,
                "--cycle",
                "ece",
                "--grid",
                "Q=12000:13000:2",
                "--soc-grid",
                "11",
            ],
            "--soc-grid, --split-grid and --soc-window apply to --strategy dp",
        ),
        (
            &[
                "sweep",
                MODEL,
                "--cycle",
                "ece",
                "--grid",
                "Q=12000:13000:2",
                "--strategy",
                "ecms",
                "--soc-tolerance",
                "0",
            ],
            "--soc-tolerance must be a positive number",
        ),
    ];
    for (args, message) in cases {
        let o = invsim(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(message), "{args:?}: {}", stderr(&o));
    }
}

/// `forward` runs no strategy: a hybrid's forward run is refused with exit 2, saying why and what to run.
#[test]
fn forward_of_a_hybrid_is_exit_2_naming_the_strategy_it_lacks() {
    let o = invsim(&["forward", MODEL, "--cycle", "ece", "--dt", "1"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("mode `hybrid_1` leaves `T_m` to an energy-management strategy"),
        "{e}"
    );
    assert!(
        e.contains("invsim simulate --strategy ecms|dp|rule-based"),
        "{e}"
    );
}
