//! Runs with operating modes (`invsim_runtime::modes`, docs/reference.md §2.5): si_engine_5speed on the NEDC and the
//! UDDS (each mode's original equations at every sample, states continuous across every switch, the replay
//! through the mode sequence, time per mode, no bound violation on the NEDC, the quasi-static impulses'
//! booking), and a two-mode linear model whose gain switches at a known time against its exact solution, for
//! the re-entry and the quasi-static option.

use std::path::Path;

use invsim_model_api::InverseModel;
use invsim_runtime::modes::{simulate_modes, GearSource, ModalOptions, ModalResult, Switching};
use invsim_runtime::{Cycle, Smoother};

#[path = "modes_support.rs"]
pub(crate) mod support;

use support::{five_speed, load, partial, spec, speed_schedule, Loaded, W};

fn run(l: &Loaded, cycle: &Cycle, dt: f64, switching: Switching, verify: bool) -> ModalResult {
    let opts = ModalOptions {
        lookahead: 5.0,
        dt,
        switching,
        transition_time: None,
        verify,
        keep_series: true,
        operating_points: true,
    };
    simulate_modes(&spec(l, speed_schedule(l)), cycle, &opts).expect("the run succeeds")
}

/// In every mode and at every sample: v' = rhs_v(x, u) is y_d', and for the modes with r = 2 also
/// y_d'' = Σ_j ∂rhs_v/∂x_j · rhs_j(x, u) (rhs_v does not depend on u there): the original equations. The
/// output is the first state, v.
pub(crate) fn check_equations(l: &Loaded, res: &ModalResult) {
    let (mut worst1, mut worst2) = (0.0f64, 0.0f64);
    for k in 0..res.free.len() {
        let model = &l.interps[res.mode[k]];
        let (x, u, y) = (&res.states[k], res.free[k], &res.yref[k]);
        let mut dx = vec![0.0; x.len()];
        model.rhs(x, W, u, &mut dx);
        worst1 = worst1.max((dx[0] - y[1]).abs() / y[1].abs().max(1.0));
        if model.info().relative_degree == 2 {
            let fv = |z: &[f64]| {
                let mut d = vec![0.0; z.len()];
                model.rhs(z, W, u, &mut d);
                d[0]
            };
            let ydd: f64 = (0..x.len()).map(|j| partial(&fv, x, j) * dx[j]).sum();
            worst2 = worst2.max((ydd - y[2]).abs() / y[2].abs().max(1.0));
        }
    }
    assert!(worst1 < 1e-8, "v' − y_d' up to {worst1:e} relative");
    assert!(worst2 < 1e-8, "y'' − y_d'' up to {worst2:e} relative");
}

/// Every state continuous across every switch: the new mode starts where the old one ended.
fn check_continuity(res: &ModalResult) -> usize {
    let mut switches = 0;
    for k in 1..res.mode.len() {
        if res.mode[k] != res.mode[k - 1] {
            switches += 1;
            for (a, b) in res.x_end[k - 1].iter().zip(&res.states[k]) {
                assert!(
                    (a - b).abs() <= 1e-8 * (1.0 + a.abs()),
                    "state jumps {a} → {b} at sample {k}"
                );
            }
        }
    }
    switches
}

#[test]
fn five_speed_nedc_and_udds_satisfy_every_mode_and_keep_the_states_continuous() {
    let l = five_speed();
    for name in ["nedc", "udds"] {
        let cycle = Cycle::builtin(name).expect("built-in");
        let res = run(&l, &cycle, 0.1, Switching::Reentry, false);
        check_equations(&l, &res);
        let switches = check_continuity(&res);
        assert!(switches > 20, "{name}: only {switches} switches");
        let total: f64 = res.summary.modes.per_mode.iter().map(|m| m.time_s).sum();
        assert!(
            (total - cycle.duration()).abs() < 1e-9,
            "{name}: time per mode adds up to {total}"
        );
        let used = res
            .summary
            .modes
            .per_mode
            .iter()
            .filter(|m| m.time_s > 0.0)
            .count();
        assert!(used >= 10, "{name}: {used} modes used");
        if name == "nedc" {
            assert!(
                res.summary.totals.input_bound_violations.is_empty(),
                "{:?}",
                res.summary.totals.input_bound_violations
            );
        }
    }
}

#[test]
fn five_speed_replay_tracks_at_dt_0_01() {
    let l = five_speed();
    for name in ["nedc", "udds"] {
        let cycle = Cycle::builtin(name).expect("built-in");
        let res = run(&l, &cycle, 0.01, Switching::Reentry, true);
        let err = res.summary.max_abs_tracking_error.expect("verified");
        assert!(
            err < 1e-3 * cycle.max_speed(),
            "{name}: replay error {err} m/s"
        );
    }
}

