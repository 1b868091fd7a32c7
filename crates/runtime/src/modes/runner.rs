//! The run with modes, sample by sample: at each t_k the current mode is solved (η advanced by its zero
//! dynamics from t_{k−1}), then the sequence decides whether to switch (gear, standstill, traction/brake
//! from the solution); on a switch the new mode is entered from the continuous state and solved again at t_k.

use invsim_model_api::InverseModel;

use super::bases::Bases;
use super::blend::Blend;
use super::gears::GearBox;
use super::record::{CouplingReset, Ctx, EntryLog, Impulse, Record, Solved, Transition, ZdSteps};
use super::reference::{ModalReference, ReferenceCell};
use super::rules::Rules;
use super::sequence::{decide, Moment, Place, Rung, Switcher};
use super::signals::record_signals;
use super::still::StillStep;
use super::verify::replay;
use super::zd_ode::ZdOde;
use super::{ModalError, ModalOptions, ModalResult, ModalSpec, Switching};
use crate::cycle::Cycle;
use crate::grid::Grid;
use crate::ode::StepFailure;
use crate::signals::SignalInput;
use crate::smoother::{FineReference, ZeroDynamicsReference};

/// Signal values a sample's inverse keeps on the stack (more go to the heap).
const W_ON_STACK: usize = 16;

/// The sequence's state between samples.
struct Seq {
    place: Place,
    modal: Inner,
}

/// What the inverse keeps of its mode beside the sequence's place: η, the re-entry in progress.
struct Inner {
    eta: Vec<f64>,
    blend: Option<Blend>,
    /// Index into the transitions of the blend in progress.
    open: Option<usize>,
}

/// The integrator of the zero dynamics and the buffers of its right-hand side, built once per run (one
/// integrator per mode with internal dynamics, at its first interval) and reused for every interval.
pub(super) struct ZeroDynamics {
    ode: Vec<Option<ZdOde>>,
    /// The run's output step (which integrator, `zd_ode.rs`).
    dt: f64,
    y: Vec<f64>,
    w: Vec<f64>,
    /// The mode and end of the last interval integrated: an interval that continues it (same mode, starting
    /// where it ended) starts with the step size the controller reached, any other with (t1 − t0)/4.
    last: Option<(usize, f64)>,
    /// The reference at the stage times from the sub-grid ([`ZeroDynamicsReference::SubGrid`]), or `None`:
    /// the smoother evaluated pointwise.
    fine: Option<FineReference>,
    /// Where the last interval found the first corner within the look-ahead ([`Smoother::still_on_from`]).
    corner: usize,
    /// The accepted steps with their continuous extensions (a differentiated run's).
    steps: Option<ZdSteps>,
    /// The last interval on a still reference crossed in one step (`still.rs`).
    still: StillStep,
}

impl ZeroDynamics {
    fn new(ctx: &Ctx<'_, '_>, grid: &Grid, logged: bool) -> ZeroDynamics {
        ZeroDynamics {
            ode: ctx.spec.modes.iter().map(|_| None).collect(),
            dt: grid.dt,
            y: vec![0.0; ctx.r_max + 1],
            w: Vec::new(),
            last: None,
            fine: ctx.fine_reference(),
            corner: 0,
            steps: logged.then(ZdSteps::new),
            still: StillStep::default(),
        }
    }
}

impl Ctx<'_, '_> {
    pub(super) fn model(&self, m: usize) -> &dyn InverseModel {
        self.spec.modes[m].model
    }

    /// y^(0 … r_max) of mode `m`'s reference at t into `y`: its map of the smoothed cycle, plus the blend.
    pub(super) fn reference_into(&self, m: usize, t: f64, blend: Option<&Blend>, y: &mut [f64]) {
        self.reference.smoother.eval(t, y);
        self.map_cycle(m, y);
        if let Some(b) = blend {
            b.add(t, y);
        }
    }

    /// A reader of the zero dynamics' sub-grid (`None`: evaluated pointwise, as the run's options ask or
    /// where no mode has internal dynamics).
    pub(super) fn fine_reference(&self) -> Option<FineReference> {
        self.reference.fine.clone().map(FineReference::on)
    }

