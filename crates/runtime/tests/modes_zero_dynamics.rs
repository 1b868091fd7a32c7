//! The zero dynamics' reference from the sub-grid (the default) against the smoother evaluated pointwise at
//! every stage time: si_engine_5speed and ford_fusion_2012_dynamic_6speed (r = 2, a grade signal) on the
//! NEDC, UDDS and WLTC class 3b at dt = 0.1 and 0.01 s, the same modes at every sample, every state within
//! 1e-9 relative and every integral (fuel) within 1e-9 relative. Likewise the variation of constants that
//! integrates zero dynamics affine in their one state on output steps from 0.05 s (`ode/affine.rs`) against
//! DOP853 (the same modes told their dynamics are not affine) at dt = 1, 0.5 and 0.1 s: integrals within
//! 1e-9, states within 1e-7 (1e-8 at dt 0.1 s) at every sample, which is DOP853's own error at its rtol 1e-8
//! (measured against DOP853 at rtol 1e-13 on the UDDS: 4.4·10⁻⁸ of si_engine_5speed's manifold pressure at a
//! sample on 0.5 s steps, 3.4·10⁻⁹ and 5.4·10⁻⁹ of a speed near a standstill on 0.1 s steps, where the
//! variation of constants is within 8.9·10⁻¹³ and 1.0·10⁻¹¹; `zd_ode.rs` has the figures).

use crate::common::integrals_deviation;
use invsim_model_api::InverseModel;
use invsim_runtime::modes::{
    simulate_modes_with_reference, ModalOptions, ModalResult, Switching, ZeroDynamicsReference,
};
use invsim_runtime::Cycle;

use crate::modes::support::{load_edited, load_repo, spec, speed_schedule};

/// The largest deviation of the sub-grid run from the pointwise one: states (relative to the larger
/// magnitude of the state at the sample and 1e-3 of its largest over the run: a speed
/// that passes through 0 at a standstill has no relative error of its own there) and integrals (relative).
fn deviation(a: &ModalResult, b: &ModalResult) -> (f64, f64) {
    assert_eq!(a.mode, b.mode, "the same mode at every sample");
    let n = a.states[0].len();
    let peak: Vec<f64> = (0..n)
        .map(|j| {
            (0..a.mode.len())
                .map(|k| b.states[k][j].abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let mut states = 0.0f64;
    for k in 0..a.mode.len() {
        for (j, &top) in peak.iter().enumerate() {
            let (x, y) = (a.states[k][j], b.states[k][j]);
            let scale = x.abs().max(y.abs()).max(1e-3 * top);
            if scale > 0.0 {
                states = states.max((x - y).abs() / scale);
            }
        }
    }
    let integrals = integrals_deviation(&a.summary.totals.integrals, &b.summary.totals.integrals);
    (states, integrals)
}

/// The states' deviation within `states_bound` and the integrals' within 1e-9 (`at`: the run, for the
/// message); the deviation, for what else the caller checks.
fn assert_close(at: &str, (states, integrals): (f64, f64), states_bound: f64) -> (f64, f64) {
    eprintln!("{at}: states {states:e}, integrals {integrals:e}");
    assert!(states < states_bound, "{at}: states {states:e}");
    assert!(integrals < 1e-9, "{at}: integrals {integrals:e}");
    (states, integrals)
}

#[test]
fn sub_grid_zero_dynamics_equal_the_pointwise_ones() {
    for file in [
        "models/si_engine_5speed.toml",
        "models/ford_fusion_2012_dynamic_6speed.toml",
    ] {
        let l = load_repo(file);
        let s = spec(&l, speed_schedule(&l));
        for cycle in ["nedc", "udds", "wltc3b"] {
            let cycle = Cycle::builtin(cycle).expect("built-in");
            for dt in [0.1, 0.01] {
                let opts = ModalOptions {
                    dt,
                    switching: Switching::Reentry,
                    ..ModalOptions::default()
                };
                let run = |zd| simulate_modes_with_reference(&s, &cycle, &opts, &[], zd);
                let fine = run(ZeroDynamicsReference::SubGrid).expect("sub-grid run");
                let pointwise = run(ZeroDynamicsReference::Pointwise).expect("pointwise run");
                let at = format!("{file} {} dt {dt}", cycle.name);
                assert_close(&at, deviation(&fine, &pointwise), 1e-9);
            }
        }
    }
}

#[test]
fn affine_zero_dynamics_on_long_steps_equal_the_adaptive_ones() {
    for file in [
        "models/si_engine_5speed.toml",
        "models/ford_fusion_2012_dynamic_6speed.toml",
    ] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../..")
            .join(file);
        let text = std::fs::read_to_string(&path).expect("the model file");
        let affine = load_repo(file);
        let adaptive = load_edited(&path, &text, |d| d.zero_dynamics_affine = None);
        assert!(
            affine.interps.iter().any(|m| m.info().zero_dynamics_affine),
            "{file}: some mode's zero dynamics are affine"
        );
        assert!(adaptive
            .interps
            .iter()
            .all(|m| !m.info().zero_dynamics_affine));
        let (a, b) = (
            spec(&affine, speed_schedule(&affine)),
            spec(&adaptive, speed_schedule(&adaptive)),
        );
        for cycle in ["nedc", "udds", "wltc3b"] {
            let cycle = Cycle::builtin(cycle).expect("built-in");
            for (dt, bound) in [(1.0, 1e-7), (0.5, 1e-7), (0.1, 1e-8)] {
                let opts = ModalOptions {
                    dt,
                    switching: Switching::Reentry,
                    ..ModalOptions::default()
                };
                let zd = ZeroDynamicsReference::SubGrid;
                let run = |s| simulate_modes_with_reference(s, &cycle, &opts, &[], zd);
                let by_variation = run(&a).expect("affine run");
                let by_dop853 = run(&b).expect("adaptive run");
                let at = format!("{file} {} dt {dt}", cycle.name);
                let (states, _) = assert_close(&at, deviation(&by_variation, &by_dop853), bound);
                assert!(states > 0.0, "{at}: the two integrators differ somewhere");
            }
        }
    }
}
