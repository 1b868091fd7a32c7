//! The rules of the mode sequence, shared by the inverse run with modes and the forward run with modes: the
//! ladder traction → brake modes, standstill, the hysteresis of the traction → brake switch, and the decision
//! at one instant (a new gear first, then the ladder and standstill), given the free input each candidate mode
//! would have there (the inverse solves the mode's inverse, the forward run computes the engine management's
//! demand in that mode).

use super::{ModalSpec, ModeSpec, Role};

/// A place in the sequence: standstill, or a rung of the ladder traction (0) → brake modes (1 …, in the
/// model file's order: each deeper rung brakes more).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Rung {
    Standstill,
    Ladder(usize),
}

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

/// The families of the ladder: the first traction family, then every brake family, in file order.
pub(crate) fn ladder<'s>(spec: &'s ModalSpec<'_>) -> Vec<&'s str> {
    let mut out: Vec<&str> = Vec::new();
    if let Some(m) = spec.modes.iter().find(|m| m.role == Role::Traction) {
        out.push(&m.family);
    }
    for m in spec.modes.iter().filter(|m| m.role == Role::Brake) {
        if !out.contains(&m.family.as_str()) {
            out.push(&m.family);
        }
    }
    out
}

/// The mode of a rung in a gear (the family's mode of that gear, else its ungeared or first mode).
pub(crate) fn pick(spec: &ModalSpec<'_>, rung: Rung, gear: usize) -> Option<usize> {
    // The rung's family, looked up once (not for every mode tried).
    let family = match rung {
        Rung::Standstill => None,
        Rung::Ladder(i) => ladder(spec).get(i).copied(),
    };
    let fits = |m: &ModeSpec<'_>| match rung {
        Rung::Standstill => m.role == Role::Standstill,
        Rung::Ladder(_) => family.is_some_and(|f| f == m.family),
    };
    spec.modes
        .iter()
        .position(|m| fits(m) && m.gear == Some(gear))
        .or_else(|| spec.modes.iter().position(|m| fits(m) && m.gear.is_none()))
        .or_else(|| spec.modes.iter().position(fits))
}

pub(crate) fn has_role(spec: &ModalSpec<'_>, role: Role) -> bool {
    spec.modes.iter().any(|m| m.role == role)
}

/// The tolerance of a bound check on mode m's free input: 1e-9 of its range (or of 1): a rung entered exactly
/// at a bound (where the old mode's input crossed it) starts there up to rounding.
pub(crate) fn tolerance(spec: &ModalSpec<'_>, m: usize) -> f64 {
    let info = spec.modes[m].model.info();
    match (info.input_min, info.input_max) {
        (Some(lo), Some(hi)) => 1e-9 * (hi - lo).max(1.0),
        _ => 1e-9,
    }
}

/// The hysteresis band of a mode's free input: the sequence's `brake_band` for traction, else 1 % of the
/// input's range (0 without both bounds).
pub(crate) fn band(spec: &ModalSpec<'_>, m: usize) -> f64 {
    let info = spec.modes[m].model.info();
    let default = match (info.input_min, info.input_max) {
        (Some(lo), Some(hi)) => 0.01 * (hi - lo),
        _ => 0.0,
    };
    match spec.modes[m].role {
        Role::Traction => spec.sequence.brake_band.unwrap_or(0.0),
        _ => default,
    }
}