    /// y^(0 … r) of mode `m`'s reference (r = y.len() − 1) and its signals (`w`, of length n_w) at a stage
    /// time t of its zero dynamics: y_c and the signals interpolated on the sub-grid `fine`, then the mode's
    /// map and the blend as [`Ctx::reference_into`] applies them; without a sub-grid, the smoother pointwise.
    pub(super) fn stage_reference_into(
        &self,
        (m, t, blend): (usize, f64, Option<&Blend>),
        fine: Option<&mut FineReference>,
        y: &mut [f64],
        (w, n_w): (&mut Vec<f64>, usize),
    ) {
        match fine {
            Some(fine) => {
                w.resize(n_w, 0.0);
                fine.eval(&self.reference.smoother, t, y, &mut w[..n_w]);
                self.map_cycle(m, y);
                if let Some(b) = blend {
                    b.add(t, y);
                }
            }
            None => {
                // y^(0 … r) only: the smoother evaluates each order on its own, so the values are those
                // of a longer evaluation.
                self.reference_into(m, t, blend, y);
                self.w_into(m, t, n_w, w);
            }
        }
    }

    /// Mode `m`'s map y = offset + scale · y_c (derivatives scaled) of the smoothed cycle in `y`, in place.
    pub(super) fn map_cycle(&self, m: usize, y: &mut [f64]) {
        let map = self.maps[m];
        for v in y.iter_mut() {
            *v *= map.scale;
        }
        y[0] += map.offset;
    }

    /// The mode's map of the smoothed cycle, y_c^(0 … r_max), from the sample's `base` (the run's `Bases`).
    fn cycle_reference(&self, m: usize, base: &[f64]) -> Vec<f64> {
        let mut y = base[..=self.r_max].to_vec();
        self.map_cycle(m, &mut y);
        y
    }

    /// The inverse of mode `m` at the sample t (`base` its smoothed cycle) with internal coordinates `eta`
    /// (x_guess: a guess for a numeric ψ⁻¹).
    pub(super) fn solve(
        &self,
        m: usize,
        at: (f64, &[f64]),
        eta: &[f64],
        blend: Option<&Blend>,
        x_guess: &[f64],
    ) -> Result<Solved, ModalError> {
        let mut out = Solved {
            x: Vec::with_capacity(x_guess.len()),
            u: 0.0,
            yref: Vec::with_capacity(self.r_max + 1),
        };
        self.solve_into(m, at, (eta, blend), x_guess, &mut out)?;
        Ok(out)
    }

    /// [`Ctx::solve`] into the buffers of `out` (no allocation once they have grown).
    fn solve_into(
        &self,
        m: usize,
        (t, base): (f64, &[f64]),
        (eta, blend): (&[f64], Option<&Blend>),
        x_guess: &[f64],
        out: &mut Solved,
    ) -> Result<(), ModalError> {
        let model = self.model(m);
        let r = model.info().relative_degree;
        out.yref.clear();
        out.yref.extend(base[..=self.r_max].iter().copied());
        self.map_cycle(m, &mut out.yref);
        if let Some(b) = blend {
            b.add(t, &mut out.yref);
        }
        out.x.clear();
        out.x.extend(x_guess.iter().copied());
        // The signals on the stack where they fit (the usual few), else in a vector of their own.
        let n_w = model.info().n_w();
        let (mut near, far);
        let w: &[f64] = if n_w <= W_ON_STACK {
            near = [0.0; W_ON_STACK];
            if n_w > 0 {
                self.w_fill(m, t, &mut near[..n_w]);
            }
            &near[..n_w]
        } else {
            far = self.w(m, t);
            &far
        };
        let (x, yref) = (&mut out.x, &out.yref);
        out.u = model
            .invert(&yref[..r], eta, w, yref[r], x)
            .map_err(|e| self.err(m, t, e.to_string()))?;
        if !(out.u.is_finite() && x.iter().all(|v| v.is_finite())) {
            return Err(self.err(
                m,
                t,
                "the inverse is not finite (β vanishes or a state left its domain)".into(),
            ));
        }
        Ok(())
    }

    pub(super) fn err(&self, m: usize, t: f64, message: String) -> ModalError {
        ModalError::Mode {
            mode: self.spec.modes[m].name.clone(),
            t,
            message,
        }
    }

