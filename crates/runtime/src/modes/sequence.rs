//! The rules of the mode sequence, shared by the inverse run with modes and the forward run with modes: the
//! ladder traction → brake modes, standstill, the hysteresis of the traction → brake switch, and the decision
//! at one instant (a new gear first, then the ladder and standstill), given the free input each candidate mode
//! would have there (the inverse solves the mode's inverse, the forward run computes the engine management's
//! demand in that mode).

use super::rules::Rules;
pub(crate) use super::rules::Rung;

/// Where the sequence is between two decisions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Place {
    pub(crate) mode: usize,
    pub(crate) rung: Rung,
    /// Whether the brake band is armed (the traction input was above min + band since the last brake).
    pub(crate) armed: bool,
    /// Time of the last traction/brake switch (for the minimum dwell).
    pub(crate) last_switch: f64,
}

impl Place {
    /// The start in `mode` on `rung`.
    pub(crate) fn new(mode: usize, rung: Rung) -> Place {
        Place {
            mode,
            rung,
            armed: true,
            last_switch: f64::NEG_INFINITY,
        }
    }
}

/// What the run knows at the instant of a decision.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Moment<'y> {
    pub(crate) t: f64,
    pub(crate) gear: usize,
    /// The reference the sequence decides on: its value and slope (the smoothed cycle for the inverse, the
    /// raw cycle for the forward run).
    pub(crate) ys: &'y [f64],
}

/// How a run enters a candidate mode.
pub(crate) trait Switcher {
    type Error;
    /// The free input mode `target` would have if the run entered it now from mode `from` (prepared; made
    /// the run's mode by [`Switcher::commit`]).
    fn try_enter(&mut self, from: usize, target: usize) -> Result<f64, Self::Error>;
    /// Make the entry last prepared the run's mode.
    fn commit(&mut self);
    /// Whether the run has settled on its reference (the inverse: no re-entry transition in progress; the
    /// forward run: the vehicle has slowed below the standstill speed), so that standstill may be entered.
    fn settled(&self) -> bool;
}

/// Where the sequence would like to go, in order of preference: standstill first where wanted, then the
/// ladder rungs `lo..hi` (descending where `down`), each with the least free input the target must then have
/// (its minimum, or minimum + band for a deeper brake: NaN).
struct Wanted {
    standstill: bool,
    lo: usize,
    hi: usize,
    down: bool,
    least: f64,
}

impl Wanted {
    fn candidates(self) -> impl Iterator<Item = (Rung, f64)> {
        let Wanted {
            standstill,
            lo,
            hi,
            down,
            least,
        } = self;
        let first = standstill.then_some((Rung::Standstill, f64::NEG_INFINITY));
        let ladder = (0..hi.saturating_sub(lo)).map(move |k| {
            let j = if down { hi - 1 - k } else { lo + k };
            (Rung::Ladder(j), least)
        });
        first.into_iter().chain(ladder)
    }
}

/// Where the sequence would like to go from the current mode's free input `u` (see [`Wanted`]).
fn wanted(
    rules: &Rules<'_, '_>,
    place: &mut Place,
    at: Moment<'_>,
    u: f64,
    settled: bool,
) -> Wanted {
    let (spec, (t, ys)) = (rules.spec, (at.t, at.ys));
    let rule = &rules.modes[place.mode];
    let lo = rule.input_min.unwrap_or(f64::NEG_INFINITY) - rule.tolerance;
    let rungs = rules.rungs;
    // Standstill is entered once the run has settled (the car then follows the cycle to rest).
    let stopping =
        ys[0] < spec.sequence.standstill_below && ys.get(1).is_none_or(|a| *a <= 0.0) && settled;
    let dwell = t - place.last_switch >= spec.sequence.min_dwell;
    let mut out = Wanted {
        standstill: false,
        lo: 0,
        hi: 0,
        down: false,
        least: f64::NEG_INFINITY,
    };
    match place.rung {
        Rung::Standstill => {
            // A brake force below its minimum while the reference stands or slows is rolling resistance at
            // a standstill (the car would roll back), not a demand for traction.
            let accelerating = ys.get(1).is_some_and(|a| *a > 0.0);
            if (u < lo && accelerating) || ys[0] > spec.sequence.standstill_above {
                out.hi = 1;
            }
        }
        Rung::Ladder(i) => {
            out.standstill = stopping && rules.has_standstill;
            if i == 0 {
                let b = rule.band;
                place.armed = place.armed || u > lo + b;
                let threshold = if place.armed { lo + b } else { lo };
                if u < threshold && dwell {
                    (out.lo, out.hi) = (1, rungs);
                }
            } else if u < lo && dwell {
                (out.lo, out.hi, out.down) = (0, i, true);
            } else if i + 1 < rungs {
                (out.lo, out.hi, out.least) = (i + 1, i + 2, f64::NAN);
            }
        }
    }
    out
}

