//! Signals in a model with operating modes: si_engine_5speed plus a road grade (the climbing force
//! m g sin θ and the rolling resistance on m g cos θ, tan θ = grade, as in si_engine_grade). A constant
//! grade 0 against the model without grade (every column); at every sample each mode's original equations
//! with the signal (dx/dt = rhs(x, w, u), y'' by the chain rule with the smoothed grade's derivative); the extra
//! fuel on a constant grade against the work against gravity over the model's marginal efficiency; the forward
//! run with modes on a grade against the inverse.

use std::collections::HashMap;
use std::path::Path;

use invsim_model_api::InverseModel;
use invsim_runtime::forward::forward_modes;
use invsim_runtime::modes::{simulate_modes_with_signals, ModalOptions, ModalResult, Switching};
use invsim_runtime::{Cycle, ForwardOptions, SignalInput, SignalValue, Smoother};

use crate::modes::support::{five_speed, load, partial, spec, speed_schedule, Loaded};

/// si_engine_5speed with a `grade` signal (text of the shipped model with the grade added to F_res).
pub(crate) fn graded() -> Loaded {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine_5speed.toml");
    let text = std::fs::read_to_string(&path).expect("the model file");
    let old = r#"F_res  = { expr = "0.5*rho_a*C_d*A_f*v^2 + m*g_0*c_r*tanh(v/v_eps)","#;
    let new = r#"F_res  = { expr = "0.5*rho_a*C_d*A_f*v^2 + m*g_0*c_r*tanh(v/v_eps)/sqrt(1 + grade^2) + m*g_0*grade/sqrt(1 + grade^2)","#;
    assert!(text.contains(old), "si_engine_5speed's F_res changed");
    let text = text.replace(old, new).replace(
        "[states]",
        "[signals]\ngrade = { default = 0.0, unit = \"-\", doc = \"road grade, rise over run\" }\n\n[states]",
    );
    load(Path::new("si_engine_5speed_grade.toml"), &text)
}

fn opts(dt: f64, verify: bool) -> ModalOptions {
    ModalOptions {
        lookahead: 5.0,
        dt,
        switching: Switching::Reentry,
        transition_time: None,
        verify,
        keep_series: true,
        operating_points: true,
    }
}

fn constant(grade: f64) -> Vec<SignalInput> {
    vec![SignalInput {
        name: "grade".into(),
        value: SignalValue::Constant(grade),
    }]
}

fn run(l: &Loaded, cycle: &Cycle, given: &[SignalInput], verify: bool) -> ModalResult {
    simulate_modes_with_signals(
        &spec(l, speed_schedule(l)),
        cycle,
        &opts(0.1, verify),
        given,
    )
    .expect("the run succeeds")
}

#[test]
fn grade_zero_equals_the_model_without_grade() {
    let (plain, grade) = (five_speed(), graded());
    let cycle = Cycle::builtin("udds").expect("built-in");
    let a = run(&plain, &cycle, &[], false);
    let b = run(&grade, &cycle, &constant(0.0), false);
    // The graded run has the smoothed signal and its derivatives right after yd_0 … yd_2 (contract §5),
    // all zero for a constant zero grade; every other column is the plain run's.
    let at = b
        .columns
        .iter()
        .position(|c| c == "grade")
        .expect("a grade column");
    assert_eq!(b.columns[at - 1], "yd_2");
    assert_eq!(b.columns[at..at + 3], ["grade", "grade_d1", "grade_d2"]);
    for c in &b.data[at..at + 3] {
        assert!(c.iter().all(|&v| v == 0.0));
    }
    let (mut b_cols, mut b_data) = (b.columns.clone(), b.data.clone());
    b_cols.drain(at..at + 3);
    b_data.drain(at..at + 3);
    assert_eq!(a.columns, b_cols);
    assert_eq!(a.mode, b.mode);
    let mut worst = 0.0f64;
    for (ca, cb) in a.data.iter().zip(&b_data) {
        for (x, y) in ca.iter().zip(cb) {
            if x != y {
                worst = worst.max((x - y).abs() / x.abs().max(1.0));
            }
        }
    }
    assert!(worst <= 1e-15, "a column differs by {worst:e} relative");
    assert_eq!(a.summary.totals.integrals, b.summary.totals.integrals);
    assert!(a.summary.signals.is_empty());
    let used = &b.summary.signals[0];
    assert_eq!(
        (used.name.as_str(), used.source.as_str(), used.used),
        ("grade", "command line (constant)", "smoothed")
    );
}

