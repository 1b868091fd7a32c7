//! Options that make no sense for the cycle (issue 15, defect 10): a look-ahead longer than a quarter of the
//! cycle and a step that leaves fewer than 10 samples are refused with the reason; a long look-ahead that
//! still means something is warned about when the smoothed reference's distance leaves the cycle's by > 1 %.

use invsim_model_api::InverseModel;
use invsim_runtime::forward::{self, ForwardOptions};
use invsim_runtime::grid::MIN_SAMPLES;
use invsim_runtime::{simulate, Cycle, RunError, SimulateError, SimulationOptions};

fn si_engine() -> Box<dyn InverseModel> {
    invsim_models::builtin("si_engine").expect("si_engine is built in")
}

fn inverse(cycle: &str, lookahead: f64, dt: f64) -> Result<invsim_runtime::Summary, SimulateError> {
    let cycle = Cycle::builtin(cycle).expect("built-in cycle");
    let opts = SimulationOptions {
        lookahead,
        dt,
        keep_series: false,
        ..SimulationOptions::default()
    };
    simulate(si_engine().as_ref(), &cycle, &opts).map(|r| r.summary)
}

#[test]
fn look_aheads_too_long_for_the_cycle_are_refused() {
    for (cycle, a) in [
        ("nedc", 5000.0),
        ("nedc", 1e300),
        ("nedc", 296.0),
        ("ece", 50.0),
    ] {
        let e = inverse(cycle, a, 1.0).expect_err("refused");
        assert!(matches!(e, SimulateError::LookaheadTooLong { .. }), "{e}");
        let msg = e.to_string();
        assert!(msg.contains("a quarter of the cycle"), "{msg}");
        assert!(msg.len() < 300, "{msg}");
    }
    assert!(inverse("nedc", 295.0, 1.0).is_ok());
}

#[test]
fn long_look_aheads_warn_when_the_distance_moves() {
    let warned = |s: &invsim_runtime::Summary| {
        s.warnings
            .iter()
            .any(|w| w.contains("the smoothed reference y_d covers"))
    };
    for (cycle, a) in [("nedc", 200.0), ("ece", 40.0), ("udds", 150.0)] {
        let s = inverse(cycle, a, 1.0).expect("runs");
        assert!(warned(&s), "{cycle} a = {a}: {:?}", s.warnings);
    }
    for (cycle, a) in [("nedc", 5.0), ("wltc3b", 10.0), ("ece", 2.0)] {
        let s = inverse(cycle, a, 1.0).expect("runs");
        assert!(!warned(&s), "{cycle} a = {a}: {:?}", s.warnings);
    }
}

#[test]
fn steps_that_leave_too_few_samples_are_refused() {
    for (cycle, dt) in [("nedc", 1e6), ("nedc", 200.0), ("ece", 100.0)] {
        let e = inverse(cycle, 5.0, dt).expect_err("refused");
        assert!(
            matches!(e, SimulateError::Run(RunError::TooFewSamples { min, .. }) if min == MIN_SAMPLES),
            "{e}"
        );
        let c = Cycle::builtin(cycle).unwrap();
        let opts = ForwardOptions {
            dt,
            ..ForwardOptions::default()
        };
        let e = forward::forward(si_engine().as_ref(), &c, &opts).expect_err("refused");
        assert!(e.to_string().contains("fewer than the 10"), "{e}");
    }
    // Ten samples are enough, with a look-ahead of at least half the step (the kernel's window spans a step).
    assert!(inverse("ece", 12.0, 195.0 / 9.0).is_ok());
    let e = inverse("ece", 5.0, 195.0 / 9.0).expect_err("a = 5 s at dt = 21.7 s is too short");
    assert!(
        matches!(e, SimulateError::LookaheadTooShort { min, .. } if (min - 195.0 / 18.0).abs() < 1e-12),
        "{e}"
    );
}