    /// Advance η of mode `m` over [t0, t1] by its zero dynamics along the (blended) reference, with the
    /// integrator and buffers of `zd`. Every interval starts without an FSAL stage (η may have been set by a
    /// switch); its first step is the one the step-size controller proposed at the end of the previous
    /// interval where that was the same mode's, up to t1 − t0, else the starting step of `ode/start.rs` (from
    /// the zero dynamics at t0 and one more evaluation), up to t1 − t0.
    /// `base0`: the smoothed cycle at the sample t0 (the run's `Bases`).
    fn advance_eta(
        &self,
        m: usize,
        (t0, t1): (f64, f64),
        base0: &[f64],
        eta: &mut [f64],
        blend: Option<&Blend>,
        zd: &mut ZeroDynamics,
    ) -> Result<(), ModalError> {
        if eta.is_empty() {
            return Ok(());
        }
        let model = self.model(m);
        let r = model.info().relative_degree;
        let n_w = model.info().n_w();
        let ZeroDynamics {
            ode,
            dt,
            y,
            w,
            last,
            fine,
            corner,
            steps,
            still: memo,
        } = zd;
        // Dense output only where the steps are logged: else η is needed at the interval's end only.
        let logged = steps.is_some();
        let affine = model.info().zero_dynamics_affine;
        let ode =
            ode[m].get_or_insert_with(|| ZdOde::new(eta.len(), *dt, t1 - t0, (logged, affine)));
        // An interval that does not continue the last one starts from the starting step of `ode/start.rs`
        // (at most the interval): its key in the still memo marks that with h0 = −1.
        let fresh = !matches!(*last, Some((lm, lt)) if lm == m && lt.to_bits() == t0.to_bits());
        let h0 = if fresh {
            -1.0
        } else {
            ode.step_size().min(t1 - t0)
        };
        *last = Some((m, t1));
        ode.reset(h0);
        // The reference and the signals depend on t alone: the two last stages of a step (DOPRI5's 6th and
        // 7th, DOP853's 12th and 13th) are both at t + h, so they are evaluated once for both (the same
        // values), and the first stage at t0 is the sample's reference, mapped from `base0` as `reference_into`
        // maps the smoother's values.
        y[..=r].copy_from_slice(&base0[..=r]);
        self.map_cycle(m, &mut y[..=r]);
        if let Some(b) = blend {
            b.add(t0, &mut y[..=r]);
        }
        self.w_into(m, t0, n_w, w);
        // Where the reference and the signals are constant on the interval (a standstill more than a
        // look-ahead from any corner, no transition under way), the stage times take t0's values.
        let still = blend.is_none_or(|b| b.done(t0))
            && (self.reference.smoother).still_on_from(corner, t0, t1);
        // A still interval that repeats the last one bit for bit has its result (`still.rs`; a
        // differentiated run logs every step, so it integrates each).
        let remembered = still && steps.is_none();
        if remembered {
            memo.key(m, eta, (&y[..=r], &w[..n_w]), (t1 - t0, h0));
            if let Some((end, h)) = memo.recall() {
                eta.copy_from_slice(end);
                ode.reset(h);
                return Ok(());
            }
        }
        let taken = ode.steps_taken();
        let mut at = t0;
        let failed = |t: f64| {
            move |e: StepFailure| self.err(m, t, format!("the zero dynamics failed: {}", e.reason))
        };
        // The variation of constants reads A and b of η' = A η + b (`zd_ode.rs`); every other integrator, and
        // the DOP853 beside it in a logged run, η' itself.
        let affine = ode.is_affine();
        if !affine || logged {
            let mut f = |t: f64, e: &[f64], de: &mut [f64]| -> Result<(), StepFailure> {
                if !still && t.to_bits() != at.to_bits() {
                    self.stage_reference_into((m, t, blend), fine.as_mut(), &mut y[..=r], (w, n_w));
                    at = t;
                }
                model.zero_dynamics(&y[..r], e, w, y[r], de);
                Ok(())
            };
            if fresh {
                ode.start(t0, eta, t1 - t0, &mut f).map_err(failed(t0))?;
            }
            let log = steps.as_mut().map(|s| &mut s.log);
            ode.advance(t0, t1, eta, &mut f, log).map_err(failed(t1))?;
        }
        if affine {
            let mut coefficients = |t: f64, s: f64, ab: &mut [f64; 2]| -> Result<(), StepFailure> {
                if !still && t.to_bits() != at.to_bits() {
                    self.stage_reference_into((m, t, blend), fine.as_mut(), &mut y[..=r], (w, n_w));
                    at = t;
                }
                zero_dynamics_coefficients(model, (&y[..r], &w[..n_w], y[r]), s, ab);
                Ok(())
            };
            ode.advance_affine(t0, t1, eta, &mut coefficients)
                .map_err(failed(t1))?;
        }
        let (accepted, rejected) = ode.steps_taken();
        match remembered && (accepted, rejected) == (taken.0 + 1, taken.1) {
            true => memo.remember(eta, ode.step_size()),
            false => memo.forget(),
        }
        Ok(())
    }

