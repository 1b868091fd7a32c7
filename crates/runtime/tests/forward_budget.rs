//! The forward run's budgets (issue 15, defect 5): a closed loop made stiff or fast by absurd driver gains stops
//! with an error that names the gains (and the stiffness, when DOPRI5 detects it) instead of taking 10⁸ steps;
//! the step budget scales with the cycle's duration, can be set, and a wall-clock limit stops a run for sweeps.

use std::time::{Duration, Instant};

use invsim_model_api::InverseModel;
use invsim_runtime::forward::{self, default_step_budget, ForwardError, ForwardOptions, Method};
use invsim_runtime::Cycle;

fn si_engine() -> Box<dyn InverseModel> {
    invsim_models::builtin("si_engine").expect("si_engine is built in")
}

fn run(cycle: &str, opts: ForwardOptions) -> Result<forward::ForwardResult, ForwardError> {
    let cycle = Cycle::builtin(cycle).expect("built-in cycle");
    forward::forward(si_engine().as_ref(), &cycle, &opts)
}

fn opts() -> ForwardOptions {
    ForwardOptions {
        dt: 1.0,
        keep_series: false,
        ..ForwardOptions::default()
    }
}

#[test]
fn the_default_budget_scales_with_the_cycle() {
    assert_eq!(default_step_budget(1180.0), 2_360_000);
    assert_eq!(default_step_budget(1.0), 100_000);
    assert_eq!(default_step_budget(1e300), usize::MAX / 2 + 1);
    // The ordinary runs stay far inside it (NEDC about 12 000 steps, WLTC about 50 000).
    for cycle in ["nedc", "wltc3b"] {
        let r = run(cycle, opts()).expect("default run");
        let s = r.summary.integrator.stats;
        let budget = default_step_budget(r.summary.run.duration_s);
        assert!(20 * (s.accepted + s.rejected) < budget, "{cycle}: {s:?}");
    }
}

/// Absurd gains, each with the words the message must contain.
#[test]
fn absurd_gains_stop_within_the_budget_naming_the_gain() {
    let cases: [(ForwardOptions, &[&str]); 4] = [
        (
            ForwardOptions { kp: 1e9, ..opts() },
            &["budget of 390000 steps", "kp = 1e9", "--max-steps"],
        ),
        (
            ForwardOptions {
                response: 1e9,
                ..opts()
            },
            &["stiff", "response = 1e9", "rosenbrock23"],
        ),
        (
            ForwardOptions {
                kp: 1e9,
                method: Method::Rosenbrock23,
                ..opts()
            },
            &["budget of 390000 steps", "kp = 1e9"],
        ),
        (
            ForwardOptions {
                kp: 1e7,
                response: 1e5,
                ..opts()
            },
            &["budget of 390000 steps", "kp = 1e7", "response = 100000"],
        ),
    ];
    for (o, words) in cases {
        let start = Instant::now();
        let e = run("ece", o.clone()).expect_err("absurd gains must stop");
        assert!(matches!(e, ForwardError::StepBudget { .. }), "{o:?}: {e}");
        let msg = e.to_string();
        for w in words {
            assert!(msg.contains(w), "`{w}` missing in: {msg}");
        }
        assert!(start.elapsed() < Duration::from_secs(60), "{msg}");
    }
}

#[test]
fn an_explicit_budget_and_a_time_limit_stop_a_run() {
    let e = run(
        "nedc",
        ForwardOptions {
            max_steps: Some(1000),
            ..opts()
        },
    )
    .expect_err("1000 steps are not enough for the NEDC");
    assert!(
        matches!(e, ForwardError::StepBudget { steps, max: 1000, .. } if steps <= 1000),
        "{e}"
    );
    assert!(e.to_string().contains("(as given)"), "{e}");
    let start = Instant::now();
    let e = run(
        "nedc",
        ForwardOptions {
            kp: 1e9,
            time_limit_s: Some(0.05),
            max_steps: Some(usize::MAX),
            ..opts()
        },
    )
    .expect_err("the time limit must stop it");
    assert!(matches!(e, ForwardError::TimeLimit { .. }), "{e}");
    assert!(e.to_string().contains("--time-limit"), "{e}");
    assert!(start.elapsed() < Duration::from_secs(5));
}

#[test]
fn nonsense_budgets_are_refused() {
    for o in [
        ForwardOptions {
            max_steps: Some(0),
            ..opts()
        },
        ForwardOptions {
            time_limit_s: Some(0.0),
            ..opts()
        },
        ForwardOptions {
            time_limit_s: Some(f64::NAN),
            ..opts()
        },
    ] {
        let e = run("ece", o).expect_err("refused");
        assert!(matches!(e, ForwardError::InvalidBudget { .. }), "{e}");
    }
}