/// A new gear: the current rung in the new gear, else another rung of it, where the input is within its
/// bounds; where none is, the gear change waits (a driver does not shift into a gear that cannot follow),
/// unless the current mode cannot follow either. Returns the free input after the decision.
fn change_gear<S: Switcher>(
    rules: &Rules<'_, '_>,
    place: &mut Place,
    gear: usize,
    u: f64,
    sw: &mut S,
) -> Result<f64, S::Error> {
    let same_gear = rules.pick(place.rung, gear) == Some(place.mode);
    if same_gear || rules.modes[place.mode].gear.is_none() {
        return Ok(u);
    }
    let current = place.rung;
    let rungs = std::iter::once(current).chain(
        (0..rules.rungs)
            .map(Rung::Ladder)
            .filter(move |r| *r != current),
    );
    // Where the current mode cannot follow either, the gear changes regardless.
    let forced = !rules.feasible(place.mode, u, f64::NEG_INFINITY);
    for (i, rung) in rungs.enumerate() {
        let Some(target) = rules.pick(rung, gear).filter(|&m| m != place.mode) else {
            continue;
        };
        let v = sw.try_enter(place.mode, target)?;
        if rules.feasible(target, v, f64::NEG_INFINITY) || (forced && i == 0) {
            sw.commit();
            place.mode = target;
            place.rung = rung;
            return Ok(v);
        }
    }
    Ok(u)
}

/// Switch as long as the sequence wants another mode (at most a few times per instant): a new gear at once,
/// another rung only where the target's free input is within its bounds there. `u` is the current mode's
/// free input; returns the free input of the mode decided on.
pub(crate) fn decide<S: Switcher>(
    rules: &Rules<'_, '_>,
    place: &mut Place,
    at: Moment<'_>,
    u: f64,
    sw: &mut S,
) -> Result<f64, S::Error> {
    let mut u = change_gear(rules, place, at.gear, u, sw)?;
    for _ in 0..4 {
        let mut moved = false;
        let wants = wanted(rules, place, at, u, sw.settled());
        for (rung, least) in wants.candidates() {
            let Some(target) = rules.pick(rung, at.gear).filter(|&m| m != place.mode) else {
                continue;
            };
            let v = sw.try_enter(place.mode, target)?;
            let rule = &rules.modes[target];
            let lo = rule.input_min.unwrap_or(f64::NEG_INFINITY);
            let least = if least.is_nan() {
                lo + rule.band
            } else {
                least
            };
            if rules.feasible(target, v, least) {
                let ladder_move =
                    matches!((place.rung, rung), (Rung::Ladder(a), Rung::Ladder(b)) if a != b);
                if ladder_move {
                    place.last_switch = at.t;
                    if rung == Rung::Ladder(0) {
                        place.armed = false;
                    }
                }
                sw.commit();
                place.mode = target;
                place.rung = rung;
                u = v;
                moved = true;
                break;
            }
        }
        if !moved {
            break;
        }
    }
    Ok(u)
}