    /// η at the start: the zero dynamics' equilibrium for the reference at t (Newton, differences). A state
    /// the mode couples (`couple`) has no equilibrium of its own (it follows ċ): it is left out of the
    /// iteration, which the other η do not depend on, and then set to its coupling at x = ψ⁻¹(ξ, η).
    fn initial_eta(&self, m: usize, (t, base): (f64, &[f64])) -> Result<Vec<f64>, ModalError> {
        let model = self.model(m);
        let info = model.info();
        let (r, ne) = (info.relative_degree, info.n_eta);
        let coupled = &self.spec.modes[m].coupled;
        let free: Vec<usize> = (0..ne)
            .filter(|&j| {
                !coupled
                    .iter()
                    .any(|&(s, _)| info.eta_states.get(j) == Some(&s))
            })
            .collect();
        let y = self.cycle_reference(m, base);
        let w = self.w(m, t);
        let mut eta = vec![0.0; ne];
        let q = |e: &[f64]| {
            let mut d = vec![0.0; ne];
            model.zero_dynamics(&y[..r], e, &w, y[r], &mut d);
            d
        };
        let nf = free.len();
        for _ in 0..60 {
            let f0 = q(&eta);
            if free.iter().all(|&i| f0[i].abs() < 1e-12) {
                break;
            }
            let mut jac = nalgebra::DMatrix::zeros(nf, nf);
            for (jj, &j) in free.iter().enumerate() {
                let h = 1e-6 * eta[j].abs().max(1.0);
                let mut e = eta.clone();
                e[j] += h;
                let f1 = q(&e);
                for (ii, &i) in free.iter().enumerate() {
                    jac[(ii, jj)] = (f1[i] - f0[i]) / h;
                }
            }
            let rhs = nalgebra::DVector::from_iterator(nf, free.iter().map(|&i| -f0[i]));
            let Some(step) = jac.lu().solve(&rhs) else {
                return Err(self.err(
                    m,
                    t,
                    "no equilibrium of the zero dynamics at the start".into(),
                ));
            };
            for (jj, &j) in free.iter().enumerate() {
                eta[j] += step[jj];
            }
        }
        if nf < ne {
            self.couple_initial_eta(m, (t, &y), &mut eta)?;
        }
        Ok(eta)
    }

    /// The coupled η at the start: c(x) at x = ψ⁻¹(ξ, η) (c does not depend on the coupled states).
    fn couple_initial_eta(
        &self,
        m: usize,
        (t, y): (f64, &[f64]),
        eta: &mut [f64],
    ) -> Result<(), ModalError> {
        let model = self.model(m);
        let info = model.info();
        let r = info.relative_degree;
        let mut x = vec![0.0; self.n];
        let w = self.w(m, t);
        model
            .invert(&y[..r], eta, &w, y[r], &mut x)
            .map_err(|e| self.err(m, t, e.to_string()))?;
        let _ = super::coupling::enter(self, m, t, &mut x, 0.0);
        for (j, &s) in info.eta_states.iter().enumerate() {
            if self.spec.modes[m].coupled.iter().any(|&(c, _)| c == s) {
                eta[j] = x[s];
            }
        }
        Ok(())
    }
}

/// Simulate a model with modes inversely along `cycle` (a model with `[signals]` takes each from the cycle
/// or its default; [`simulate_modes_with_signals`] gives them on the command line's terms).
pub fn simulate_modes(
    spec: &ModalSpec<'_>,
    cycle: &Cycle,
    opts: &ModalOptions,
) -> Result<ModalResult, ModalError> {
    simulate_modes_with_signals(spec, cycle, opts, &[])
}

/// Simulate a model with modes inversely along `cycle`, its signals from `signals` first (`--signal`), then
/// the cycle's column, the cycle's elevation or the default (`crate::signals`); every mode's model calls take
/// the smoothed signals and their derivatives.
pub fn simulate_modes_with_signals(
    spec: &ModalSpec<'_>,
    cycle: &Cycle,
    opts: &ModalOptions,
    signals: &[SignalInput],
) -> Result<ModalResult, ModalError> {
    simulate_modes_with_reference(spec, cycle, opts, signals, ZeroDynamicsReference::default())
}

/// [`simulate_modes_with_signals`] with the zero dynamics' reference taken as `zd` says.
pub fn simulate_modes_with_reference(
    spec: &ModalSpec<'_>,
    cycle: &Cycle,
    opts: &ModalOptions,
    signals: &[SignalInput],
    zd: ZeroDynamicsReference,
) -> Result<ModalResult, ModalError> {
    simulate_modes_differentiated(spec, cycle, opts, signals, (zd, None))
}

/// [`simulate_modes_with_reference`] and, with `wrt`, the summary's `gradient` with respect to those
/// parameters (`gradient.rs`; re-entry switching, modes without couplings).
pub fn simulate_modes_differentiated(
    spec: &ModalSpec<'_>,
    cycle: &Cycle,
    opts: &ModalOptions,
    signals: &[SignalInput],
    how: (ZeroDynamicsReference, Option<&crate::gradient::ModalWrt>),
) -> Result<ModalResult, ModalError> {
    simulate_modes_kept(spec, cycle, opts, signals, how, None)
}