/// Whether mode m's free input u is within its bounds (up to the tolerance) and at least `least`.
pub(crate) fn feasible(spec: &ModalSpec<'_>, m: usize, u: f64, least: f64) -> bool {
    let info = spec.modes[m].model.info();
    let tol = tolerance(spec, m);
    let lo = info.input_min.unwrap_or(f64::NEG_INFINITY) - tol;
    let hi = info.input_max.unwrap_or(f64::INFINITY) + tol;
    u >= lo.max(least) && u <= hi
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

/// Where the sequence would like to go from the current mode's free input `u`, in order of preference, each
/// with the least free input the target must then have (its minimum, or minimum + band for a deeper brake).
fn wanted(
    spec: &ModalSpec<'_>,
    place: &mut Place,
    at: Moment<'_>,
    u: f64,
    settled: bool,
) -> Vec<(Rung, f64)> {
    let (t, ys) = (at.t, at.ys);
    let info = spec.modes[place.mode].model.info();
    let lo = info.input_min.unwrap_or(f64::NEG_INFINITY) - tolerance(spec, place.mode);
    let rungs = ladder(spec).len();
    // Standstill is entered once the run has settled (the car then follows the cycle to rest).
    let stopping =
        ys[0] < spec.sequence.standstill_below && ys.get(1).is_none_or(|a| *a <= 0.0) && settled;
    let dwell = t - place.last_switch >= spec.sequence.min_dwell;
    let mut out = Vec::new();
    match place.rung {
        Rung::Standstill => {
            // A brake force below its minimum while the reference stands or slows is rolling resistance at
            // a standstill (the car would roll back), not a demand for traction.
            let accelerating = ys.get(1).is_some_and(|a| *a > 0.0);
            if (u < lo && accelerating) || ys[0] > spec.sequence.standstill_above {
                out.push((Rung::Ladder(0), f64::NEG_INFINITY));
            }
        }
        Rung::Ladder(i) => {
            if stopping && has_role(spec, Role::Standstill) {
                out.push((Rung::Standstill, f64::NEG_INFINITY));
            }
            if i == 0 {
                let b = band(spec, place.mode);
                place.armed = place.armed || u > lo + b;
                let threshold = if place.armed { lo + b } else { lo };
                if u < threshold && dwell {
                    out.extend((1..rungs).map(|j| (Rung::Ladder(j), f64::NEG_INFINITY)));
                }
            } else if u < lo && dwell {
                out.extend((0..i).rev().map(|j| (Rung::Ladder(j), f64::NEG_INFINITY)));
            } else if i + 1 < rungs {
                out.push((Rung::Ladder(i + 1), f64::NAN));
            }
        }
    }
    out
}

/// A new gear: the current rung in the new gear, else another rung of it, where the input is within its
/// bounds; where none is, the gear change waits (a driver does not shift into a gear that cannot follow),
/// unless the current mode cannot follow either. Returns the free input after the decision.
fn change_gear<S: Switcher>(
    spec: &ModalSpec<'_>,
    place: &mut Place,
    gear: usize,
    u: f64,
    sw: &mut S,
) -> Result<f64, S::Error> {
    let same_gear = pick(spec, place.rung, gear) == Some(place.mode);
    if same_gear || spec.modes[place.mode].gear.is_none() {
        return Ok(u);
    }
    let mut rungs = vec![place.rung];
    rungs.extend(
        (0..ladder(spec).len())
            .map(Rung::Ladder)
            .filter(|r| *r != place.rung),
    );
    // Where the current mode cannot follow either, the gear changes regardless.
    let forced = !feasible(spec, place.mode, u, f64::NEG_INFINITY);
    for (i, rung) in rungs.into_iter().enumerate() {
        let Some(target) = pick(spec, rung, gear).filter(|&m| m != place.mode) else {
            continue;
        };
        let v = sw.try_enter(place.mode, target)?;
        if feasible(spec, target, v, f64::NEG_INFINITY) || (forced && i == 0) {
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
    spec: &ModalSpec<'_>,
    place: &mut Place,
    at: Moment<'_>,
    u: f64,
    sw: &mut S,
) -> Result<f64, S::Error> {
    let mut u = change_gear(spec, place, at.gear, u, sw)?;
    for _ in 0..4 {
        let mut moved = false;
        for (rung, least) in wanted(spec, place, at, u, sw.settled()) {
            let Some(target) = pick(spec, rung, at.gear).filter(|&m| m != place.mode) else {
                continue;
            };
            let v = sw.try_enter(place.mode, target)?;
            let info = spec.modes[target].model.info();
            let lo = info.input_min.unwrap_or(f64::NEG_INFINITY);
            let least = if least.is_nan() {
                lo + band(spec, target)
            } else {
                least
            };
            if feasible(spec, target, v, least) {
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
