//! `--lookahead auto`: the longest look-ahead whose smoothed reference a regulation would accept and whose
//! cycle energy stays close to the exact trace's.
//!
//! The look-ahead a trades smoothness against fidelity: a longer a lowers y_d^(r) (for r ≥ 2 the input's
//! peaks scale with a^(1−r) at a corner of the trace) but cuts the corners, so the reference leaves the
//! cycle's tolerance band ([`crate::tolerance_band`]) and drives a gentler cycle than the exact-trace tools
//! (FASTSim, ADVISOR) and the test cell. The choice is the longest a of the ladder [`CANDIDATES`] (within
//! the run's own limits: a ≥ dt/2, a ≤ duration/4) whose reference, on the run's grid,
//!
//! 1. stays inside the tolerance band at every sample, and
//! 2. has a cycle energy within [`ENERGY_TOLERANCE`] of the trace's. The energy is SAE J2951's Energy
//!    Rating per unit mass with a generic light-duty road load,
//!    `E = ∫ max(0, v (v' + f_0 + f_2 v²)) dt`, f_0 = [`ROLLING_ACCEL`] (c_r g, c_r = 0.013),
//!    f_2 = [`DRAG_PER_M`] (½ ρ C_d A / m for ρ = 1.2 kg/m³, C_d A = 0.65 m², m = 1300 kg), by the
//!    rectangle rule on the run's grid when dt ≤ [`ENERGY_STEP`] (the trace's slope at a sample the mean of
//!    its two sides), else by the midpoint rule with that step, for both the reference (v = y_d,
//!    v' = y_d') and the trace (v = v_c, v' its slope).
//!
//! Both tests fail for every a beyond some value on the built-in cycles (the band and the energy deviation
//! grow with a), so the ladder is searched by bisection: about four evaluations of y_d and y_d' on the grid
//! instead of an inverse run per candidate. If no candidate passes, the shortest allowed one is used (and
//! the run reports how far it leaves the band). The longest candidate, 5 s, is the fixed default of
//! `--lookahead`.

use serde::Serialize;

use crate::cycle::Cycle;
use crate::inverse::SimulateError;
use crate::smoother::{Smoother, SmootherError};
use crate::tolerance_band::BandTally;

/// The look-aheads tried, s, longest first.
pub const CANDIDATES: [f64; 16] = [
    5.0, 4.0, 3.0, 2.5, 2.0, 1.75, 1.5, 1.25, 1.0, 0.8, 0.6, 0.5, 0.4, 0.3, 0.2, 0.1,
];
/// The step of the energy's midpoint rule, s.
pub const ENERGY_STEP: f64 = 0.1;
/// The finest grid the bisection judges on, s: a finer run's grid only checks the chosen look-ahead's band.
pub const MIN_SEARCH_STEP: f64 = 0.05;
/// Largest relative difference of the reference's cycle energy from the trace's.
pub const ENERGY_TOLERANCE: f64 = 0.01;
/// f_0 of the generic road load, m/s²: c_r g with c_r = 0.013.
pub const ROLLING_ACCEL: f64 = 0.013 * 9.81;
/// f_2 of the generic road load, 1/m: ½ ρ C_d A / m = 0.5 · 1.2 · 0.65 / 1300.
pub const DRAG_PER_M: f64 = 0.5 * 1.2 * 0.65 / 1300.0;

/// The look-ahead `--lookahead auto` chose and why (the summary's `lookahead_choice` block).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LookaheadChoice {
    /// `auto`.
    pub method: &'static str,
    /// The look-ahead chosen, s.
    pub lookahead_s: f64,
    /// Whether it met both tests (else it is the shortest allowed one).
    pub accepted: bool,
    /// (E_reference − E_trace)/E_trace at the chosen look-ahead (0 for a cycle without positive energy).
    pub energy_deviation: f64,
    /// The look-aheads tried, s, in the order tried.
    pub tried_s: Vec<f64>,
}

