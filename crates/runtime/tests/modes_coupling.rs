//! States a mode couples to the others (`couple`, docs/reference.md §2.5). A coupled copy of the gain-switch model,
//! whose coupled state s = k x2 carries the gain, runs the same input as the gain switch itself (whose exact
//! solution `modes.rs` checks), keeps s at its coupling at every sample and lists the reset at the switch,
//! where s jumps by (2 − 1)·x2. si_engine_5speed_clutch (the engine speed a state of its own with the clutch
//! open, coupled to the gearbox side with it closed) on the NEDC: every mode's original equations, every
//! state continuous across every switch except the listed resets, the engine speed at its coupling in the
//! coupled modes and held near idle by the governor at a standstill, the replay, the fuel against
//! si_engine_5speed and against the forward run.

use std::path::Path;

use invsim_runtime::forward::forward_modes;
use invsim_runtime::modes::{
    simulate_modes, GearSource, ModalOptions, ModalResult, ModalSpec, Switching,
};
use invsim_runtime::{Cycle, ForwardOptions};

use crate::modes::check_equations;
use crate::modes::support::{five_speed, load, load_repo, spec, speed_schedule, Loaded, W};
use crate::modes::{GAIN_SWITCH, T_S};

const COUPLED_SWITCH: &str = r#"
name = "coupled_switch"
[parameters]
k = 1.0
[states]
x1 = { rhs = "s" }
x2 = { rhs = "-x2 + u + b" }
s = { rhs = "-s", doc = "never used: every mode couples it" }
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
couple = { s = "k*x2" }
"#;

fn options(dt: f64) -> ModalOptions {
    ModalOptions {
        lookahead: 5.0,
        dt,
        switching: Switching::Reentry,
        transition_time: None,
        verify: true,
        keep_series: true,
        operating_points: true,
    }
}

fn switch_run(text: &str) -> ModalResult {
    let l = load(Path::new("m.toml"), text);
    let cycle =
        Cycle::from_csv_str("ramp", "time_s,speed_mps\n0,0\n10,0\n40,15\n70,15\n").expect("cycle");
    let gears = GearSource::Table(vec![(0.0, 1), (T_S, 2)]);
    simulate_modes(&spec(&l, gears), &cycle, &options(0.01)).expect("the run succeeds")
}

#[test]
fn a_coupled_state_carries_the_gain_switch_and_resets_at_the_switch() {
    let plain = switch_run(GAIN_SWITCH);
    let coupled = switch_run(COUPLED_SWITCH);
    let scale = plain.free.iter().fold(1.0f64, |m, u| m.max(u.abs()));
    let worst = plain
        .free
        .iter()
        .zip(&coupled.free)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-12 * scale, "the inputs differ by {worst:e}");
    let t = coupled.column("t").expect("t");
    for (k, &tk) in t.iter().enumerate() {
        let x = &coupled.states[k];
        let gain = if tk < T_S { 1.0 } else { 2.0 };
        let e = (x[2] - gain * x[1]).abs();
        assert!(
            e <= 1e-12 * (1.0 + x[2].abs()),
            "s − k x2 = {e:e} at t = {tk}"
        );
    }
    let resets = &coupled.summary.modes.coupling_resets;
    assert_eq!(resets.len(), 1, "{resets:?}");
    let k = t.iter().position(|&s| s >= T_S).expect("the switch sample");
    let x2 = coupled.x_end[k - 1][1];
    assert!((resets[0].t - T_S).abs() < 1e-9 && resets[0].state == "s");
    assert!(
        (resets[0].jump - x2).abs() <= 1e-12 * x2.abs(),
        "jump {} against x2 = {x2}",
        resets[0].jump
    );
    assert!(coupled.summary.max_abs_tracking_error.expect("verified") < 1e-5);
}

fn clutch() -> Loaded {
    load_repo("tests/models/si_engine_5speed_clutch.toml")
}

