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

#[cfg(test)]
mod tests {
    use invsim_model_api::{InverseModel, ModelError, ModelInfo};

    use super::*;
    use crate::modes::{GearSource, ModeSpec, SequenceParams};

    /// A model that only describes its free input's bounds (the sequence's rules ask nothing else).
    struct Bounds(ModelInfo);

    impl InverseModel for Bounds {
        fn info(&self) -> &ModelInfo {
            &self.0
        }
        fn params(&self) -> &[f64] {
            &[]
        }
        fn set_param(&mut self, _: &str, _: f64) -> Result<(), ModelError> {
            unreachable!("not asked by the rules")
        }
        fn h(&self, _: &[f64], _: &[f64]) -> f64 {
            unreachable!("not asked by the rules")
        }
        fn psi(&self, _: &[f64], _: &[f64], _: &mut [f64], _: &mut [f64]) {}
        fn psi_inv(
            &self,
            _: &[f64],
            _: &[f64],
            _: &[f64],
            _: &mut [f64],
        ) -> Result<(), ModelError> {
            unreachable!("not asked by the rules")
        }
        fn alpha(&self, _: &[f64], _: &[f64], _: &[f64]) -> f64 {
            unreachable!("not asked by the rules")
        }
        fn beta(&self, _: &[f64], _: &[f64], _: &[f64]) -> f64 {
            unreachable!("not asked by the rules")
        }
        fn zero_dynamics(&self, _: &[f64], _: &[f64], _: &[f64], _: f64, _: &mut [f64]) {}
        fn rhs(&self, _: &[f64], _: &[f64], _: f64, _: &mut [f64]) {}
        fn outputs(&self, _: &[f64], _: &[f64], _: f64, _: &mut [f64]) {}
    }

    /// The rung's mode as the sequence defined it before the rules were tabulated: the ladder of family
    /// names rebuilt and the modes scanned by family name.
    fn pick_by_names(spec: &ModalSpec<'_>, rung: Rung, gear: usize) -> Option<usize> {
        let family = match rung {
            Rung::Standstill => None,
            Rung::Ladder(i) => ladder(spec).get(i).copied(),
        };
        let fits = |m: &ModeSpec<'_>| match rung {
            Rung::Standstill => m.role == Role::Standstill,
            Rung::Ladder(_) => family.is_some_and(|f| f == m.family),
        };
        let modes = &spec.modes;
        modes
            .iter()
            .position(|m| fits(m) && m.gear == Some(gear))
            .or_else(|| modes.iter().position(|m| fits(m) && m.gear.is_none()))
            .or_else(|| modes.iter().position(fits))
    }

    #[test]
    fn tabulated_rules_agree_with_the_scan_by_family_names() {
        let drive = Bounds(ModelInfo {
            input_min: Some(0.0),
            input_max: Some(0.1),
            ..ModelInfo::default()
        });
        let brake = Bounds(ModelInfo {
            input_min: Some(0.0),
            input_max: Some(5000.0),
            ..ModelInfo::default()
        });
        let mode = |name: &str, family: &str, role: Role, gear: Option<usize>| ModeSpec {
            name: name.into(),
            family: family.into(),
            role,
            gear,
            free_input: 0,
            fixed_outputs: Vec::new(),
            coupled: Vec::new(),
            model: if role == Role::Traction {
                &drive
            } else {
                &brake
            },
        };
        let spec = ModalSpec {
            name: "test".into(),
            inputs: Vec::new(),
            modes: vec![
                mode("idle", "idle", Role::Standstill, None),
                mode("drive_1", "drive", Role::Traction, Some(1)),
                mode("drive_2", "drive", Role::Traction, Some(2)),
                mode("sport_1", "sport", Role::Traction, Some(1)),
                mode("coast_2", "coast", Role::Brake, Some(2)),
                mode("coast_1", "coast", Role::Brake, Some(1)),
                mode("overrun", "overrun", Role::Brake, None),
            ],
            gears: 2,
            gear_source: GearSource::Fixed,
            sequence: SequenceParams {
                standstill_below: 0.05,
                standstill_above: 1.0,
                brake_band: Some(0.002),
                min_dwell: 0.0,
            },
            n_outputs: 0,
            hybrid: None,
        };
        let rules = Rules::new(&spec);
        assert_eq!((rules.rungs, rules.has_standstill), (3, true));
        // Gears inside and beyond the table, rungs on and off the ladder.
        for gear in 0..6 {
            for rung in [0, 1, 2, 3, 7]
                .map(Rung::Ladder)
                .into_iter()
                .chain([Rung::Standstill])
            {
                let expected = pick_by_names(&spec, rung, gear);
                assert_eq!(rules.pick(rung, gear), expected, "{rung:?} in gear {gear}");
            }
        }
        assert_eq!(rules.pick(Rung::Ladder(1), 1), Some(5));
        assert_eq!(rules.pick(Rung::Ladder(0), 3), Some(1));
        // Tolerance 1e-9 of the range (or of 1), band: the sequence's for traction, 1 % of the range else.
        assert_eq!(rules.modes[1].tolerance, 1e-9);
        assert_eq!(rules.modes[4].tolerance, 1e-9 * 5000.0);
        assert_eq!((rules.modes[1].band, rules.modes[4].band), (0.002, 50.0));
        assert!(rules.feasible(4, -4e-6, f64::NEG_INFINITY));
        assert!(!rules.feasible(4, -6e-6, f64::NEG_INFINITY));
        assert!(!rules.feasible(4, 10.0, 50.0));
        assert!(rules.feasible(1, 0.1, 0.05) && !rules.feasible(1, 0.2, 0.05));
    }
}
