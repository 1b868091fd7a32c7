//! The forward run with modes (`invsim_runtime::forward::forward_modes`) against the inverse run with modes:
//! si_engine_5speed on the NEDC, the same fuel within 2 % and the same gear at every sample outside a short
//! window around each shift, the tracking error to the raw cycle reported; with the regulation's gear table,
//! the prescribed gear at every geared sample.

use invsim_runtime::forward::{forward_modes, ModalForwardResult};
use invsim_runtime::modes::{simulate_modes, ModalOptions, ModalResult, Switching};
use invsim_runtime::{Cycle, ForwardOptions};

use crate::modes::support::{five_speed, spec, speed_schedule, Loaded};

fn inverse(l: &Loaded, cycle: &Cycle, dt: f64) -> ModalResult {
    let opts = ModalOptions {
        lookahead: 5.0,
        dt,
        switching: Switching::Reentry,
        transition_time: None,
        verify: false,
        keep_series: true,
        operating_points: true,
    };
    simulate_modes(&spec(l, speed_schedule(l)), cycle, &opts).expect("the inverse run succeeds")
}

fn forward(l: &Loaded, cycle: &Cycle, dt: f64) -> ModalForwardResult {
    let opts = ForwardOptions::builder()
        .dt(dt)
        .engine("interpreted")
        .keep_series(true)
        .build()
        .expect("options");
    forward_modes(&spec(l, speed_schedule(l)), cycle, &opts).expect("the forward run succeeds")
}

/// The times where the gear of the geared modes changes (ungeared samples, gear 0, skipped), and where the
/// run enters or leaves an ungeared mode (standstill).
fn events(t: &[f64], gear: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut shifts, mut stands) = (Vec::new(), Vec::new());
    let mut last = 0.0;
    for k in 1..gear.len() {
        if (gear[k] == 0.0) != (gear[k - 1] == 0.0) {
            stands.push(t[k]);
        }
        if gear[k] > 0.0 {
            if last > 0.0 && gear[k] != last {
                shifts.push(t[k]);
            }
            last = gear[k];
        }
    }
    (shifts, stands)
}

/// The gears of the geared samples, run-length compressed.
fn sequence(gear: &[f64]) -> Vec<f64> {
    let mut v: Vec<f64> = Vec::new();
    for &g in gear.iter().filter(|g| **g > 0.0) {
        if v.last() != Some(&g) {
            v.push(g);
        }
    }
    v
}

fn near(events: &[f64], t: f64, window: f64) -> bool {
    events.iter().any(|e| (e - t).abs() <= window + 1e-9)
}