/// [`simulate_modes_differentiated`] reading the smoothed cycle kept in `kept` where it was made for this
/// run (else made, and kept there if `kept` is empty): a sweep's runs on one cycle share it.
pub(crate) fn simulate_modes_kept(
    spec: &ModalSpec<'_>,
    cycle: &Cycle,
    opts: &ModalOptions,
    signals: &[SignalInput],
    (zd, wrt): (ZeroDynamicsReference, Option<&crate::gradient::ModalWrt>),
    kept: Option<&ReferenceCell>,
) -> Result<ModalResult, ModalError> {
    if spec.modes.is_empty() {
        return Err(ModalError::Setup("the model has no mode".into()));
    }
    refuse_decided(spec)?;
    let grid = Grid::new(cycle.time[0], cycle.duration(), opts.dt)?;
    crate::inverse::checks::check_lookahead(opts.lookahead, cycle.duration(), opts.dt)
        .map_err(|e| ModalError::Setup(e.to_string()))?;
    let rereads = opts.verify || wrt.is_some();
    let reference =
        ModalReference::kept_or_new((kept, rereads), spec, (cycle, &grid), opts, (signals, zd))?;
    let r_max = spec.r_max();
    let n = spec.modes[0].model.info().n_states();
    let transition = opts.transition_time.unwrap_or(opts.lookahead);
    if !(transition > 0.0 && transition.is_finite()) {
        return Err(ModalError::Setup(format!(
            "the transition time must be positive, got {transition} s"
        )));
    }
    let ctx = Ctx {
        spec,
        rules: Rules::new(spec),
        reference,
        r_max,
        n,
        transition,
        decided: super::record::decided_slots(spec),
        maps: super::record::reference_maps(spec),
    };
    let rec = run_sequence(&ctx, &grid, opts, wrt.is_some())?;
    let verify = if opts.verify {
        Some(replay(&ctx, &rec)?)
    } else {
        None
    };
    let derivatives = wrt
        .map(|wrt| super::gradient::of_run(&ctx, &grid, &rec, wrt))
        .transpose()?;
    let mut result = super::summary::assemble(&ctx, cycle, opts, rec, verify);
    if let Some((wrt, d)) = wrt.zip(derivatives) {
        result.summary.gradient = Some(super::gradient::figures_of(spec, wrt, &result.summary, d));
    }
    record_signals(&mut result, ctx.reference.resolved.clone());
    Ok(result)
}

/// The (mode, input) of every mode that leaves an input to a strategy, in the modes' order.
pub(crate) fn decided_inputs_of(spec: &ModalSpec<'_>) -> Vec<(String, String)> {
    let decided = super::record::decided_slots(spec);
    let pairs = spec.modes.iter().zip(&decided);
    pairs
        .filter_map(|(m, d)| {
            d.first()
                .map(|&(i, _)| (m.name.clone(), spec.inputs[i].name.clone()))
        })
        .collect()
}

/// A mode that leaves an input to a strategy (`decided`) runs only with one (`--strategy ecms`).
pub(crate) fn refuse_decided(spec: &ModalSpec<'_>) -> Result<(), ModalError> {
    let decided = super::record::decided_slots(spec);
    if let Some(m) = decided.iter().position(|d| !d.is_empty()) {
        return Err(ModalError::Setup(format!(
            "mode `{}` leaves `{}` to a strategy (`decided`): run it with --strategy ecms, dp or \
             rule-based (`simulate`, `sweep`)",
            spec.modes[m].name, spec.inputs[decided[m][0].0].name
        )));
    }
    Ok(())
}

