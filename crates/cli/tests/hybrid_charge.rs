//! The battery's charge within [0, 1] in a strategy's run: a start outside exits 2 naming the state and the
//! option, and so does a run that drains the battery below empty (hev_p2 on UDDS with the battery priced at
//! nothing, `--equivalence 0`: 1.3 kWh from 0.6 cannot drive the cycle electrically), with the time it
//! happens; a charge-sustaining run from the same start is untouched.

use crate::common::{invsim, simulate_summary, stderr};

const HEV: &str = "models/hev_p2.toml";

#[test]
fn a_start_charge_outside_0_1_exits_2_naming_it() {
    for (given, strategy) in [
        ("soc=2", "ecms"),
        ("soc=-0.1", "dp"),
        ("soc=1.5", "rule-based"),
    ] {
        let o = invsim(&[
            "simulate",
            HEV,
            "--cycle",
            "ece",
            "--dt",
            "1",
            "--strategy",
            strategy,
            "--initial",
            given,
        ]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{given} {strategy}: {err}");
        assert!(
            err.contains("start charge soc =")
                && err.contains("outside [0, 1]")
                && err.contains("--initial soc="),
            "{given} {strategy}: {err}"
        );
    }
}

#[test]
fn a_run_that_empties_the_battery_exits_2_with_the_time() {
    let o = invsim(&[
        "simulate",
        HEV,
        "--cycle",
        "udds",
        "--dt",
        "1",
        "--strategy",
        "ecms",
        "--equivalence",
        "0",
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("soc leaves [0, 1] at t = "), "{err}");
    assert!(
        err.contains("beyond empty") && err.contains("more charge at the start"),
        "{err}"
    );
    // The searched, charge-sustaining run from the file's 0.6 stays inside and runs.
    let (v, _) = simulate_summary(
        &[HEV, "--cycle", "ece", "--dt", "1", "--strategy", "ecms"],
        "charge-ece",
    );
    let end = v["hybrid"]["soc_end"].as_f64().unwrap();
    assert!((end - 0.6).abs() <= 1e-4, "{end}");
}