/// Forward with modes against the inverse with modes on the NEDC (dt = 0.1 s, look-ahead 5 s): fuel within
/// 2 % (measured +1.4 %, as for the single-mode si_engine, +1.5 %: the forward car follows the raw cycle's
/// corners, the inverse the smoothed cycle); the same sequence of gears; at every sample where both are in a
/// geared mode the same gear, except within 1.5 s of a shift of either run (the inverse shifts on the
/// smoothed cycle's speed, the forward run on the speed driven); where one stands (idle, the gear column 0)
/// and the other drives, within the look-ahead a = 5 s of a standstill entry or exit of either run (the
/// smoothed reference leaves and reaches 0 up to a before the raw cycle does).
#[test]
fn five_speed_forward_matches_the_inverse_on_the_nedc() {
    let l = five_speed();
    let cycle = Cycle::builtin("nedc").expect("built-in");
    let inv = inverse(&l, &cycle, 0.1);
    let fwd = forward(&l, &cycle, 0.1);
    let s = &fwd.summary;
    let (fi, ff) = (
        inv.summary.totals.integrals["fuel"],
        s.totals.integrals["fuel"],
    );
    assert!(
        ((ff - fi) / fi).abs() < 0.02,
        "forward fuel {ff} kg vs inverse {fi} kg"
    );
    let (gi, gf) = (
        inv.column("gear").expect("gear"),
        fwd.column("gear").expect("gear"),
    );
    let t = fwd.column("t").expect("t");
    assert_eq!(t.len(), gi.len());
    assert_eq!(sequence(gi), sequence(gf), "the same gear sequence");
    let (shifts_i, stands_i) = events(t, gi);
    let (shifts_f, stands_f) = events(t, gf);
    assert!(shifts_i.len() > 30, "{} shifts", shifts_i.len());
    for k in 0..t.len() {
        if gi[k] == gf[k] {
            continue;
        }
        if gi[k] > 0.0 && gf[k] > 0.0 {
            assert!(
                near(&shifts_i, t[k], 1.5) || near(&shifts_f, t[k], 1.5),
                "gear {} (inverse) vs {} (forward) at t = {} s, far from a shift",
                gi[k],
                gf[k],
                t[k]
            );
        } else {
            assert!(
                near(&stands_i, t[k], 5.0) || near(&stands_f, t[k], 5.0),
                "standstill differs at t = {} s, far from a standstill entry or exit",
                t[k]
            );
        }
    }
    // Tracking error to the raw cycle reported, within the regulation's trace tolerance (2 mph).
    assert!(s.max_abs_tracking_error > 0.0 && s.max_abs_tracking_error < 0.5);
    assert!(s.rms_tracking_error > 0.0 && s.rms_tracking_error < s.max_abs_tracking_error);
    assert!(s.trace_misses.is_empty(), "{:?}", s.trace_misses);
    assert!(
        s.totals.input_bound_violations.is_empty(),
        "{:?}",
        s.totals.input_bound_violations
    );
    let total: f64 = s.modes.per_mode.iter().map(|m| m.time_s).sum();
    assert!(
        (total - cycle.duration()).abs() < 1e-6,
        "time per mode adds up to {total}"
    );
    assert_eq!(s.modes.switches, s.modes.transitions.len());
    assert!(s.modes.switches > 50);
    // Every brake and standstill family is used, and the inputs stay within their bounds.
    for family in ["drive", "coast", "overrun", "idle"] {
        assert!(
            s.modes
                .per_mode
                .iter()
                .any(|m| m.name.starts_with(family) && m.time_s > 0.0),
            "{family} used"
        );
    }
    for i in &s.inputs {
        assert!(
            i.min >= i.lower_bound.unwrap_or(f64::NEG_INFINITY) - 1e-9,
            "{i:?}"
        );
        assert!(i.max <= i.upper_bound.unwrap_or(f64::INFINITY), "{i:?}");
    }
}

/// With the regulation's gear prescription (a gear table) the forward run takes its gear from the table, as
/// the inverse does: on the NEDC every geared sample of both runs is in the prescribed gear, except where
/// the run waits for a gear that cannot follow yet (the inverse's rule, shared): not at all on the NEDC.
#[test]
fn five_speed_forward_follows_the_regulation_gears() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine_5speed.toml");
    let text = std::fs::read_to_string(&path).expect("the model file");
    let text = text
        .replace("upshift   = [", "schedule = \"regulation\"\n# upshift = [")
        .replace("downshift = [", "# downshift = [");
    let l = crate::modes::support::load(&path, &text);
    let table = invsim_runtime::modes::gears::regulation_table("nedc").expect("a prescription");
    let cycle = Cycle::builtin("nedc").expect("built-in");
    let opts = ForwardOptions::builder()
        .engine("interpreted")
        .keep_series(true)
        .build()
        .expect("options");
    let source = invsim_runtime::modes::GearSource::Table(table.clone());
    let fwd = forward_modes(&spec(&l, source), &cycle, &opts).expect("the forward run");
    let (t, gear) = (
        fwd.column("t").expect("t"),
        fwd.column("gear").expect("gear"),
    );
    let mut geared = 0;
    for (tk, g) in t.iter().zip(gear) {
        if *g > 0.0 {
            geared += 1;
            let want = table
                .iter()
                .take_while(|(tr, _)| tr <= tk)
                .last()
                .map_or(1, |r| r.1);
            assert_eq!(*g, want as f64, "gear at t = {tk} s");
        }
    }
    assert!(geared > 8000, "{geared} geared samples");
    assert!(fwd.summary.totals.input_bound_violations.is_empty());
}
