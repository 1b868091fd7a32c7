//! The run with modes, sample by sample: at each t_k the current mode is solved (η advanced by its zero
//! dynamics from t_{k−1}), then the sequence decides whether to switch (gear, standstill, traction/brake
//! from the solution); on a switch the new mode is entered from the continuous state and solved again at t_k.

use invsim_model_api::InverseModel;

use super::blend::Blend;
use super::gears::GearBox;
use super::record::{Ctx, Impulse, Record, Solved, Transition};
use super::verify::replay;
use super::NO_SIGNALS;
use super::{ModalError, ModalOptions, ModalResult, ModalSpec, Role, Switching};
use crate::cycle::Cycle;
use crate::grid::Grid;
use crate::ode::{Dopri5, StepFailure};
use crate::smoother::Smoother;

/// The sequence's state between samples.
struct Seq {
    mode: usize,
    rung: Rung,
    eta: Vec<f64>,
    blend: Option<Blend>,
    /// Index into the transitions of the blend in progress.
    open: Option<usize>,
    /// Whether the brake band is armed (the traction input was above min + band since the last brake).
    armed: bool,
    last_switch: f64,
}

impl Ctx<'_, '_> {
    fn model(&self, m: usize) -> &dyn InverseModel {
        self.spec.modes[m].model
    }

    /// y^(0 … r_max) of mode `m`'s reference at t: its map of the smoothed cycle, plus the blend.
    pub(super) fn reference(&self, m: usize, t: f64, blend: Option<&Blend>) -> Vec<f64> {
        let mut y = self.cycle_reference(m, t);
        if let Some(b) = blend {
            b.add(t, &mut y);
        }
        y
    }

    /// The mode's map of the smoothed cycle, y_c^(0 … r_max).
    fn cycle_reference(&self, m: usize, t: f64) -> Vec<f64> {
        let mut y = vec![0.0; self.r_max + 1];
        self.smoother.eval(t, &mut y);
        let map = self.model(m).reference();
        for v in y.iter_mut() {
            *v *= map.scale;
        }
        y[0] += map.offset;
        y
    }

    /// The inverse of mode `m` at t with internal coordinates `eta` (x_guess: a guess for a numeric ψ⁻¹).
    pub(super) fn solve(
        &self,
        m: usize,
        t: f64,
        eta: &[f64],
        blend: Option<&Blend>,
        x_guess: &[f64],
    ) -> Result<Solved, ModalError> {
        let model = self.model(m);
        let r = model.info().relative_degree;
        let yref = self.reference(m, t, blend);
        let mut x = x_guess.to_vec();
        let u = model
            .invert(&yref[..r], eta, NO_SIGNALS, yref[r], &mut x)
            .map_err(|e| self.err(m, t, e.to_string()))?;
        if !(u.is_finite() && x.iter().all(|v| v.is_finite())) {
            return Err(self.err(
                m,
                t,
                "the inverse is not finite (β vanishes or a state left its domain)".into(),
            ));
        }
        Ok(Solved { x, u, yref })
    }

    pub(super) fn err(&self, m: usize, t: f64, message: String) -> ModalError {
        ModalError::Mode {
            mode: self.spec.modes[m].name.clone(),
            t,
            message,
        }
    }

    /// Advance η of mode `m` over [t0, t1] by its zero dynamics along the (blended) reference.
    fn advance_eta(
        &self,
        m: usize,
        (t0, t1): (f64, f64),
        eta: &mut [f64],
        blend: Option<&Blend>,
    ) -> Result<(), ModalError> {
        if eta.is_empty() {
            return Ok(());
        }
        let model = self.model(m);
        let r = model.info().relative_degree;
        let mut ode = Dopri5::new(eta.len(), 1e-10, 1e-12, (t1 - t0) / 4.0);
        let mut f = |t: f64, e: &[f64], de: &mut [f64]| -> Result<(), StepFailure> {
            let y = self.reference(m, t, blend);
            model.zero_dynamics(&y[..r], e, NO_SIGNALS, y[r], de);
            Ok(())
        };
        ode.advance(t0, t1, eta, &mut f).map_err(|e: StepFailure| {
            self.err(m, t1, format!("the zero dynamics failed: {}", e.reason))
        })
    }