#[test]
fn five_speed_fuel_is_plausible_and_hwfet_below_udds() {
    let l = five_speed();
    let per = |name: &str| {
        let res = run(
            &l,
            &Cycle::builtin(name).expect("built-in"),
            0.1,
            Switching::Reentry,
            false,
        );
        res.summary.totals.integrals_per_100km["fuel_volume"]
    };
    let (nedc, udds, hwfet) = (per("nedc"), per("udds"), per("hwfet"));
    assert!(
        (5.0..9.0).contains(&nedc) && (5.0..9.0).contains(&udds),
        "NEDC {nedc}, UDDS {udds} l/100 km"
    );
    assert!(
        (3.5..7.0).contains(&hwfet) && hwfet < udds,
        "HWFET {hwfet} vs UDDS {udds} l/100 km"
    );
}

#[test]
fn five_speed_quasi_static_books_its_impulses() {
    let l = five_speed();
    let cycle = Cycle::builtin("nedc").expect("built-in");
    let qs = run(&l, &cycle, 0.1, Switching::QuasiStatic, false);
    let s = &qs.summary;
    assert!(!s.modes.impulses.is_empty());
    // Hand calculation: fuel = m_at/(lambda AFs) with the fuel on, so each impulse of m_at books U/14.7 kg.
    let hand: f64 = s
        .modes
        .impulses
        .iter()
        .filter(|i| i.input == "m_at" && !i.mode.starts_with("overrun"))
        .map(|i| i.amount / 14.7)
        .sum();
    let booked = s.modes.impulse_booked["fuel"];
    assert!(
        (booked - hand).abs() <= 1e-6 * hand.abs().max(1e-6),
        "booked {booked} vs hand {hand}"
    );
    // The states jump (the re-entry keeps them continuous): some switch has a jump of p_i.
    let jumps = (1..qs.mode.len())
        .filter(|&k| {
            qs.mode[k] != qs.mode[k - 1] && (qs.x_end[k - 1][1] - qs.states[k][1]).abs() > 1.0
        })
        .count();
    assert!(jumps > 0, "no state jump in the quasi-static run");
}

/// A two-mode linear model: y = x1, x1' = k x2, x2' = −x2 + u (+ b, a second input held at 0); k = 1 in
/// gear 1, 2 in gear 2, the gear switching at t_s = 30 s.
pub(crate) const GAIN_SWITCH: &str = r#"
name = "gain_switch"
[parameters]
k = 1.0
[states]
x1 = { rhs = "k*x2" }
x2 = { rhs = "-x2 + u + b" }
[inputs.u]
[inputs.b]
[output]
name = "y"
h = "x1"
[outputs]
U = { expr = "u", accumulate = true, per_distance = false }
[gearbox]
parameters = { k = [1.0, 2.0] }
schedule = "cycle"
[modes.drive]
inputs = { b = 0.0 }
"#;

pub(crate) const T_S: f64 = 30.0;

fn gain_switch_run(switching: Switching) -> (ModalResult, Cycle) {
    let l = load(Path::new("gain_switch.toml"), GAIN_SWITCH);
    let cycle =
        Cycle::from_csv_str("ramp", "time_s,speed_mps\n0,0\n10,0\n40,15\n70,15\n").expect("cycle");
    let opts = ModalOptions {
        lookahead: 5.0,
        dt: 0.01,
        switching,
        transition_time: None,
        verify: true,
        keep_series: true,
        operating_points: true,
    };
    let res = simulate_modes(
        &spec(&l, GearSource::Table(vec![(0.0, 1), (T_S, 2)])),
        &cycle,
        &opts,
    )
    .expect("the run succeeds");
    (res, cycle)
}

/// The smoothstep of order 4 and its first two derivatives: S(s) = 126 s^5 − 420 s^6 + 540 s^7 − 315 s^8 +
/// 70 s^9 (S(0) = 0, S(1) = 1, derivatives 1 … 4 zero at both ends).
fn smoothstep4(s: f64) -> [f64; 3] {
    let c = [126.0, -420.0, 540.0, -315.0, 70.0];
    let mut out = [0.0; 3];
    for (i, ci) in c.iter().enumerate() {
        let p = 5 + i as i32;
        out[0] += ci * s.powi(p);
        out[1] += ci * p as f64 * s.powi(p - 1);
        out[2] += ci * (p * (p - 1)) as f64 * s.powi(p - 2);
    }
    out
}