impl LookaheadChoice {
    /// Summary text: `look-ahead chosen: auto, 1 s of 1.25, 0.5, 0.8, 1 s tried; cycle energy -0.93 % of the
    /// trace's, inside the tolerance band`.
    pub(crate) fn text(&self) -> String {
        let tried: Vec<String> = self
            .tried_s
            .iter()
            .map(|&a| crate::numfmt::num(a))
            .collect();
        format!(
            "look-ahead chosen: auto, {} s of {} s tried; cycle energy {:+.2} % of the trace's{}",
            crate::numfmt::num(self.lookahead_s),
            tried.join(", "),
            100.0 * self.energy_deviation,
            if self.accepted {
                ", inside the tolerance band"
            } else {
                " (no candidate met both tests: the shortest allowed)"
            }
        )
    }
}

/// The verdict on one candidate: inside the band, and the relative energy deviation.
struct Verdict {
    inside: bool,
    energy_deviation: f64,
}

/// `E = ∫ max(0, v (v' + f_0 + f_2 v²)) dt` by the rectangle rule with step `dt`.
fn energy(v: impl Iterator<Item = (f64, f64)>, dt: f64) -> f64 {
    v.map(|(v, a)| (v * (a + ROLLING_ACCEL + DRAG_PER_M * v * v)).max(0.0))
        .sum::<f64>()
        * dt
}

/// Samples evaluated at once: the grids are walked in blocks, so no allocation grows with the cycle.
const BLOCK: usize = 4096;

/// The trace v_c at increasing `times`, and its slope there (that of the segment holding t, the mean of both
/// sides at a sample; 0 outside the samples), into `v` and `s`.
fn trace_on(cycle: &Cycle, times: &[f64], v: &mut Vec<f64>, s: &mut Vec<f64>) {
    let (time, speed) = (&cycle.time, &cycle.speed);
    let n = time.len().min(speed.len());
    let slope = |i: usize| (speed[i + 1] - speed[i]) / (time[i + 1] - time[i]);
    let mut i = times
        .first()
        .map_or(0, |&t| time.partition_point(|&c| c <= t).saturating_sub(1));
    v.clear();
    s.clear();
    for &t in times {
        while i + 2 < n && time[i + 1] <= t {
            i += 1;
        }
        let (value, b) = if n < 2 || t < time[0] {
            (speed.first().copied().unwrap_or(0.0), 0.0)
        } else if t > time[n - 1] {
            (speed[n - 1], 0.0)
        } else {
            let at_sample = |j: usize| (t - time[j]).abs() <= 1e-9 * t.abs().max(1.0);
            let b = if at_sample(i) {
                0.5 * (slope(i) + if i > 0 { slope(i - 1) } else { 0.0 })
            } else if at_sample(i + 1) {
                0.5 * (slope(i) + if i + 2 < n { slope(i + 1) } else { 0.0 })
            } else {
                slope(i)
            };
            (speed[i] + slope(i) * (t - time[i]), b)
        };
        v.push(value);
        s.push(b);
    }
}

/// A regular grid t_k = t_0 + k·h, k = 0 … n − 1.
#[derive(Debug, Clone, Copy)]
struct Grid {
    t0: f64,
    h: f64,
    n: usize,
}

impl Grid {
    /// The output grid of a run: t_0 + k·dt up to the cycle's end (as `crate::grid::Grid` builds it).
    fn run(cycle: &Cycle, dt: f64) -> Grid {
        let steps = (cycle.duration() / dt).round() as usize;
        Grid {
            t0: cycle.time.first().copied().unwrap_or(0.0),
            h: dt,
            n: steps + 1,
        }
    }

    /// The midpoints of about `step` wide cells over the cycle.
    fn midpoints(cycle: &Cycle, step: f64) -> Grid {
        let duration = cycle.duration();
        let m = ((duration / step).ceil() as usize).max(1);
        let h = duration / m as f64;
        Grid {
            t0: cycle.time.first().copied().unwrap_or(0.0) + 0.5 * h,
            h,
            n: m,
        }
    }

    /// Call `f` with the times of each block of at most [`BLOCK`] samples, in order.
    fn blocks(&self, mut f: impl FnMut(&[f64])) {
        let mut times = Vec::with_capacity(BLOCK.min(self.n));
        let mut k0 = 0;
        while k0 < self.n {
            let k1 = (k0 + BLOCK).min(self.n);
            times.clear();
            times.extend((k0..k1).map(|k| self.t0 + k as f64 * self.h));
            f(&times);
            k0 = k1;
        }
    }
}

