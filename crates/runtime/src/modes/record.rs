//! What a run with modes records as it goes and what its summary lists: the run's fixed context, each solved
//! sample, the record of the whole run, and the time per mode, the switches and the quasi-static impulses.
//! Shared by the runner, the replay and the summary (which import it; it imports none of them).

use serde::Serialize;

use super::rows::Rows;
use super::rules::Rules;
use super::ModalSpec;

/// Time spent in one mode.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeTime {
    pub name: String,
    pub time_s: f64,
    pub relative_degree: usize,
}

/// One switch and, for the re-entry, its transition's largest deviation |y − y_c| from the smoothed cycle.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Transition {
    pub t: f64,
    pub from: String,
    pub to: String,
    pub max_deviation: f64,
}

/// One impulse of the quasi-static option.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Impulse {
    pub t: f64,
    pub mode: String,
    pub input: String,
    /// ∫ u dt of the impulse (input unit · s).
    pub amount: f64,
    /// The part of the state jump no impulse of the input realises, relative to the state's size.
    pub unrealisable: f64,
    /// Booked into each of the model's `[outputs]` (0 for those not accumulated), in their order.
    pub booked: Vec<f64>,
}

/// A state set to its coupling where a mode that couples it was entered with the state elsewhere (a clutch
/// closing with slip); entries that find the state at its coupling are not listed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CouplingReset {
    pub t: f64,
    pub mode: String,
    pub state: String,
    /// c(x) − s at the entry, in the state's unit.
    pub jump: f64,
}

/// A committed entry into a mode, as the gradient pass (`gradient.rs`) replays it: the sample it happened
/// at, the modes, the re-entry's blend and the number of deviations it started from (r of the new mode, or
/// r + 1 where the input continued through the switch; 0 for a quasi-static jump).
#[derive(Debug, Clone)]
pub(super) struct EntryLog {
    pub(super) sample: usize,
    pub(super) from: usize,
    pub(super) to: usize,
    pub(super) blend: Option<super::blend::Blend>,
    pub(super) deviations: usize,
}

/// The run's fixed context.
pub(super) struct Ctx<'a, 'm> {
    pub(super) spec: &'a ModalSpec<'m>,
    /// The sequence's rules of the spec (computed once).
    pub(super) rules: Rules<'a, 'm>,
    /// The smoothed cycle and signals (at the samples, on the zero dynamics' sub-grid, pointwise).
    pub(super) reference: std::sync::Arc<super::reference::ModalReference>,
    /// Highest relative degree over the modes (yd columns 0 … r_max).
    pub(super) r_max: usize,
    pub(super) n: usize,
    pub(super) transition: f64,
    /// Per mode, the decided inputs (`decided`) as (input index, slot in the mode's signal values `w`).
    pub(super) decided: Vec<Vec<(usize, usize)>>,
    /// Per mode, its map of the smoothed cycle (asked of the model once: the stages read it often).
    pub(super) maps: Vec<invsim_model_api::ReferenceMap>,
}

/// Per mode of `spec`, its map of the smoothed cycle (`InverseModel::reference`).
pub(super) fn reference_maps(spec: &ModalSpec<'_>) -> Vec<invsim_model_api::ReferenceMap> {
    spec.modes.iter().map(|m| m.model.reference()).collect()
}

/// Per mode of `spec`, its decided inputs: the signals of its model named like an input, as (input index,
/// slot of the value in `w`, [S, S_d1, …, S_dr] per signal).
pub(super) fn decided_slots(spec: &ModalSpec<'_>) -> Vec<Vec<(usize, usize)>> {
    spec.modes
        .iter()
        .map(|m| {
            let info = m.model.info();
            let per = info.relative_degree + 1;
            info.signals
                .iter()
                .enumerate()
                .filter_map(|(j, s)| {
                    let i = spec.inputs.iter().position(|x| x.name == s.name)?;
                    Some((i, j * per))
                })
                .collect()
        })
        .collect()
}

/// The zero dynamics' accepted steps over the run with their continuous extensions, kept where the run is
/// differentiated: the gradient's pass reads η between them (`gradient_zd.rs`) instead of integrating again.
pub(super) struct ZdSteps {
    pub(super) log: crate::ode::StepLog,
    /// Interval k's steps are `starts[k] .. starts[k + 1]` of the log (none for a mode without η).
    pub(super) starts: Vec<usize>,
}

impl ZdSteps {
    /// The most values the log keeps (128 MB): a run whose steps need more is refused its gradient.
    const VALUES_MAX: usize = 1 << 24;