/// The run's record; with the zero dynamics' steps where `logged` (a differentiated run).
fn run_sequence(
    ctx: &Ctx<'_, '_>,
    grid: &Grid,
    opts: &ModalOptions,
    logged: bool,
) -> Result<Record, ModalError> {
    let spec = ctx.spec;
    let mut gearbox = GearBox::new(spec.gear_source.clone(), spec.gears);
    let t0 = grid.time(0);
    // The smoothed cycle at the sample, y_c^(0 … max(r_max, 1)) (what every mode's reference at a sample is
    // a map of), evaluated on the grid block by block.
    let mut bases = Bases::new(&ctx.reference.samples);
    let mut base = vec![0.0; ctx.reference.samples.orders()];
    bases.at(&ctx.reference.smoother, 0, &mut base);
    let gear = gearbox.gear(t0, base[0]);
    let stand = base[0] < spec.sequence.standstill_below && ctx.rules.has_standstill;
    let rung = if stand {
        Rung::Standstill
    } else {
        Rung::Ladder(0)
    };
    let mode = ctx
        .rules
        .pick(rung, gear)
        .ok_or_else(|| ModalError::Setup("no traction mode".into()))?;
    let eta = ctx.initial_eta(mode, (t0, &base))?;
    let mut seq = Seq {
        place: Place::new(mode, rung),
        modal: Inner {
            eta,
            blend: None,
            open: None,
        },
    };
    let first = ctx.solve(mode, (t0, &base), &seq.modal.eta, None, &vec![0.0; ctx.n])?;
    // The record holds per sample t, speed, mode, the free input, the n states and the r_max + 1 references,
    // per step the input and the n states at its end.
    let per_sample = 2 * ctx.n + ctx.r_max + 6;
    crate::grid::check_record(grid.samples(), per_sample, opts.dt)?;
    let mut rec = Record::new((t0, base[0]), mode, grid.samples(), (ctx.n, ctx.r_max + 1));
    let mut zd = ZeroDynamics::new(ctx, grid, logged);
    // Decide at t0 too (a start that needs another mode at once).
    let mut cur = step_sequence(
        ctx,
        &mut seq,
        &mut gearbox,
        (t0, &base),
        first,
        &mut rec,
        opts,
    )?;
    rec.push_solved(&cur);
    // The buffers of the next solution (the previous one's, once it is recorded).
    let mut spare = cur.clone();
    let mut tb = t0;
    for k in 1..=grid.n {
        let ta = tb;
        tb = grid.time(k);
        let (m, inner) = (seq.place.mode, &mut seq.modal);
        ctx.advance_eta(
            m,
            (ta, tb),
            &base,
            &mut inner.eta,
            inner.blend.as_ref(),
            &mut zd,
        )?;
        if let Some(steps) = zd.steps.as_mut() {
            steps.starts.push(steps.log.len());
        }
        bases.at(&ctx.reference.smoother, k, &mut base);
        let local = (&inner.eta[..], inner.blend.as_ref());
        ctx.solve_into(m, (tb, &base), local, &cur.x, &mut spare)?;
        rec.u_end.push(spare.u);
        rec.x_end.push(&spare.x);
        rec.t.push(tb);
        rec.speed.push(base[0]);
        rec.impulse.push(0.0);
        if seq.modal.blend.as_ref().is_some_and(|b| b.done(tb)) {
            seq.modal.blend = None;
            seq.modal.open = None;
        }
        let next = step_sequence(
            ctx,
            &mut seq,
            &mut gearbox,
            (tb, &base),
            spare,
            &mut rec,
            opts,
        )?;
        track_deviation(ctx, &seq, &base, &next, &mut rec);
        rec.mode.push(seq.place.mode);
        rec.push_solved(&next);
        spare = std::mem::replace(&mut cur, next);
    }
    rec.zd_steps = zd.steps.take();
    Ok(rec)
}

/// (A, b) of one internal state's affine zero dynamics η' = A η + b at (ξ, w, y^(r)): from the model's one
/// evaluation of them where it has it, else from η' at η = 0 and at η = s (`zd_ode.rs`).
#[inline(always)]
fn zero_dynamics_coefficients(
    model: &dyn InverseModel,
    (xi, w, yr): (&[f64], &[f64], f64),
    s: f64,
    ab: &mut [f64; 2],
) {
    let mut fused = [0.0; 2];
    if model.zero_dynamics_affine(xi, w, yr, &mut fused) {
        *ab = fused;
        return;
    }
    *ab = super::zd_ode::coefficients_from_two_states(s, |eta| {
        let mut q = [0.0];
        model.zero_dynamics(xi, &[eta], w, yr, &mut q);
        q[0]
    });
}

/// The largest deviation of the transition in progress (`base`: the sample's smoothed cycle).
fn track_deviation(ctx: &Ctx<'_, '_>, seq: &Seq, base: &[f64], cur: &Solved, rec: &mut Record) {
    if let Some(i) = seq.modal.open {
        let map = ctx.maps[seq.place.mode];
        // y_c = offset + scale · base[0], as `map_cycle` computes it.
        let yc = base[0] * map.scale + map.offset;
        let d = (cur.yref[0] - yc).abs();
        let tr = &mut rec.transitions[i];
        tr.max_deviation = tr.max_deviation.max(d);
    }
}