/// What one pass over a grid measured: the reference's samples outside the band (when asked) and the
/// energies of the reference and the trace (when asked).
#[derive(Debug, Default)]
struct Pass {
    outside: usize,
    energy: f64,
    trace_energy: f64,
}

/// One pass of `smoother` (none: the trace alone) over `grid`, checking the band if `band` and summing the
/// energies if `energies`.
fn pass(
    cycle: &Cycle,
    smoother: Option<&Smoother>,
    grid: Grid,
    (band, energies): (bool, bool),
) -> Pass {
    let mut tally = BandTally::new(cycle.tolerance);
    let (mut e, mut e_trace) = (0.0, 0.0);
    let (mut y, mut dy, mut v, mut s) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    grid.blocks(|times| {
        trace_on(cycle, times, &mut v, &mut s);
        if energies {
            e_trace += energy(v.iter().copied().zip(s.iter().copied()), grid.h);
        }
        let Some(smoother) = smoother else { return };
        y.resize(times.len(), 0.0);
        dy.resize(times.len(), 0.0);
        if energies {
            smoother.eval_grid(times, Some(grid.h), &mut [&mut y[..], &mut dy[..]]);
            e += energy(y.iter().copied().zip(dy.iter().copied()), grid.h);
        } else {
            smoother.eval_grid(times, Some(grid.h), &mut [&mut y[..]]);
        }
        if band {
            for ((&t, &yd), &c) in times.iter().zip(&y).zip(&v) {
                tally.push(cycle, t, yd, yd - c);
            }
        }
    });
    Pass {
        outside: tally.finish(grid.n).samples_outside,
        energy: e,
        trace_energy: e_trace,
    }
}

/// The grids the bisection judges on: the band's and, when it differs, the energy's.
#[derive(Debug, Clone, Copy)]
struct Grids {
    band: Grid,
    energy: Option<Grid>,
    e_trace: f64,
}

impl Grids {
    /// The run's grid when dt ≤ [`ENERGY_STEP`] (both tests on it), else the run's grid for the band and
    /// midpoints [`ENERGY_STEP`] apart for the energy.
    fn new(cycle: &Cycle, dt: f64) -> Grids {
        let band = Grid::run(cycle, dt);
        let energy = (dt > ENERGY_STEP).then(|| Grid::midpoints(cycle, ENERGY_STEP));
        let e_trace = pass(cycle, None, energy.unwrap_or(band), (false, true)).trace_energy;
        Grids {
            band,
            energy,
            e_trace,
        }
    }
}

/// Judge look-ahead `a` on the `grids`.
fn judge(cycle: &Cycle, a: f64, grids: &Grids) -> Result<Verdict, SmootherError> {
    let smoother = Smoother::new(cycle, a)?;
    let (outside, e) = match grids.energy {
        None => {
            let p = pass(cycle, Some(&smoother), grids.band, (true, true));
            (p.outside, p.energy)
        }
        Some(grid) => (
            pass(cycle, Some(&smoother), grids.band, (true, false)).outside,
            pass(cycle, Some(&smoother), grid, (false, true)).energy,
        ),
    };
    Ok(Verdict {
        inside: outside == 0,
        energy_deviation: if grids.e_trace > 0.0 {
            e / grids.e_trace - 1.0
        } else {
            0.0
        },
    })
}

/// Whether look-ahead `a`'s reference stays inside the band on the run's grid (the energy not asked).
fn inside_band(cycle: &Cycle, a: f64, dt: f64) -> Result<bool, SmootherError> {
    let smoother = Smoother::new(cycle, a)?;
    Ok(pass(cycle, Some(&smoother), Grid::run(cycle, dt), (true, false)).outside == 0)
}