#[test]
fn gain_switch_reentry_follows_its_exact_solution() {
    let (res, cycle) = gain_switch_run(Switching::Reentry);
    let sm = Smoother::new(&cycle, 5.0).expect("smoother");
    let mut yc_s = [0.0; 3];
    sm.eval(T_S, &mut yc_s);
    // x2 is continuous: x2(t_s) = y_c'(t_s)/1, so in gear 2 ξ2 = 2 x2 starts e1 = y_c'(t_s) above the cycle's
    // slope; the reference is y = y_c + e1 τ (1 − S(τ/T)) on [t_s, t_s + T], T = 5 s, and u = (y'' + y')/k.
    let e1 = yc_s[1];
    let t_end = 5.0;
    let mut worst = 0.0f64;
    for (k, &t) in res.data[0].iter().enumerate() {
        let mut yc = [0.0; 3];
        sm.eval(t, &mut yc);
        let (gain, mut y1, mut y2) = if t < T_S {
            (1.0, yc[1], yc[2])
        } else {
            (2.0, yc[1], yc[2])
        };
        let tau = t - T_S;
        if (0.0..t_end).contains(&tau) {
            let [s0, s1, s2] = smoothstep4(tau / t_end);
            y1 += e1 * (1.0 - s0) - e1 * tau * s1 / t_end;
            y2 += -2.0 * e1 * s1 / t_end - e1 * tau * s2 / (t_end * t_end);
        }
        let u_exact = (y2 + y1) / gain;
        worst = worst.max((res.free[k] - u_exact).abs());
    }
    assert!(worst < 1e-9, "u departs from the exact solution by {worst}");
    check_continuity(&res);
    let dev = res.summary.modes.transitions[0].max_deviation;
    assert!(dev > 0.1 && dev < e1 * t_end, "largest deviation {dev}");
    let err = res.summary.max_abs_tracking_error.expect("verified");
    assert!(err < 1e-5, "replay error {err}");
}

#[test]
fn gain_switch_quasi_static_jumps_and_books_the_impulse() {
    let (qs, cycle) = gain_switch_run(Switching::QuasiStatic);
    let (re, _) = gain_switch_run(Switching::Reentry);
    let sm = Smoother::new(&cycle, 5.0).expect("smoother");
    // Exact: u = (y_c'' + y_c')/k throughout, the state jumps at t_s from x2 = y_c' to y_c'/2.
    let mut worst = 0.0f64;
    for (k, &t) in qs.data[0].iter().enumerate() {
        let mut yc = [0.0; 3];
        sm.eval(t, &mut yc);
        let gain = if t < T_S { 1.0 } else { 2.0 };
        worst = worst.max((qs.free[k] - (yc[2] + yc[1]) / gain).abs());
    }
    assert!(worst < 1e-9, "u departs from the exact solution by {worst}");
    let mut yc = [0.0; 2];
    sm.eval(T_S, &mut yc);
    let u_hand = yc[1] * (1.0 / 2.0 - 1.0 / 1.0);
    let booked = qs.summary.modes.impulse_booked["U"];
    assert!(
        (booked - u_hand).abs() < 1e-9,
        "booked {booked}, by hand {u_hand}"
    );
    // ∫u = Δx2 + ∫x2 dt is the same for both once the impulse is booked; without it they differ by U.
    let (iq, ir) = (
        qs.summary.totals.integrals["U"],
        re.summary.totals.integrals["U"],
    );
    assert!((iq - ir).abs() < 1e-5, "quasi-static {iq} vs re-entry {ir}");
    assert!(((iq - booked) - (ir - u_hand)).abs() < 1e-5);
    assert!(qs.summary.max_abs_tracking_error.expect("verified") < 1e-6);
}

#[test]
fn five_speed_follows_the_regulation_gears_on_the_nedc() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine_5speed.toml");
    let text = std::fs::read_to_string(&path).expect("the model file");
    let text = text
        .replace("upshift   = [", "schedule = \"regulation\"\n# upshift = [")
        .replace("downshift = [", "# downshift = [");
    let l = load(&path, &text);
    assert_eq!(
        l.model.gearbox.as_ref().map(|g| &g.schedule),
        Some(&invsim_inversion::Schedule::Regulation)
    );
    let table = invsim_runtime::modes::gears::regulation_table("nedc")
        .expect("the NEDC has a prescription");
    let cycle = Cycle::builtin("nedc").expect("built-in");
    let opts = ModalOptions {
        lookahead: 5.0,
        dt: 0.1,
        switching: Switching::Reentry,
        transition_time: None,
        verify: false,
        keep_series: true,
        operating_points: true,
    };
    let res = simulate_modes(&spec(&l, GearSource::Table(table)), &cycle, &opts)
        .expect("the run succeeds");
    let gear = res.column("gear").expect("gear column");
    // ECE-15: 32 km/h in 2nd (t = 70 s), 50 km/h in 3rd (150 s); EUDC: 50 km/h in 4th, 100 km/h in 5th.
    for (t, g) in [
        (70.0, 2.0),
        (150.0, 3.0),
        (780.0 + 150.0, 4.0),
        (780.0 + 300.0, 5.0),
    ] {
        let k = (t / 0.1_f64).round() as usize;
        assert_eq!(gear[k], g, "gear at t = {t} s");
    }
    check_continuity(&res);
}