/// The sequence's decision at the sample t (gear from the smoothed cycle's speed `base[0]`), entering each
/// candidate mode from the continuous state by the inverse.
fn step_sequence(
    ctx: &Ctx<'_, '_>,
    seq: &mut Seq,
    gearbox: &mut GearBox,
    (t, base): (f64, &[f64]),
    cur: Solved,
    rec: &mut Record,
    opts: &ModalOptions,
) -> Result<Solved, ModalError> {
    let gear = gearbox.gear(t, base[0]);
    let u = cur.u;
    let mut sw = InverseEntry {
        ctx,
        inner: &mut seq.modal,
        rec,
        t,
        base,
        switching: opts.switching,
        cur,
        pending: None,
    };
    let at = Moment {
        t,
        gear,
        ys: &base[..2],
    };
    decide(&ctx.rules, &mut seq.place, at, u, &mut sw)?;
    Ok(sw.cur)
}

/// The inverse's way into a candidate mode: the re-entry or the quasi-static jump from the current solution.
struct InverseEntry<'c, 'a, 'm> {
    ctx: &'c Ctx<'a, 'm>,
    inner: &'c mut Inner,
    rec: &'c mut Record,
    t: f64,
    /// The sample's smoothed cycle.
    base: &'c [f64],
    switching: Switching,
    cur: Solved,
    pending: Option<Entry>,
}

impl Switcher for InverseEntry<'_, '_, '_> {
    type Error = ModalError;

    fn try_enter(&mut self, from: usize, target: usize) -> Result<f64, ModalError> {
        let at = (self.t, self.base);
        let e = entry(self.ctx, (from, target), at, &self.cur, self.switching)?;
        let u = e.solved.u;
        self.pending = Some(e);
        Ok(u)
    }

    fn commit(&mut self) {
        if let Some(e) = self.pending.take() {
            self.cur = commit(self.ctx, self.inner, self.rec, e);
        }
    }

    fn settled(&self) -> bool {
        self.inner.blend.as_ref().is_none_or(|b| b.done(self.t))
    }
}

/// What entering a mode gives: its η, blend, solution and the record of the switch.
struct Entry {
    eta: Vec<f64>,
    blend: Option<Blend>,
    solved: Solved,
    transition: Switch,
    impulse: Option<(Impulse, Vec<f64>)>,
    /// The states set to their couplings on entering (`couple`).
    resets: Vec<CouplingReset>,
    /// The number of the re-entry's initial deviations (0 for a quasi-static jump).
    deviations: usize,
}

/// Enter mode `target` at t from the continuous state `prev.x` (not yet committed).
fn entry(
    ctx: &Ctx<'_, '_>,
    (from, target): (usize, usize),
    (t, base): (f64, &[f64]),
    prev: &Solved,
    switching: Switching,
) -> Result<Entry, ModalError> {
    let model = ctx.model(target);
    let info = model.info();
    let r = info.relative_degree;
    let mut xi = vec![0.0; r];
    let mut eta = vec![0.0; info.n_eta];
    let w = ctx.w(target, t);
    // The state the new mode starts from: the old one, with the states the new mode couples at their
    // couplings.
    let mut x0 = std::borrow::Cow::Borrowed(&prev.x[..]);
    let jumps = if ctx.spec.modes[target].coupled.is_empty() {
        Vec::new()
    } else {
        super::coupling::enter(ctx, target, t, x0.to_mut(), prev.u)
    };
    let resets = jumps
        .into_iter()
        .map(|(s, jump)| CouplingReset {
            t,
            mode: ctx.spec.modes[target].name.clone(),
            state: info.states[s].clone(),
            jump,
        })
        .collect();
    let x0 = &x0[..];
    model.psi(x0, &w, &mut xi, &mut eta);
    let yc = ctx.cycle_reference(target, base);
    // The record of the switch, its names looked up only when the entry is committed.
    let transition = Switch {
        t,
        from,
        to: target,
        max_deviation: 0.0,
    };
    match switching {
        Switching::Reentry => {
            let e = deviations(ctx, from, target, &xi, &yc, prev);
            let blend = e
                .iter()
                .any(|d| *d != 0.0)
                .then(|| Blend::new(t, ctx.transition, &e));
            let solved = ctx.solve(target, (t, base), &eta, blend.as_ref(), x0)?;
            let max_deviation = e.first().map_or(0.0, |d| d.abs());
            Ok(Entry {
                deviations: e.len(),
                eta,
                blend,
                solved,
                transition: Switch {
                    max_deviation,
                    ..transition
                },
                impulse: None,
                resets,
            })
        }
        Switching::QuasiStatic => {
            let solved = ctx.solve(target, (t, base), &eta, None, x0)?;
            let imp = impulse(ctx, target, t, x0, &solved);
            let impulse = (imp.amount != 0.0).then(|| (imp, g_of(model, &solved.x, &w)));
            Ok(Entry {
                eta,
                blend: None,
                solved,
                transition,
                impulse,
                resets,
                deviations: 0,
            })
        }
    }
}