/// A cycle with a grade column that varies (a sin(2π t/60)): the grade's derivative enters y''.
fn hilly(name: &str, a: f64) -> Cycle {
    let base = Cycle::builtin(name).expect("built-in");
    let mut text = String::from("t,mps,grade\n");
    for (t, v) in base.time.iter().zip(&base.speed) {
        let g = a * (2.0 * std::f64::consts::PI * t / 60.0).sin();
        text.push_str(&format!("{t},{v},{g}\n"));
    }
    Cycle::from_csv_str(&format!("{name}_hilly"), &text).expect("the cycle reads")
}

#[test]
fn every_mode_satisfies_its_equations_with_a_varying_grade() {
    let l = graded();
    let cycle = hilly("udds", 0.04);
    let res = run(&l, &cycle, &[], true);
    assert_eq!(res.summary.signals[0].source, "cycle column grade");
    // The smoothed grade and its derivatives: the grade column smoothed like a cycle (same kernel, same
    // look-ahead), independent of the run's own signal smoother.
    let gcycle = Cycle::from_csv_str(
        "g",
        &std::iter::once("t,mps\n".to_string())
            .chain(
                cycle
                    .time
                    .iter()
                    .zip(cycle.grade.as_ref().expect("grade"))
                    .map(|(t, g)| format!("{t},{}\n", g + 1.0)),
            )
            .collect::<String>(),
    );
    let gs = Smoother::new(&gcycle.expect("reads"), 5.0).expect("smoother");
    let t = res.column("t").expect("t").to_vec();
    let (mut worst1, mut worst2) = (0.0f64, 0.0f64);
    for (k, &tk) in t.iter().enumerate() {
        let model = &l.interps[res.mode[k]];
        let r = model.info().relative_degree;
        let mut sg = vec![0.0; r + 1];
        gs.eval(tk, &mut sg);
        // The grade was smoothed shifted by 1 (a cycle's speed is not negative); smoothing is linear.
        sg[0] -= 1.0;
        let (x, u, y) = (&res.states[k], res.free[k], &res.yref[k]);
        let mut dx = [0.0; 2];
        model.rhs(x, &sg, u, &mut dx);
        worst1 = worst1.max((dx[0] - y[1]).abs() / y[1].abs().max(1.0));
        if r == 2 {
            // z = (v, p_i, grade): y'' = ∂f_v/∂v v' + ∂f_v/∂p_i p_i' + ∂f_v/∂grade grade'.
            let fv = |z: &[f64]| {
                let mut d = [0.0; 2];
                model.rhs(&z[..2], &[z[2], 0.0, 0.0], u, &mut d);
                d[0]
            };
            let z = [x[0], x[1], sg[0]];
            let ydd = partial(&fv, &z, 0) * dx[0]
                + partial(&fv, &z, 1) * dx[1]
                + partial(&fv, &z, 2) * sg[1];
            worst2 = worst2.max((ydd - y[2]).abs() / y[2].abs().max(1.0));
        }
    }
    assert!(worst1 < 1e-8, "v' − y_d' up to {worst1:e} relative");
    assert!(worst2 < 1e-8, "y'' − y_d'' up to {worst2:e} relative");
    let err = res.summary.max_abs_tracking_error.expect("verified");
    assert!(err < 1e-2 * cycle.max_speed(), "replay error {err} m/s");
}

/// A drive without braking: 15 m/s, up to 25 m/s in 60 s, held, down to 18 m/s in 100 s (0.07 m/s², less
/// than drag and rolling resistance decelerate the car), held.
fn cruise() -> Cycle {
    let text = "t,mps\n0,15\n40,15\n100,25\n250,25\n350,18\n450,18\n";
    Cycle::from_csv_str("cruise", text).expect("the cycle reads")
}

