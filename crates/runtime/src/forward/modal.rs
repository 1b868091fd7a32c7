//! Forward simulation of a model with operating modes (docs/reference.md §2.5): the original equations of the mode
//! in force, closed by the same PI driver and engine management as the single-mode forward run, through a mode
//! sequence decided by the same rules as the inverse run's (`crate::modes::sequence`).
//!
//! Every mode has its own closed loop ([`Loop`]: the engine management inverts that mode's normal form), and
//! all share the state z = (x, I, Q, D): the vehicle's state, the driver's integral and the quadratures. The
//! driver's request a_req = y_c' + K_p e + I is one; each mode turns it into its own free input: in a traction
//! mode the throttle (a positive demand), in a brake mode the brake force (a negative one). At every sample
//! t_k of the output grid the sequence decides as in the inverse, with the free input the candidate mode's
//! engine management would demand at x(t_k) in place of the inverse's solution:
//! - the gear from the schedule on the vehicle speed actually driven y = h(x) (or from the regulation's or
//!   the cycle file's gear table);
//! - traction → brake when the traction demand falls below its minimum (+ the band, armed as in the
//!   inverse), deeper brake rungs where their demand is at least their minimum + 1 % of the range, back up
//!   when the brake demand falls below its minimum;
//! - standstill when the raw cycle is below `standstill_below`, not rising, and the vehicle has slowed below
//!   that speed; left when the brake demand falls below its minimum while the cycle rises, or above
//!   `standstill_above`. At a standstill the brake demand is clipped at its minimum (the brake holds, it
//!   never pushes: a demand below it is the car coming to rest against its rolling resistance, as in the
//!   inverse), and that is no bound violation.
//!
//! The mode holds over [t_k, t_{k+1}] (a controller sampled at the output step, as the inverse switches at
//! its samples); the state is continuous across every switch by construction, the integrator restarts there
//! (the right-hand side jumps).

use invsim_model_api::InverseModel;

use super::budget::Budget;
use super::driver::{Drive, Loop, RawCycle};
use super::integrator::Integrator;
use super::modal_record::{ModalForwardResult, ModalRecorder};
use super::modal_summary::SwitchAt;
use super::{closed_loop, initial_state, ForwardError, ForwardOptions, Method};
use crate::cycle::Cycle;
use crate::error::RunError;
use crate::grid::Grid;
use crate::modes::rules::Rules;
use crate::modes::sequence::{decide, Moment, Place, Rung, Switcher};
use crate::modes::{GearBox, ModalSpec, Role};
use crate::ode::{Dopri5, OdeStats, Rosenbrock23};

/// The run's modes, their closed loops and the sequence's state.
struct ModalRun<'s, 'a> {
    spec: &'s ModalSpec<'a>,
    rules: Rules<'s, 'a>,
    loops: Vec<Loop<'a, dyn InverseModel + 'a>>,
    gearbox: GearBox,
    place: Place,
    gear: usize,
    seg: usize,
    switches: Vec<SwitchAt>,
}