/// The re-entry's initial deviations from the cycle: ξ_j − y_c^(j) for j < r of the new mode and, where the
/// new mode tracks the same output as the old one (same reference map, same value), the old reference's r-th
/// derivative as well, so that the new mode's input (which depends on y^(r)) continues through the switch.
fn deviations(
    ctx: &Ctx<'_, '_>,
    from: usize,
    target: usize,
    xi: &[f64],
    yc: &[f64],
    prev: &Solved,
) -> Vec<f64> {
    let r = xi.len();
    let mut e: Vec<f64> = (0..r).map(|j| xi[j] - yc[j]).collect();
    let same_map = ctx.maps[from] == ctx.maps[target];
    let same_value = xi
        .first()
        .is_some_and(|x0| (x0 - prev.yref[0]).abs() <= 1e-9 * (1.0 + x0.abs()));
    if same_map && same_value {
        e.push(prev.yref[r] - yc[r]);
    }
    e
}

/// A switch of an entry not yet committed: modes by index.
#[derive(Debug, Clone, Copy)]
struct Switch {
    t: f64,
    from: usize,
    to: usize,
    max_deviation: f64,
}

/// Make an entry the inverse's state (the sequence's place is the caller's).
fn commit(ctx: &Ctx<'_, '_>, seq: &mut Inner, rec: &mut Record, e: Entry) -> Solved {
    rec.entries.push(EntryLog {
        sample: rec.t.len() - 1,
        from: e.transition.from,
        to: e.transition.to,
        blend: e.blend.clone(),
        deviations: e.deviations,
    });
    seq.eta = e.eta;
    seq.blend = e.blend;
    let Switch {
        t,
        from,
        to,
        max_deviation,
    } = e.transition;
    rec.transitions.push(Transition {
        t,
        from: ctx.spec.modes[from].name.clone(),
        to: ctx.spec.modes[to].name.clone(),
        max_deviation,
    });
    seq.open = seq.blend.as_ref().map(|_| rec.transitions.len() - 1);
    rec.resets.extend(e.resets);
    if let Some((imp, g)) = e.impulse {
        let k = rec.impulse.len() - 1;
        rec.impulse[k] += imp.amount;
        rec.set_impulse_dir(k, g);
        rec.impulses.push(imp);
    }
    e.solved
}

/// g(x, w) of an affine model: rhs(x, w, 1) − rhs(x, w, 0).
pub(super) fn g_of(model: &dyn InverseModel, x: &[f64], w: &[f64]) -> Vec<f64> {
    let n = x.len();
    let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
    model.rhs(x, w, 1.0, &mut a);
    model.rhs(x, w, 0.0, &mut b);
    a.iter().zip(&b).map(|(p, q)| p - q).collect()
}

/// The impulse U along g that realises the jump prev → s.x, with its booking in the accumulated outputs.
fn impulse(ctx: &Ctx<'_, '_>, m: usize, t: f64, prev: &[f64], s: &Solved) -> Impulse {
    let model = ctx.model(m);
    let w = ctx.w(m, t);
    let g = g_of(model, &s.x, &w);
    let dx: Vec<f64> = s.x.iter().zip(prev).map(|(a, b)| a - b).collect();
    let gg: f64 = g.iter().map(|v| v * v).sum();
    let amount = if gg > 0.0 {
        g.iter().zip(&dx).map(|(a, b)| a * b).sum::<f64>() / gg
    } else {
        0.0
    };
    let residual = dx
        .iter()
        .zip(&g)
        .map(|(d, gi)| (d - amount * gi).abs() / (s.x.iter().map(|v| v.abs()).fold(1.0, f64::max)))
        .fold(0.0, f64::max);
    let no = model.info().outputs.len();
    let (mut op, mut om) = (vec![0.0; no], vec![0.0; no]);
    let h = 1e-6 * s.u.abs().max(1e-6);
    model.outputs(&s.x, &w, s.u + h, &mut op);
    model.outputs(&s.x, &w, s.u - h, &mut om);
    let booked: Vec<f64> = (0..ctx.spec.n_outputs)
        .map(|i| {
            if model.info().outputs[i].accumulate {
                amount * (op[i] - om[i]) / (2.0 * h)
            } else {
                0.0
            }
        })
        .collect();
    Impulse {
        t,
        mode: ctx.spec.modes[m].name.clone(),
        input: model.info().input.clone(),
        amount,
        unrealisable: residual,
        booked,
    }
}