/// The extra fuel on a constant grade against m·g·Δh over the marginal efficiency, computed from the model's
/// equations as in the single-mode signals test (tests/tests/signals.rs): at a fixed speed ṁ_f and the wheel
/// power are both affine in p_i, so dṁ_f/dP_w = (∂m_fc/∂p_i)/(4π η_trm ∂T_e/∂p_i) is one constant (it does
/// not depend on the gear); the extra wheel work is m g D (sin θ + c_r (cos θ − 1)), D = ∫ y_d dt.
#[test]
fn fuel_on_a_grade_matches_the_work_against_gravity() {
    let l = graded();
    let model = &l.interps[0];
    let p: HashMap<&str, f64> = model
        .info()
        .parameters
        .iter()
        .map(String::as_str)
        .zip(model.params().iter().copied())
        .collect();
    let dm_fc = p["s_i"] * p["V_d"] / (p["R_a"] * p["T_i"] * p["lambda"] * p["AFs"]);
    let k_b = (0.075 / p["B"]).sqrt();
    let dbmep =
        (dm_fc * p["Q_hv"] * p["eta_th"] / p["V_d"] + 1.0) / (1.0 + 0.0215 * p["xi_aux"] * k_b);
    let dte = dbmep * p["V_d"] / (4.0 * std::f64::consts::PI);
    let dfuel_dwork = dm_fc / (4.0 * std::f64::consts::PI * p["eta_trm"] * dte);
    let cycle = cruise();
    let fuel = |grade: f64| {
        let res = run(&l, &cycle, &constant(grade), false);
        let yd = res.column("yd_0").expect("yd_0");
        let distance: f64 = yd.windows(2).map(|w| 0.05 * (w[0] + w[1])).sum();
        let traction = res
            .summary
            .modes
            .per_mode
            .iter()
            .filter(|m| m.name.starts_with("drive"));
        let in_drive: f64 = traction.map(|m| m.time_s).sum();
        assert!(
            (in_drive - cycle.duration()).abs() < 1e-6,
            "grade {grade}: braked"
        );
        (res.summary.totals.integrals["fuel"], distance)
    };
    let (flat, distance) = fuel(0.0);
    for grade in [0.02, 0.04] {
        let (f, _) = fuel(grade);
        let theta = f64::atan(grade);
        let work = p["m"] * p["g_0"] * distance * (theta.sin() + p["c_r"] * (theta.cos() - 1.0));
        let expected = work * dfuel_dwork;
        let got = f - flat;
        eprintln!("grade {grade}: extra fuel {got:.6} kg, m g Δh/(η_m Q_hv) = {expected:.6} kg");
        assert!(got > 0.0);
        assert!(
            (got - expected).abs() < 1e-3 * expected,
            "grade {grade}: extra fuel {got} kg vs {expected} kg"
        );
    }
    // On a whole cycle with braking the fuel still rises with the grade.
    let udds = Cycle::builtin("udds").expect("built-in");
    let on = |g: f64| run(&l, &udds, &constant(g), false).summary.totals.integrals["fuel"];
    assert!(on(0.02) > on(0.0));
}

#[test]
fn forward_with_modes_on_a_grade_tracks_and_agrees_with_the_inverse() {
    let l = graded();
    let cycle = hilly("udds", 0.02);
    let inv = run(&l, &cycle, &[], false);
    let fopts = ForwardOptions::builder()
        .dt(0.1)
        .engine("interpreted")
        .keep_series(true)
        .build()
        .expect("options");
    let fwd = forward_modes(&spec(&l, speed_schedule(&l)), &cycle, &fopts).expect("forward runs");
    assert_eq!(fwd.summary.signals[0].used, "raw");
    let (fi, ff) = (
        inv.summary.totals.integrals["fuel"],
        fwd.summary.totals.integrals["fuel"],
    );
    let rel = (ff - fi) / fi;
    let track = fwd.summary.max_abs_tracking_error;
    eprintln!("hilly UDDS: fuel inverse {fi:.5} kg, forward {ff:.5} kg ({:+.2} %), tracking {track:.3} m/s", 100.0 * rel);
    let plain = forward_modes(
        &spec(&l, speed_schedule(&l)),
        &Cycle::builtin("udds").unwrap(),
        &fopts,
    )
    .expect("forward runs");
    let (rms, plain_rms) = (
        fwd.summary.rms_tracking_error,
        plain.summary.rms_tracking_error,
    );
    eprintln!(
        "rms tracking {rms:.4} m/s (without grade {plain_rms:.4} m/s), trace misses {:?}",
        fwd.summary.trace_misses
    );
    // The grade makes the driver work harder (the feed-forward knows the cycle's slope, not the grade's
    // force): the error grows but stays a fraction of a m/s, with trace misses of at most a few seconds.
    let missed: f64 = fwd.summary.trace_misses.iter().map(|m| m[1] - m[0]).sum();
    assert!(
        track < 1.5 && rms < 0.2 && missed < 3.0,
        "forward tracking {track} m/s, rms {rms}, missed {missed} s"
    );
    assert!(rel.abs() < 0.04, "forward fuel {ff} vs inverse {fi}");
    assert!(ff > 0.0 && plain.summary.totals.integrals["fuel"] != ff);
}