/// Simulate a model with modes forward along the raw `cycle`, closed by the PI driver (see the module docs).
pub fn forward_modes(
    spec: &ModalSpec<'_>,
    cycle: &Cycle,
    opts: &ForwardOptions,
) -> Result<ModalForwardResult, ForwardError> {
    opts.validate()?;
    if let Err(e) = cycle.validate() {
        return Err(RunError::InvalidCycle {
            cycle: cycle.name.clone(),
            reason: e.to_string(),
        }
        .into());
    }
    check_spec(spec)?;
    let (t0, duration) = (cycle.time[0], cycle.duration());
    let grid = Grid::new(t0, duration, opts.dt)?;
    let raw = RawCycle::new(cycle);
    let seg0 = raw.segment(t0);
    let y0 = raw.value(seg0, t0);
    let mut gearbox = GearBox::new(spec.gear_source.clone(), spec.gears);
    let gear = gearbox.gear(t0, y0);
    let rules = Rules::new(spec);
    let stand = y0 < spec.sequence.standstill_below && rules.has_standstill;
    let rung = if stand {
        Rung::Standstill
    } else {
        Rung::Ladder(0)
    };
    let mode = rules.pick(rung, gear).ok_or_else(|| ForwardError::Modes {
        reason: "the model has no traction mode".into(),
    })?;
    // The signals, raw (linear between samples, derivative slots 0) as in the single-mode forward run; each
    // mode takes them in its own layout (its relative degree).
    let resolved = crate::signals::resolve(spec.modes[mode].model.info(), cycle, &opts.signals)
        .map_err(RunError::from)?;
    let signals = crate::signals::smoothers(&resolved, 1.0);
    let mut w0 = vec![0.0; spec.modes[mode].model.info().n_w()];
    super::driver::raw_signals(&signals, t0, &mut w0);
    let mut x0 = initial_state(spec.modes[mode].model, (&raw, &w0), seg0, t0, opts)?;
    // A start in a mode that couples states: they start at their couplings.
    let _ = crate::modes::coupling::set_couplings(&spec.modes[mode], &mut x0, &w0, 0.0);
    // At a standstill the brake holds the car and never pushes it: a demand below the free input's minimum
    // there (the car would roll against its rolling resistance) is clipped, whatever `bounds` says.
    let loops: Vec<Loop<'_, dyn InverseModel>> = spec
        .modes
        .iter()
        .map(|m| {
            let mut lp = closed_loop(m.model, RawCycle::new(cycle), opts);
            lp.signals = signals.clone();
            if m.role == Role::Standstill && !lp.enforce {
                lp.enforce = true;
                lp.hi = f64::INFINITY;
            }
            lp
        })
        .collect();
    // Start in equilibrium: without feed-forward the integral carries the cycle's initial slope.
    let mut z = x0.clone();
    z.push(if opts.feedforward || opts.ki == 0.0 {
        0.0
    } else {
        raw.slope[seg0]
    });
    z.resize(z.len() + loops[mode].accumulate.len() + 1, 0.0);
    let mut run = ModalRun {
        spec,
        rules,
        loops,
        gearbox,
        place: Place::new(mode, rung),
        gear,
        seg: seg0,
        switches: Vec::new(),
    };
    if opts.keep_series {
        let columns = super::modal_record::layout(spec, &x0).0.len();
        crate::grid::check_record(grid.samples(), columns, opts.dt)?;
    }
    let mut rec = ModalRecorder::new(spec, cycle, &grid, opts, &x0);
    let (nz, n_err, h0) = (z.len(), x0.len() + 1, opts.dt.min(0.01));
    let budget = Budget::new(opts, duration, (t0, grid.time(grid.n)));
    let stats = match opts.method {
        Method::Rosenbrock23 => {
            let mut s = Rosenbrock23::new(nz, opts.rtol, opts.atol, h0).error_components(n_err);
            drive_modes(&mut s, &mut run, &mut rec, (&grid, &budget), &mut z)?
        }
        Method::Dopri5 => {
            let mut s = Dopri5::new(nz, opts.rtol, opts.atol, h0).error_components(n_err);
            drive_modes(&mut s, &mut run, &mut rec, (&grid, &budget), &mut z)?
        }
    };
    let mut result = rec.finish(spec, &run.switches, (cycle, opts), stats);
    result.summary.signals = crate::signals::signal_uses(&resolved, "raw");
    result.signals = resolved;
    Ok(result)
}

/// Why a forward run of a hybrid cannot start: a mode leaves an input to a strategy (`decided`), and the
/// driver closes the loop on one input per mode; which mode and how the decided input is split is the
/// strategy's, which `forward` does not run.
fn hybrid_refusal(spec: &ModalSpec<'_>) -> String {
    let decided = crate::modes::decided_inputs_of(spec);
    let (mode, input) = decided.first().cloned().unwrap_or_default();
    format!(
        "mode `{mode}` leaves `{input}` to an energy-management strategy (`decided`), and `forward` runs no \
         strategy: its driver sets one input per mode, not the mode and the split between engine and motor. \
         Run the hybrid inversely with `invsim simulate --strategy ecms|dp|rule-based` (its CSV has the \
         decided input and the mode at every sample)"
    )
}

/// What a forward run with modes needs of the spec: modes, one state vector, the same accumulated outputs.
fn check_spec(spec: &ModalSpec<'_>) -> Result<(), ForwardError> {
    let fail = |reason: &str| {
        Err(ForwardError::Modes {
            reason: reason.to_string(),
        })
    };
    let Some(first) = spec.modes.first() else {
        return fail("the model has no mode");
    };
    if crate::modes::refuse_decided(spec).is_err() {
        return fail(&hybrid_refusal(spec));
    }
    let info = first.model.info();
    let names = |i: &invsim_model_api::ModelInfo| -> Vec<String> {
        i.signals.iter().map(|s| s.name.clone()).collect()
    };
    if spec
        .modes
        .iter()
        .any(|m| names(m.model.info()) != names(info))
    {
        return fail("every mode must declare the same signals");
    }
    let acc = |i: &invsim_model_api::ModelInfo| -> Vec<usize> {
        (0..i.outputs.len())
            .filter(|&k| i.outputs[k].accumulate)
            .collect()
    };
    for m in &spec.modes {
        let mi = m.model.info();
        if mi.n_states() != info.n_states() || acc(mi) != acc(info) {
            return fail("every mode must have the same states and accumulated outputs");
        }
    }
    Ok(())
}

