//! The mode sequence's view of a spec, computed once per run: the ladder traction → brake families, each
//! mode's rung on it, the mode of every rung in every gear, and each mode's input bounds, tolerance and
//! hysteresis band. The sequence ([`super::sequence`]) asks these at every sample and for every candidate
//! mode; from the spec alone each question would rebuild the ladder of family names.

use super::{ModalSpec, Role};

/// A place in the sequence: standstill, or a rung of the ladder traction (0) → brake modes (1 …, in the
/// model file's order: each deeper rung brakes more).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Rung {
    Standstill,
    Ladder(usize),
}

/// What the sequence needs of one mode.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ModeRule {
    pub(crate) role: Role,
    pub(crate) gear: Option<usize>,
    /// Its family's place on the ladder (none for a family that is not on it: standstill, a traction family
    /// after the first one).
    pub(crate) ladder: Option<usize>,
    pub(crate) input_min: Option<f64>,
    pub(crate) input_max: Option<f64>,
    /// 1e-9 of the free input's range (or of 1): a rung entered exactly at a bound (where the old mode's
    /// input crossed it) starts there up to rounding.
    pub(crate) tolerance: f64,
    /// The hysteresis band of the free input: the sequence's `brake_band` for traction, else 1 % of the
    /// input's range (0 without both bounds).
    pub(crate) band: f64,
}

/// The sequence's rules of one spec.
pub(crate) struct Rules<'s, 'm> {
    pub(crate) spec: &'s ModalSpec<'m>,
    pub(crate) modes: Vec<ModeRule>,
    /// Number of rungs of the ladder.
    pub(crate) rungs: usize,
    pub(crate) has_standstill: bool,
    /// `picks[g][r]`: the mode of rung r (0 standstill, 1 + i ladder rung i) in gear g, for g ≤ the highest
    /// gear of the spec; other gears are looked up by [`Rules::pick_slow`].
    picks: Vec<Vec<Option<usize>>>,
}

/// The families of the ladder: the first traction family, then every brake family, in file order.
fn ladder<'s>(spec: &'s ModalSpec<'_>) -> Vec<&'s str> {
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

impl<'s, 'm> Rules<'s, 'm> {
    pub(crate) fn new(spec: &'s ModalSpec<'m>) -> Rules<'s, 'm> {
        let families = ladder(spec);
        let modes: Vec<ModeRule> = spec
            .modes
            .iter()
            .map(|m| {
                let info = m.model.info();
                let ladder = families.iter().position(|f| *f == m.family);
                let (tolerance, range_band) = match (info.input_min, info.input_max) {
                    (Some(lo), Some(hi)) => (1e-9 * (hi - lo).max(1.0), 0.01 * (hi - lo)),
                    _ => (1e-9, 0.0),
                };
                let band = match m.role {
                    Role::Traction => spec.sequence.brake_band.unwrap_or(0.0),
                    _ => range_band,
                };
                ModeRule {
                    role: m.role,
                    gear: m.gear,
                    ladder,
                    input_min: info.input_min,
                    input_max: info.input_max,
                    tolerance,
                    band,
                }
            })
            .collect();
        let mut rules = Rules {
            spec,
            has_standstill: modes.iter().any(|m| m.role == Role::Standstill),
            modes,
            rungs: families.len(),
            picks: Vec::new(),
        };
        let top = rules.modes.iter().filter_map(|m| m.gear).max().unwrap_or(0);
        let top = top.max(spec.gears);
        rules.picks = (0..=top)
            .map(|g| {
                (0..=rules.rungs)
                    .map(|r| {
                        let rung = r.checked_sub(1).map_or(Rung::Standstill, Rung::Ladder);
                        rules.pick_slow(rung, g)
                    })
                    .collect()
            })
            .collect();
        rules
    }

    /// The mode of a rung in a gear (the family's mode of that gear, else its ungeared or first mode).
    pub(crate) fn pick(&self, rung: Rung, gear: usize) -> Option<usize> {
        let r = match rung {
            Rung::Standstill => 0,
            Rung::Ladder(i) if i < self.rungs => 1 + i,
            Rung::Ladder(_) => return None,
        };
        match self.picks.get(gear) {
            Some(row) => row[r],
            None => self.pick_slow(rung, gear),
        }
    }

    /// [`Rules::pick`] by a scan of the modes.
    fn pick_slow(&self, rung: Rung, gear: usize) -> Option<usize> {
        let fits = |m: &ModeRule| match rung {
            Rung::Standstill => m.role == Role::Standstill,
            Rung::Ladder(i) => m.ladder == Some(i),
        };
        self.modes
            .iter()
            .position(|m| fits(m) && m.gear == Some(gear))
            .or_else(|| self.modes.iter().position(|m| fits(m) && m.gear.is_none()))
            .or_else(|| self.modes.iter().position(fits))
    }

    /// Whether mode m's free input u is within its bounds (up to the tolerance) and at least `least`.
    pub(crate) fn feasible(&self, m: usize, u: f64, least: f64) -> bool {
        let r = &self.modes[m];
        let lo = r.input_min.unwrap_or(f64::NEG_INFINITY) - r.tolerance;
        let hi = r.input_max.unwrap_or(f64::INFINITY) + r.tolerance;
        u >= lo.max(least) && u <= hi
    }
}