    /// η at the start: the zero dynamics' equilibrium for the reference at t (Newton, differences).
    fn initial_eta(&self, m: usize, t: f64) -> Result<Vec<f64>, ModalError> {
        let model = self.model(m);
        let (r, ne) = (model.info().relative_degree, model.info().n_eta);
        let y = self.reference(m, t, None);
        let mut eta = vec![0.0; ne];
        let q = |e: &[f64]| {
            let mut d = vec![0.0; ne];
            model.zero_dynamics(&y[..r], e, NO_SIGNALS, y[r], &mut d);
            d
        };
        for _ in 0..60 {
            let f0 = q(&eta);
            if f0.iter().all(|v: &f64| v.abs() < 1e-12) {
                break;
            }
            let mut jac = nalgebra::DMatrix::zeros(ne, ne);
            for j in 0..ne {
                let h = 1e-6 * eta[j].abs().max(1.0);
                let mut e = eta.clone();
                e[j] += h;
                let f1 = q(&e);
                for i in 0..ne {
                    jac[(i, j)] = (f1[i] - f0[i]) / h;
                }
            }
            let rhs = nalgebra::DVector::from_iterator(ne, f0.iter().map(|v| -v));
            let Some(step) = jac.lu().solve(&rhs) else {
                return Err(self.err(
                    m,
                    t,
                    "no equilibrium of the zero dynamics at the start".into(),
                ));
            };
            for j in 0..ne {
                eta[j] += step[j];
            }
        }
        Ok(eta)
    }
}

/// A place in the sequence: standstill, or a rung of the ladder traction (0) → brake modes (1 …, in the
/// model file's order: each deeper rung brakes more).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rung {
    Standstill,
    Ladder(usize),
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

/// The mode of a rung in a gear (the family's mode of that gear, else its ungeared or first mode).
fn pick(spec: &ModalSpec<'_>, rung: Rung, gear: usize) -> Option<usize> {
    let fits = |m: &super::ModeSpec<'_>| match rung {
        Rung::Standstill => m.role == Role::Standstill,
        Rung::Ladder(i) => ladder(spec).get(i).is_some_and(|f| *f == m.family),
    };
    spec.modes
        .iter()
        .position(|m| fits(m) && m.gear == Some(gear))
        .or_else(|| spec.modes.iter().position(|m| fits(m) && m.gear.is_none()))
        .or_else(|| spec.modes.iter().position(fits))
}

fn has_role(spec: &ModalSpec<'_>, role: Role) -> bool {
    spec.modes.iter().any(|m| m.role == role)
}

/// The hysteresis band of a mode's free input: the sequence's `brake_band` for traction, else 1 % of the
/// input's range (0 without both bounds).
/// The tolerance of a bound check on mode m's free input: 1e-9 of its range (or of 1): a rung entered exactly
/// at a bound (where the old mode's input crossed it) starts there up to rounding.
fn tolerance(ctx: &Ctx<'_, '_>, m: usize) -> f64 {
    let info = ctx.model(m).info();
    match (info.input_min, info.input_max) {
        (Some(lo), Some(hi)) => 1e-9 * (hi - lo).max(1.0),
        _ => 1e-9,
    }
}

fn band(ctx: &Ctx<'_, '_>, m: usize) -> f64 {
    let info = ctx.model(m).info();
    let default = match (info.input_min, info.input_max) {
        (Some(lo), Some(hi)) => 0.01 * (hi - lo),
        _ => 0.0,
    };
    match ctx.spec.modes[m].role {
        Role::Traction => ctx.spec.sequence.brake_band.unwrap_or(0.0),
        _ => default,
    }
}