/// v and p_i continuous across every switch; w_e too, except where the summary lists a reset (a shift,
/// the coupling changing with the gear), whose jump is the state's.
fn check_continuity(res: &ModalResult) -> (usize, usize) {
    let t = res.column("t").expect("t");
    let (mut switches, mut jumps) = (0, 0);
    for (k, &tk) in t.iter().enumerate().skip(1) {
        if res.mode[k] == res.mode[k - 1] {
            continue;
        }
        switches += 1;
        let (a, b) = (&res.x_end[k - 1], &res.states[k]);
        for i in 0..2 {
            assert!(
                (a[i] - b[i]).abs() <= 1e-8 * (1.0 + a[i].abs()),
                "state {i} jumps at {tk}"
            );
        }
        let reset = res.summary.modes.coupling_resets.iter().find(|r| r.t == tk);
        match reset {
            Some(r) => {
                jumps += 1;
                assert!(((b[2] - a[2]) - r.jump).abs() <= 1e-9 * (1.0 + a[2].abs()));
            }
            None => assert!(
                (a[2] - b[2]).abs() <= 1e-8 * (1.0 + a[2].abs()),
                "w_e jumps at {tk}"
            ),
        }
    }
    (switches, jumps)
}

/// In the coupled modes w_e is its coupling at every sample; in the idle mode the governor holds it near
/// w_idle = 83.78 rad/s.
fn check_coupling(sp: &ModalSpec<'_>, res: &ModalResult) {
    let mut idle = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..res.free.len() {
        let mode = &sp.modes[res.mode[k]];
        let x = &res.states[k];
        match mode.coupled.first() {
            Some(&(s, o)) => {
                let mut out = vec![0.0; mode.model.info().outputs.len()];
                mode.model.outputs(x, W, res.free[k], &mut out);
                assert!(
                    (x[s] - out[o]).abs() <= 1e-9 * out[o].abs(),
                    "w_e {} vs {}",
                    x[s],
                    out[o]
                );
            }
            None => idle = (idle.0.min(x[2]), idle.1.max(x[2])),
        }
    }
    assert!(idle.0 > 82.0 && idle.1 < 86.0, "idle speed range {idle:?}");
}

#[test]
fn clutch_state_on_the_nedc_keeps_every_mode_and_the_fuel_of_the_five_speed() {
    let l = clutch();
    let sp = spec(&l, speed_schedule(&l));
    let cycle = Cycle::builtin("nedc").expect("built-in");
    let res = simulate_modes(&sp, &cycle, &options(0.1)).expect("the run succeeds");
    check_equations(&l, &res);
    let (switches, jumps) = check_continuity(&res);
    assert!(
        switches > 60 && jumps > 10,
        "{switches} switches, {jumps} resets"
    );
    check_coupling(&sp, &res);
    let vmax = cycle.speed.iter().fold(0.0f64, |m, v| m.max(*v));
    assert!(res.summary.max_abs_tracking_error.expect("verified") < 1e-3 * vmax);
    assert!(res.summary.totals.input_bound_violations.is_empty());
    // The same car with the engine at w_idle by definition at a standstill: the governor's engine burns
    // within 0.1 % of it.
    let f5 = five_speed();
    let r5 = simulate_modes(&spec(&f5, speed_schedule(&f5)), &cycle, &options(0.1)).expect("runs");
    let (a, b) = (
        res.summary.totals.integrals["fuel"],
        r5.summary.totals.integrals["fuel"],
    );
    assert!(
        (a - b).abs() < 1e-3 * b,
        "fuel {a} against the five-speed's {b}"
    );
    assert!((a - b).abs() > 0.0, "the idle dynamics change the fuel");
    let opts = ForwardOptions::builder()
        .dt(0.1)
        .engine("interpreted")
        .build()
        .expect("options");
    let fwd = forward_modes(&sp, &cycle, &opts).expect("the forward run succeeds");
    let ff = fwd.summary.totals.integrals["fuel"];
    assert!(
        (ff - a).abs() < 0.02 * a,
        "forward fuel {ff} against the inverse's {a}"
    );
}