/// The look-ahead for `cycle` on the grid t_0 + k·dt (see the module docs). The grid is checked first as
/// the run checks it (dt valid, between 10 and `crate::grid::MAX_SAMPLES` samples); the candidates outside
/// [dt/2, duration/4] are skipped.
pub fn choose(cycle: &Cycle, dt: f64) -> Result<LookaheadChoice, SimulateError> {
    let duration = cycle.duration();
    crate::grid::Grid::new(cycle.time.first().copied().unwrap_or(0.0), duration, dt)?;
    let allowed: Vec<f64> = CANDIDATES
        .into_iter()
        .filter(|&a| {
            a >= crate::inverse::MIN_LOOKAHEAD_PER_DT * dt
                && a <= crate::inverse::MAX_LOOKAHEAD_FRACTION * duration
        })
        .collect();
    // The bisection's grid: the run's, or for a finer run a grid of step ENERGY_STEP, and then the chosen
    // look-ahead's band is checked on the run's grid too (the next shorter one taken while it fails).
    let grids = Grids::new(
        cycle,
        if dt >= MIN_SEARCH_STEP {
            dt
        } else {
            ENERGY_STEP
        },
    );
    // Bisection over the ladder for the first (longest) passing candidate: every index below `first_unknown`
    // fails, `hi` passes (or is the count).
    let (mut first_unknown, mut hi) = (0, allowed.len());
    let mut tried = Vec::new();
    let mut deviations = vec![0.0; allowed.len()];
    while first_unknown < hi {
        let mid = (first_unknown + hi - 1) / 2;
        tried.push(allowed[mid]);
        let v = judge(cycle, allowed[mid], &grids)?;
        deviations[mid] = v.energy_deviation;
        if v.inside && v.energy_deviation.abs() <= ENERGY_TOLERANCE {
            hi = mid;
        } else {
            first_unknown = mid + 1;
        }
    }
    if dt < MIN_SEARCH_STEP {
        while hi < allowed.len() && !inside_band(cycle, allowed[hi], dt)? {
            hi += 1;
            if let Some(&a) = allowed.get(hi) {
                tried.push(a);
                deviations[hi] = judge(cycle, a, &grids)?.energy_deviation;
            }
        }
    }
    // Nothing passed: the shortest allowed look-ahead (tried last: every index failed); no candidate
    // allowed at all: the default, which the run refuses with its reason.
    let (lookahead_s, accepted, energy_deviation) = if hi < allowed.len() {
        (allowed[hi], true, deviations[hi])
    } else {
        match allowed.len().checked_sub(1) {
            Some(last) => (allowed[last], false, deviations[last]),
            None => (CANDIDATES[0], false, 0.0),
        }
    };
    Ok(LookaheadChoice {
        method: "auto",
        lookahead_s,
        accepted,
        energy_deviation,
        tried_s: tried,
    })
}

/// `opts` for a run on `cycle`: with `lookahead_auto`, the look-ahead [`choose`]n and the choice; else the
/// options as they are and `None`.
pub fn resolve(
    opts: &crate::inverse::SimulationOptions,
    cycle: &Cycle,
) -> Result<(crate::inverse::SimulationOptions, Option<LookaheadChoice>), SimulateError> {
    if !opts.lookahead_auto {
        return Ok((opts.clone(), None));
    }
    let choice = choose(cycle, opts.dt)?;
    Ok((with_choice(opts, &choice), Some(choice)))
}

/// `opts` with the look-ahead `choice` made (no longer `auto`).
pub fn with_choice(
    opts: &crate::inverse::SimulationOptions,
    choice: &LookaheadChoice,
) -> crate::inverse::SimulationOptions {
    crate::inverse::SimulationOptions {
        lookahead: choice.lookahead_s,
        lookahead_auto: false,
        ..opts.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every built-in cycle gets a look-ahead that passes both tests at dt = 0.1 s and 1 s, and the choice
    /// is the longest passing one: the next longer candidate fails a test.
    #[test]
    fn builtin_cycles_choose_a_passing_lookahead() {
        for name in Cycle::builtin_names() {
            let cycle = Cycle::builtin(name).unwrap();
            for dt in [0.1, 1.0] {
                let c = choose(&cycle, dt).unwrap();
                println!("{name} dt {dt}: {c:?}");
                assert!(c.accepted, "{name} dt {dt}: {c:?}");
                assert!(c.energy_deviation.abs() <= ENERGY_TOLERANCE);
                assert!(c.tried_s.len() <= 5, "{c:?}");
                let i = CANDIDATES.iter().position(|&a| a == c.lookahead_s).unwrap();
                if i > 0 && CANDIDATES[i - 1] <= 0.25 * cycle.duration() {
                    let v = judge(&cycle, CANDIDATES[i - 1], &Grids::new(&cycle, dt)).unwrap();
                    assert!(
                        !v.inside || v.energy_deviation.abs() > ENERGY_TOLERANCE,
                        "{name} {dt}"
                    );
                }
            }
        }
    }
}