/// Where the sequence would like to go from the current mode's solution `u`, in order of preference, each
/// with the least free input the target must then have (its minimum, or minimum + band for a deeper brake).
fn wanted(ctx: &Ctx<'_, '_>, seq: &mut Seq, t: f64, u: f64, ys: &[f64]) -> Vec<(Rung, f64)> {
    let spec = ctx.spec;
    let info = ctx.model(seq.mode).info();
    let lo = info.input_min.unwrap_or(f64::NEG_INFINITY) - tolerance(ctx, seq.mode);
    let rungs = ladder(spec).len();
    // Standstill is entered once a re-entry transition is over (the car then follows the cycle to rest).
    let stopping = ys[0] < spec.sequence.standstill_below
        && ys.get(1).is_none_or(|a| *a <= 0.0)
        && seq.blend.as_ref().is_none_or(|b| b.done(t));
    let dwell = t - seq.last_switch >= spec.sequence.min_dwell;
    let mut out = Vec::new();
    match seq.rung {
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
                let b = band(ctx, seq.mode);
                seq.armed = seq.armed || u > lo + b;
                let threshold = if seq.armed { lo + b } else { lo };
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

/// Simulate a model with modes inversely along `cycle`.
pub fn simulate_modes(
    spec: &ModalSpec<'_>,
    cycle: &Cycle,
    opts: &ModalOptions,
) -> Result<ModalResult, ModalError> {
    if spec.modes.is_empty() {
        return Err(ModalError::Setup("the model has no mode".into()));
    }
    if spec.modes.iter().any(|m| m.model.info().n_w() > 0) {
        return Err(ModalError::Setup(
            "a model with modes may not have [signals] yet".into(),
        ));
    }
    let grid = Grid::new(cycle.time[0], cycle.duration(), opts.dt)?;
    let smoother =
        Smoother::new(cycle, opts.lookahead).map_err(|e| ModalError::Setup(e.to_string()))?;
    let r_max = spec
        .modes
        .iter()
        .map(|m| m.model.info().relative_degree)
        .max()
        .unwrap_or(0);
    let n = spec.modes[0].model.info().n_states();
    let transition = opts.transition_time.unwrap_or(opts.lookahead);
    if !(transition > 0.0 && transition.is_finite()) {
        return Err(ModalError::Setup(format!(
            "the transition time must be positive, got {transition} s"
        )));
    }
    let ctx = Ctx {
        spec,
        smoother,
        r_max,
        n,
        transition,
    };
    let rec = run_sequence(&ctx, &grid, opts)?;
    let verify = if opts.verify {
        Some(replay(&ctx, &rec)?)
    } else {
        None
    };
    Ok(super::summary::assemble(&ctx, cycle, opts, rec, verify))
}

fn run_sequence(ctx: &Ctx<'_, '_>, grid: &Grid, opts: &ModalOptions) -> Result<Record, ModalError> {
    let spec = ctx.spec;
    let mut gearbox = GearBox::new(spec.gear_source.clone(), spec.gears);
    let t0 = grid.time(0);
    let ys0 = ctx.smoothed(t0);
    let gear = gearbox.gear(t0, ys0[0]);
    let stand = ys0[0] < spec.sequence.standstill_below && has_role(spec, Role::Standstill);
    let rung = if stand {
        Rung::Standstill
    } else {
        Rung::Ladder(0)
    };
    let mode =
        pick(spec, rung, gear).ok_or_else(|| ModalError::Setup("no traction mode".into()))?;
    let eta = ctx.initial_eta(mode, t0)?;
    let mut seq = Seq {
        mode,
        rung,
        eta,
        blend: None,
        open: None,
        armed: true,
        last_switch: f64::NEG_INFINITY,
    };
    let first = ctx.solve(mode, t0, &seq.eta, None, &vec![0.0; ctx.n])?;
    let mut rec = Record {
        t: vec![t0],
        mode: vec![mode],
        solved: Vec::with_capacity(grid.samples()),
        u_end: Vec::with_capacity(grid.n),
        x_end: Vec::with_capacity(grid.n),
        impulse: vec![0.0],
        impulse_dir: vec![Vec::new()],
        transitions: Vec::new(),
        impulses: Vec::new(),
    };
    let mut cur = first;
    // Decide at t0 too (a start that needs another mode at once).
    cur = decide(ctx, &mut seq, &mut gearbox, t0, cur, &mut rec, opts)?;
    rec.solved.push(cur.clone());
    for k in 1..=grid.n {
        let (ta, tb) = (grid.time(k - 1), grid.time(k));
        ctx.advance_eta(seq.mode, (ta, tb), &mut seq.eta, seq.blend.as_ref())?;
        let end = ctx.solve(seq.mode, tb, &seq.eta, seq.blend.as_ref(), &cur.x)?;
        rec.u_end.push(end.u);
        rec.x_end.push(end.x.clone());
        rec.t.push(tb);
        rec.impulse.push(0.0);
        rec.impulse_dir.push(Vec::new());
        if seq.blend.as_ref().is_some_and(|b| b.done(tb)) {
            seq.blend = None;
            seq.open = None;
        }
        cur = decide(ctx, &mut seq, &mut gearbox, tb, end, &mut rec, opts)?;
        track_deviation(ctx, &seq, tb, &cur, &mut rec);
        rec.mode.push(seq.mode);
        rec.solved.push(cur.clone());
    }
    Ok(rec)
}

impl Ctx<'_, '_> {
    /// The smoothed cycle y_c, y_c' at t (unmapped: the sequence decides on the cycle's speed).
    fn smoothed(&self, t: f64) -> [f64; 2] {
        let mut y = [0.0; 2];
        self.smoother.eval(t, &mut y);
        y
    }
}

/// The largest deviation of the transition in progress.
fn track_deviation(ctx: &Ctx<'_, '_>, seq: &Seq, t: f64, cur: &Solved, rec: &mut Record) {
    if let Some(i) = seq.open {
        let yc = ctx.cycle_reference(seq.mode, t);
        let d = (cur.yref[0] - yc[0]).abs();
        let tr = &mut rec.transitions[i];
        tr.max_deviation = tr.max_deviation.max(d);
    }
}

/// Switch as long as the sequence wants another mode (at most a few times per sample): a new gear at once,
/// another rung only where the target's free input is within its bounds there.
fn decide(
    ctx: &Ctx<'_, '_>,
    seq: &mut Seq,
    gearbox: &mut GearBox,
    t: f64,
    mut cur: Solved,
    rec: &mut Record,
    opts: &ModalOptions,
) -> Result<Solved, ModalError> {
    let ys = ctx.smoothed(t);
    let gear = gearbox.gear(t, ys[0]);
    // A new gear: the current rung in the new gear, else another rung of it, where the input is within its
    // bounds; where none is, the gear change waits (a driver does not shift into a gear that cannot follow).
    let same_gear = pick(ctx.spec, seq.rung, gear) == Some(seq.mode);
    if !same_gear && ctx.spec.modes[seq.mode].gear.is_some() {
        let mut rungs = vec![seq.rung];
        rungs.extend(
            (0..ladder(ctx.spec).len())
                .map(Rung::Ladder)
                .filter(|r| *r != seq.rung),
        );
        // Where the current mode cannot follow either, the gear changes regardless.
        let forced = !feasible(ctx, seq.mode, cur.u, f64::NEG_INFINITY);
        for (i, rung) in rungs.into_iter().enumerate() {
            let Some(target) = pick(ctx.spec, rung, gear).filter(|&m| m != seq.mode) else {
                continue;
            };
            let e = entry(ctx, seq.mode, target, t, &cur, opts.switching)?;
            if feasible(ctx, target, e.solved.u, f64::NEG_INFINITY) || (forced && i == 0) {
                cur = commit(seq, rec, rung, e);
                break;
            }
        }
    }
    for _ in 0..4 {
        let mut moved = false;
        for (rung, least) in wanted(ctx, seq, t, cur.u, &ys) {
            let Some(target) = pick(ctx.spec, rung, gear).filter(|&m| m != seq.mode) else {
                continue;
            };
            let e = entry(ctx, seq.mode, target, t, &cur, opts.switching)?;
            let info = ctx.model(target).info();
            let lo = info.input_min.unwrap_or(f64::NEG_INFINITY);
            let least = if least.is_nan() {
                lo + band(ctx, target)
            } else {
                least
            };
            if feasible(ctx, target, e.solved.u, least) {
                let ladder_move =
                    matches!((seq.rung, rung), (Rung::Ladder(a), Rung::Ladder(b)) if a != b);
                if ladder_move {
                    seq.last_switch = t;
                    if rung == Rung::Ladder(0) {
                        seq.armed = false;
                    }
                }
                cur = commit(seq, rec, rung, e);
                moved = true;
                break;
            }
        }
        if !moved {
            break;
        }
    }
    Ok(cur)
}

/// Whether mode m's free input u is within its bounds (up to the tolerance) and at least `least`.
fn feasible(ctx: &Ctx<'_, '_>, m: usize, u: f64, least: f64) -> bool {
    let info = ctx.model(m).info();
    let tol = tolerance(ctx, m);
    let lo = info.input_min.unwrap_or(f64::NEG_INFINITY) - tol;
    let hi = info.input_max.unwrap_or(f64::INFINITY) + tol;
    u >= lo.max(least) && u <= hi
}

/// What entering a mode gives: its η, blend, solution and the record of the switch.
struct Entry {
    target: usize,
    eta: Vec<f64>,
    blend: Option<Blend>,
    solved: Solved,
    transition: Transition,
    impulse: Option<(Impulse, Vec<f64>)>,
}

/// Enter mode `target` at t from the continuous state `prev.x` (not yet committed).
fn entry(
    ctx: &Ctx<'_, '_>,
    from: usize,
    target: usize,
    t: f64,
    prev: &Solved,
    switching: Switching,
) -> Result<Entry, ModalError> {
    let model = ctx.model(target);
    let info = model.info();
    let r = info.relative_degree;
    let mut xi = vec![0.0; r];
    let mut eta = vec![0.0; info.n_eta];
    model.psi(&prev.x, NO_SIGNALS, &mut xi, &mut eta);
    let yc = ctx.cycle_reference(target, t);
    let transition = Transition {
        t,
        from: ctx.spec.modes[from].name.clone(),
        to: ctx.spec.modes[target].name.clone(),
        max_deviation: 0.0,
    };
    match switching {
        Switching::Reentry => {
            let e = deviations(ctx, from, target, &xi, &yc, prev);
            let blend = e
                .iter()
                .any(|d| *d != 0.0)
                .then(|| Blend::new(t, ctx.transition, &e));
            let solved = ctx.solve(target, t, &eta, blend.as_ref(), &prev.x)?;
            let max_deviation = e.first().map_or(0.0, |d| d.abs());
            Ok(Entry {
                target,
                eta,
                blend,
                solved,
                transition: Transition {
                    max_deviation,
                    ..transition
                },
                impulse: None,
            })
        }
        Switching::QuasiStatic => {
            let solved = ctx.solve(target, t, &eta, None, &prev.x)?;
            let imp = impulse(ctx, target, t, &prev.x, &solved);
            let impulse = (imp.amount != 0.0).then(|| (imp, g_of(model, &solved.x)));
            Ok(Entry {
                target,
                eta,
                blend: None,
                solved,
                transition,
                impulse,
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
    let same_map = ctx.model(from).reference() == ctx.model(target).reference();
    let same_value = xi
        .first()
        .is_some_and(|x0| (x0 - prev.yref[0]).abs() <= 1e-9 * (1.0 + x0.abs()));
    if same_map && same_value {
        e.push(prev.yref[r] - yc[r]);
    }
    e
}

/// Make an entry the sequence's state.
fn commit(seq: &mut Seq, rec: &mut Record, rung: Rung, e: Entry) -> Solved {
    seq.mode = e.target;
    seq.rung = rung;
    seq.eta = e.eta;
    seq.blend = e.blend;
    rec.transitions.push(e.transition);
    seq.open = seq.blend.as_ref().map(|_| rec.transitions.len() - 1);
    if let Some((imp, g)) = e.impulse {
        let k = rec.impulse.len() - 1;
        rec.impulse[k] += imp.amount;
        rec.impulse_dir[k] = g;
        rec.impulses.push(imp);
    }
    e.solved
}

/// g(x) of an affine model: rhs(x, 1) − rhs(x, 0).
pub(super) fn g_of(model: &dyn InverseModel, x: &[f64]) -> Vec<f64> {
    let n = x.len();
    let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
    model.rhs(x, NO_SIGNALS, 1.0, &mut a);
    model.rhs(x, NO_SIGNALS, 0.0, &mut b);
    a.iter().zip(&b).map(|(p, q)| p - q).collect()
}

/// The impulse U along g that realises the jump prev → s.x, with its booking in the accumulated outputs.
fn impulse(ctx: &Ctx<'_, '_>, m: usize, t: f64, prev: &[f64], s: &Solved) -> Impulse {
    let model = ctx.model(m);
    let g = g_of(model, &s.x);
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
    model.outputs(&s.x, NO_SIGNALS, s.u + h, &mut op);
    model.outputs(&s.x, NO_SIGNALS, s.u - h, &mut om);
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