    pub(super) fn new() -> ZdSteps {
        ZdSteps {
            log: crate::ode::StepLog::new(Self::VALUES_MAX),
            starts: vec![0],
        }
    }

    /// The steps of interval k.
    pub(super) fn of_interval(&self, k: usize) -> std::ops::Range<usize> {
        self.starts[k]..self.starts[k + 1]
    }
}

/// One solved sample of a mode.
#[derive(Debug, Clone)]
pub(super) struct Solved {
    pub(super) x: Vec<f64>,
    pub(super) u: f64,
    /// y^(0 … r_max) of the mode's reference (blend included).
    pub(super) yref: Vec<f64>,
}

/// Everything recorded along the run.
pub(super) struct Record {
    pub(super) t: Vec<f64>,
    /// The smoothed cycle's speed y_c(t) at each sample (unmapped).
    pub(super) speed: Vec<f64>,
    pub(super) mode: Vec<usize>,
    /// The solved samples: the state, the free input and the reference y^(0 … r_max) at each.
    pub(super) states: Rows,
    pub(super) free: Vec<f64>,
    pub(super) yref: Rows,
    pub(super) u_end: Vec<f64>,
    pub(super) x_end: Rows,
    pub(super) impulse: Vec<f64>,
    /// The direction g of each sample's impulse, for the samples that have one (few): (sample, g) in order
    /// ([`Record::set_impulse_dir`]).
    pub(super) impulse_dir: Vec<(usize, Vec<f64>)>,
    pub(super) transitions: Vec<Transition>,
    pub(super) impulses: Vec<Impulse>,
    pub(super) resets: Vec<CouplingReset>,
    /// Every committed entry, in order.
    pub(super) entries: Vec<EntryLog>,
    /// The decided inputs' values at each sample (held over its interval), in the mode's order of
    /// [`Ctx::decided`]; empty for a run without a strategy.
    pub(super) decided: Vec<Vec<f64>>,
    /// The zero dynamics' steps (a differentiated run's).
    pub(super) zd_steps: Option<ZdSteps>,
}

impl Record {
    /// The record of a run of `samples` samples that starts at t0 (smoothed cycle's speed `speed0`) in
    /// `mode`, its states and references of `n` and `n_yref` values.
    pub(super) fn new(
        (t0, speed0): (f64, f64),
        mode: usize,
        samples: usize,
        (n, n_yref): (usize, usize),
    ) -> Record {
        // Every per-sample column is allocated for the whole run at once.
        fn first<T>(v: T, samples: usize) -> Vec<T> {
            let mut c = Vec::with_capacity(samples.max(1));
            c.push(v);
            c
        }
        let intervals = samples.saturating_sub(1);
        Record {
            t: first(t0, samples),
            speed: first(speed0, samples),
            mode: first(mode, samples),
            states: Rows::with_capacity(n, samples),
            free: Vec::with_capacity(samples),
            yref: Rows::with_capacity(n_yref, samples),
            u_end: Vec::with_capacity(intervals),
            x_end: Rows::with_capacity(n, intervals),
            impulse: first(0.0, samples),
            impulse_dir: Vec::new(),
            transitions: Vec::new(),
            impulses: Vec::new(),
            resets: Vec::new(),
            entries: Vec::new(),
            decided: Vec::new(),
            zd_steps: None,
        }
    }

    /// The direction of sample k's impulse (a later impulse at the sample replaces it).
    pub(super) fn set_impulse_dir(&mut self, k: usize, g: Vec<f64>) {
        match self.impulse_dir.last_mut() {
            Some((s, dir)) if *s == k => *dir = g,
            _ => self.impulse_dir.push((k, g)),
        }
    }

    /// The direction of sample k's impulse (empty where it has none).
    pub(super) fn impulse_dir_at(&self, k: usize) -> &[f64] {
        match self.impulse_dir.binary_search_by_key(&k, |(s, _)| *s) {
            Ok(i) => &self.impulse_dir[i].1,
            Err(_) => &[],
        }
    }

    /// Record the solved sample `s`.
    pub(super) fn push_solved(&mut self, s: &Solved) {
        self.states.push(&s.x);
        self.free.push(s.u);
        self.yref.push(&s.yref);
    }
}

/// The decided inputs' values of sample k (held over its interval) into their slots of `w` (mode m).
pub(super) fn set_decided(ctx: &Ctx<'_, '_>, rec: &Record, (m, k): (usize, usize), w: &mut [f64]) {
    if let Some(values) = rec.decided.get(k) {
        for (&(_, slot), &v) in ctx.decided[m].iter().zip(values) {
            w[slot] = v;
        }
    }
}