/// The run: interval by interval of the output grid in the mode decided at its start, the sequence deciding
/// at every sample.
fn drive_modes<I: Integrator>(
    stepper: &mut I,
    run: &mut ModalRun<'_, '_>,
    rec: &mut ModalRecorder<'_>,
    (grid, budget): (&Grid, &Budget),
    z: &mut [f64],
) -> Result<OdeStats, ForwardError> {
    let t0 = grid.time(0);
    let d = run.decide(t0, z)?;
    rec.emit(
        run.spec,
        run.place.mode,
        (0, t0),
        z,
        (d, &run.loops[run.place.mode].w),
    )?;
    for k in 1..=grid.n {
        let (ta, tb) = (grid.time(k - 1), grid.time(k));
        run.advance(stepper, budget, (ta, tb), z)?;
        let before = run.place.mode;
        let d = run.decide(tb, z)?;
        if run.place.mode != before {
            stepper.restart();
            // The states the new mode couples (a clutch closing) at their couplings.
            let mode = &run.spec.modes[run.place.mode];
            let n = mode.model.info().n_states();
            let w = &run.loops[run.place.mode].w;
            let _ = crate::modes::coupling::set_couplings(mode, &mut z[..n], w, d.applied);
        }
        rec.emit(
            run.spec,
            run.place.mode,
            (k, tb),
            z,
            (d, &run.loops[run.place.mode].w),
        )?;
    }
    Ok(stepper.stats())
}

impl<'a> ModalRun<'_, 'a> {
    /// Move to the segment of the raw cycle that starts at or before t (a sample on a corner belongs to the
    /// segment it starts); the integrator restarts at each corner (the right-hand side has one there).
    fn sync_segment<I: Integrator>(&mut self, t: f64, stepper: &mut I) {
        let raw = &self.loops[0].raw;
        while self.seg + 1 < raw.segments() && raw.end(self.seg) - t <= 1e-9 * (1.0 + t.abs()) {
            self.seg += 1;
            stepper.restart();
        }
    }

    /// Integrate z over [ta, tb] in the current mode, segment by segment of the raw cycle, within the budget.
    fn advance<I: Integrator>(
        &mut self,
        stepper: &mut I,
        budget: &Budget,
        (ta, tb): (f64, f64),
        z: &mut [f64],
    ) -> Result<(), ForwardError> {
        let mut t = ta;
        loop {
            self.sync_segment(t, stepper);
            if tb - t <= 1e-12 * (1.0 + t.abs()) {
                break;
            }
            let seg = self.seg;
            let target = self.loops[0].raw.end(seg).min(tb);
            let lp = &mut self.loops[self.place.mode];
            t = stepper
                .step_to(t, target, z, &mut |s, zz: &[f64], dz: &mut [f64]| {
                    lp.rhs(seg, s, zz, dz)
                })
                .map_err(|e| match e {
                    ForwardError::Integration { t, reason } => ForwardError::Integration {
                        t,
                        reason: format!("{reason}; {}", budget.gains_hint()),
                    },
                    e => e,
                })?;
            budget.check(t, &stepper.step_state())?;
        }
        self.sync_segment(tb, stepper);
        Ok(())
    }

    /// The sequence's decision at sample t from the state z: the gear from the speed driven, the rest from
    /// each candidate mode's demand. Returns the drive of the mode decided on.
    fn decide(&mut self, t: f64, z: &[f64]) -> Result<Drive, ForwardError> {
        let (seg, m) = (self.seg, self.place.mode);
        let d = self.loops[m].drive(seg, t, z)?;
        let ys = [d.yc, self.loops[0].raw.slope[seg]];
        self.gear = self.gearbox.gear(t, d.y);
        let mut sw = ForwardEntry {
            loops: &mut self.loops,
            seg,
            t,
            z,
            cur: d,
            pending: None,
            settled: d.y.abs() < self.spec.sequence.standstill_below,
            switches: &mut self.switches,
        };
        let at = Moment {
            t,
            gear: self.gear,
            ys: &ys,
        };
        decide(&self.rules, &mut self.place, at, d.demand, &mut sw)?;
        Ok(sw.cur)
    }
}

/// The forward run's way into a candidate mode: that mode's engine management at the current state.
struct ForwardEntry<'r, 'a> {
    loops: &'r mut [Loop<'a, dyn InverseModel + 'a>],
    seg: usize,
    t: f64,
    z: &'r [f64],
    cur: Drive,
    pending: Option<(usize, usize, Drive)>,
    settled: bool,
    switches: &'r mut Vec<SwitchAt>,
}

impl Switcher for ForwardEntry<'_, '_> {
    type Error = ForwardError;

    fn try_enter(&mut self, from: usize, target: usize) -> Result<f64, ForwardError> {
        let d = self.loops[target].drive(self.seg, self.t, self.z)?;
        self.pending = Some((from, target, d));
        Ok(d.demand)
    }

    fn commit(&mut self) {
        if let Some((from, to, d)) = self.pending.take() {
            self.cur = d;
            self.switches.push((self.t, from, to));
        }
    }

    fn settled(&self) -> bool {
        self.settled
    }
}
