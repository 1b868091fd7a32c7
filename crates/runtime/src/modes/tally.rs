//! The pass over a run's samples that the summary of a run with modes is made of, run by run of samples in
//! one mode: the integrals (trapezoids of each interval in its own mode), the time per mode, each input's
//! range, the bound violations, the reference's deviation, the engine's operating points and (with
//! `keep_series`) the table's inputs and outputs.
//!
//! A run of samples k₀ … k₁ − 1 is a stretch where the run stayed in one mode m with the state, the free
//! input and the decided inputs continuous: the end of interval k (x_end, u_end) is the next sample bit for
//! bit. The model's `[outputs]` at its samples are then one batch ([`InverseModel::outputs_batch`]) where
//! the stretch is long enough to pay for a batch's set-up ([`BATCH_FROM`]), and each interval's end within it
//! takes the next sample's outputs; only the last interval of the stretch, which ends where the run switched
//! or jumped (or where a stretch longer than [`STRETCH_MAX`] is cut), evaluates its end on its own. The
//! trapezoid of interval k, ½ (t_{k+1} − t_k)(o_k + o_end,k), is added in the order of the intervals, as
//! sample by sample.

use super::record::{set_decided, Ctx, Record};
use super::rows::Rows;
use super::rules::ModeRule;
use super::ModalOptions;
use crate::cycle::Cycle;
use crate::operating_points::OperatingPointTally;
use crate::reference_deviation::DeviationTally;

/// The most samples in one batch of outputs (a longer stretch in one mode is taken in several).
const STRETCH_MAX: usize = 256;
/// The fewest samples taken as a batch: a compiled batch sets up its buffers (a few thousand values) first,
/// so a shorter stretch (frequent switching, a long output step) evaluates its samples one by one. Chosen by
/// the time of repeated runs in one process, not by instructions (the buffers' zeroing is a few `rep stos`,
/// fast but counted by the byte): from 16 on, si_engine_5speed on UDDS at dt 0.1 s takes ~4 % less time a run
/// than from 128 on (about half its samples lie in stretches of 16 … 127), the runs at dt 1 s ~1 % less.
const BATCH_FROM: usize = 16;

/// What one pass over the samples gathers.
pub(super) struct Tally {
    /// Every input and the model's `[outputs]` at each sample (empty without `keep_series`), and each
    /// input's range (NaN where a mode neither frees nor reports it is skipped).
    pub(super) inputs: Rows,
    pub(super) outputs: Rows,
    pub(super) ranges: Vec<[f64; 2]>,
    pub(super) integrals: Vec<f64>,
    pub(super) time: Vec<f64>,
    pub(super) violations: Vec<[f64; 2]>,
    /// The sample whose free input lies farthest beyond its bounds.
    pub(super) farthest: Option<Excursion>,
    pub(super) deviation: DeviationTally,
    pub(super) operating: Option<OperatingPointTally>,
}

/// A sample whose free input lies beyond its bounds: where, in which mode, the value and the bound it
/// crosses, the smoothed cycle's speed there (for the warning).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Excursion {
    pub(super) t: f64,
    pub(super) mode: usize,
    pub(super) u: f64,
    pub(super) bound: f64,
    /// The mode's bounds of its free input.
    pub(super) bounds: (Option<f64>, Option<f64>),
    pub(super) speed: f64,
}

/// Whether two slices hold the same numbers bit for bit (so that a function of them gives the same value).
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// Whether samples k and k + 1 hold the same decided values bit for bit (a run without a strategy has none).
fn same_decided(rec: &Record, k: usize) -> bool {
    match (rec.decided.get(k), rec.decided.get(k + 1)) {
        (Some(a), Some(b)) => same_bits(a, b),
        (a, b) => a.is_none() && b.is_none(),
    }
}

/// Whether interval k's end is sample k + 1 in the same mode m: the same state, input and decided inputs.
/// The decided inputs matter where the free input does not depend on them (a series hybrid's generator power,
/// which enters only the battery's and the fuel's equations): the end of an interval holds the interval's
/// value, the next sample its own.
fn continues(rec: &Record, k: usize, m: usize) -> bool {
    rec.mode[k + 1] == m
        && rec.u_end[k].to_bits() == rec.free[k + 1].to_bits()
        && same_bits(&rec.x_end[k], &rec.states[k + 1])
        && same_decided(rec, k)
}

/// The columns of one stretch: the states, the signals and decided inputs, the outputs (each column of
/// [`STRETCH_MAX`] values), and the outputs at the end of the stretch's last interval.
struct Stretch {
    x: Vec<Vec<f64>>,
    w: Vec<Vec<f64>>,
    out: Vec<Vec<f64>>,
    end: Vec<f64>,
    /// A sample's signals and decided inputs (and, for the table with `keep_series`, its row of outputs),
    /// and the values of its inputs.
    w_one: Vec<f64>,
    row: Vec<f64>,
}

impl Stretch {
    fn new(ctx: &Ctx<'_, '_>) -> Stretch {
        let most = |f: fn(&invsim_model_api::ModelInfo) -> usize| {
            let sizes = ctx.spec.modes.iter().map(|m| f(m.model.info()));
            sizes.max().unwrap_or(0)
        };
        let column = || vec![0.0; STRETCH_MAX];
        Stretch {
            x: (0..ctx.n).map(|_| column()).collect(),
            w: (0..most(|i| i.n_w())).map(|_| column()).collect(),
            out: (0..most(|i| i.outputs.len())).map(|_| column()).collect(),
            end: Vec::new(),
            w_one: Vec::new(),
            row: Vec::new(),
        }
    }

    /// Mode m's outputs at samples k0 … k0 + len − 1 into the first `len` values of `out`'s columns: as one
    /// batch from [`BATCH_FROM`] samples on, else sample by sample.
    fn outputs(&mut self, ctx: &Ctx<'_, '_>, rec: &Record, (m, k0, len): (usize, usize, usize)) {
        let model = ctx.model(m);
        let (n_out, n_w) = (model.info().outputs.len(), model.info().n_w());
        if len < BATCH_FROM {
            for j in 0..len {
                let k = k0 + j;
                self.pointwise(ctx, rec, m, (&rec.states[k], rec.t[k], rec.free[k], k));
                for (c, v) in self.out.iter_mut().zip(&self.end) {
                    c[j] = *v;
                }
            }
            return;
        }
        for j in 0..len {
            for (c, v) in self.x.iter_mut().zip(&rec.states[k0 + j]) {
                c[j] = *v;
            }
            if n_w > 0 {
                ctx.w_into(m, rec.t[k0 + j], n_w, &mut self.w_one);
                set_decided(ctx, rec, (m, k0 + j), &mut self.w_one);
                for (c, v) in self.w.iter_mut().zip(&self.w_one) {
                    c[j] = *v;
                }
            }
        }
        let x: Vec<&[f64]> = self.x.iter().map(|c| &c[..len]).collect();
        let w: Vec<&[f64]> = self.w[..n_w].iter().map(|c| &c[..len]).collect();
        let mut out: Vec<&mut [f64]> = self.out[..n_out]
            .iter_mut()
            .map(|c| &mut c[..len])
            .collect();
        model.outputs_batch(&x, &w, &rec.free[k0..k0 + len], &mut out);
    }

    /// Mode m's outputs at the end of interval k (x_end, u_end, the signals at t_{k+1} with the interval's
    /// decided inputs) into `end`.
    fn end_outputs(&mut self, ctx: &Ctx<'_, '_>, rec: &Record, (m, k): (usize, usize)) {
        self.pointwise(ctx, rec, m, (&rec.x_end[k], rec.t[k + 1], rec.u_end[k], k));
    }

    /// Mode m's outputs at state x, time t and input u, with sample k's decided inputs, into `end`.
    fn pointwise(
        &mut self,
        ctx: &Ctx<'_, '_>,
        rec: &Record,
        m: usize,
        (x, t, u, k): (&[f64], f64, f64, usize),
    ) {
        let model = ctx.model(m);
        let (n_out, n_w) = (model.info().outputs.len(), model.info().n_w());
        self.end.clear();
        self.end.resize(n_out, 0.0);
        ctx.w_into(m, t, n_w, &mut self.w_one);
        set_decided(ctx, rec, (m, k), &mut self.w_one);
        model.outputs(x, &self.w_one, u, &mut self.end);
    }
}

/// The pass over the samples (module docs).
pub(super) fn walk(ctx: &Ctx<'_, '_>, cycle: &Cycle, opts: &ModalOptions, rec: &Record) -> Tally {
    let spec = ctx.spec;
    let ns = rec.t.len();
    let info0 = spec.modes[0].model.info();
    let no = spec.n_outputs;
    let kept = if opts.keep_series { ns } else { 0 };
    let mut tally = Tally {
        inputs: Rows::with_capacity(spec.inputs.len(), kept),
        outputs: Rows::with_capacity(no, kept),
        ranges: vec![[f64::INFINITY, f64::NEG_INFINITY]; spec.inputs.len()],
        integrals: vec![0.0; no],
        time: vec![0.0; spec.modes.len()],
        violations: Vec::new(),
        farthest: None,
        deviation: DeviationTally::new(
            invsim_model_api::ReferenceMap::IDENTITY,
            opts.dt,
            cycle.tolerance,
        ),
        // The engine's outputs are among those every mode shares (the first n_outputs).
        operating: OperatingPointTally::new(info0, ns).filter(|_| {
            opts.operating_points
                && info0
                    .engine
                    .as_ref()
                    .is_some_and(|e| e.speed.max(e.torque) < no)
        }),
    };
    let accumulated: Vec<usize> = (0..no).filter(|&i| info0.outputs[i].accumulate).collect();
    let mut stretch = Stretch::new(ctx);
    let mut outside = false;
    let mut k0 = 0;
    while k0 < ns {
        let m = rec.mode[k0];
        let mut k1 = k0 + 1;
        while k1 < ns && k1 - k0 < STRETCH_MAX && continues(rec, k1 - 1, m) {
            k1 += 1;
        }
        let len = k1 - k0;
        stretch.outputs(ctx, rec, (m, k0, len));
        let state = (&mut tally, &mut outside, opts.keep_series);
        samples(ctx, rec, (m, k0, len), &mut stretch, state);
        if let Some(op) = tally.operating.as_mut() {
            op.extend(&stretch.out, 0..len);
        }
        // The intervals k0 … k1 − 1 (the last one only where a sample follows): each ends at the next
        // sample's outputs but the last, which ends on its own.
        let last = if k1 < ns {
            stretch.end_outputs(ctx, rec, (m, k1 - 1));
            len
        } else {
            len - 1
        };
        for &i in &accumulated {
            let (column, end) = (&stretch.out[i][..len], stretch.end.get(i).copied());
            let mut total = tally.integrals[i];
            for j in 0..last {
                let dt = rec.t[k0 + j + 1] - rec.t[k0 + j];
                let o_end = if j + 1 < len {
                    column[j + 1]
                } else {
                    end.unwrap_or(f64::NAN)
                };
                total += 0.5 * dt * (column[j] + o_end);
            }
            tally.integrals[i] = total;
        }
        // Summed in a local (the same additions in the same order), not through memory at every sample.
        let mut time = tally.time[m];
        for j in 0..last {
            time += rec.t[k0 + j + 1] - rec.t[k0 + j];
        }
        tally.time[m] = time;
        k0 = k1;
    }
    // The reference's deviation, the samples as a block (the same operations as sample by sample).
    tally.deviation.push_block(cycle, &rec.t, &rec.speed);
    tally
}

/// Each sample of the stretch of mode m from k0 (its outputs in `stretch.out`): every input's range, the
/// table's rows (`keep`: with `keep_series`), the free input's bound violations.
fn samples(
    ctx: &Ctx<'_, '_>,
    rec: &Record,
    (m, k0, len): (usize, usize, usize),
    stretch: &mut Stretch,
    (tally, outside, keep): (&mut Tally, &mut bool, bool),
) {
    let rule = &ctx.rules.modes[m];
    if keep {
        rows(ctx, rec, (m, k0, len), stretch, tally);
    } else {
        ranges(ctx, rec, (m, k0, len), &stretch.out, &mut tally.ranges);
    }
    for k in k0..k0 + len {
        let u = rec.free[k];
        *outside = track_violation(rule, (rec.t[k], u), *outside, &mut tally.violations);
        if *outside {
            let here = Excursion {
                t: rec.t[k],
                mode: m,
                u,
                bound: crossed_bound(rule, u),
                bounds: (rule.input_min, rule.input_max),
                speed: rec.speed[k],
            };
            tally.farthest = Some(farther(tally.farthest, here));
        }
    }
}

/// The value of input i at sample k of mode m (`out`: the mode's outputs at the stretch's samples, k0 its
/// first): a decided input's value, else the free input, else the output the mode fixes it to, else NaN
/// (the mode neither frees nor reports it).
fn input_value(
    ctx: &Ctx<'_, '_>,
    rec: &Record,
    (m, k0, k): (usize, usize, usize),
    out: &[Vec<f64>],
    i: usize,
) -> f64 {
    let decided = rec.decided.get(k).and_then(|values| {
        let j = ctx.decided[m].iter().position(|&(input, _)| input == i)?;
        values.get(j).copied()
    });
    let mode = &ctx.spec.modes[m];
    decided.unwrap_or_else(|| {
        if i == mode.free_input {
            rec.free[k]
        } else {
            mode.fixed_outputs
                .iter()
                .find(|(input, _)| *input == i)
                .map_or(f64::NAN, |(_, o)| out[*o][k - k0])
        }
    })
}

/// Each input's range over the stretch, input by input and sample by sample in order: the same folds as the
/// table's rows give (NaN, an input the mode neither frees nor reports, leaves a range as it is). Without
/// decided inputs the free input's and the fixed ones' columns are read as they are.
fn ranges(
    ctx: &Ctx<'_, '_>,
    rec: &Record,
    (m, k0, len): (usize, usize, usize),
    out: &[Vec<f64>],
    ranges: &mut [[f64; 2]],
) {
    let mode = &ctx.spec.modes[m];
    for (i, r) in ranges.iter_mut().enumerate() {
        if !rec.decided.is_empty() {
            for k in k0..k0 + len {
                widen(r, input_value(ctx, rec, (m, k0, k), out, i));
            }
        } else if i == mode.free_input {
            rec.free[k0..k0 + len].iter().for_each(|&v| widen(r, v));
        } else if let Some(&(_, o)) = mode.fixed_outputs.iter().find(|(input, _)| *input == i) {
            out[o][..len].iter().for_each(|&v| widen(r, v));
        }
    }
}

/// A range [lo, hi] widened by `v` (NaN leaves it as it is).
fn widen(r: &mut [f64; 2], v: f64) {
    *r = [r[0].min(v), r[1].max(v)];
}

/// The table's rows of the stretch (with `keep_series`): every input's value (and its range) and the model's
/// `[outputs]`, sample by sample.
fn rows(
    ctx: &Ctx<'_, '_>,
    rec: &Record,
    (m, k0, len): (usize, usize, usize),
    stretch: &mut Stretch,
    tally: &mut Tally,
) {
    let n_in = ctx.spec.inputs.len();
    for k in k0..k0 + len {
        let row = &mut stretch.row;
        row.clear();
        row.extend((0..n_in).map(|i| input_value(ctx, rec, (m, k0, k), &stretch.out, i)));
        for (r, &v) in tally.ranges.iter_mut().zip(row.iter()) {
            widen(r, v);
        }
        tally.inputs.push(row);
        stretch.w_one.clear();
        let j = k - k0;
        stretch
            .w_one
            .extend(stretch.out[..ctx.spec.n_outputs].iter().map(|c| c[j]));
        tally.outputs.push(&stretch.w_one);
    }
}

/// Whether the free input `u` at t is outside its bounds (up to the mode's tolerance, 1e-9 of its range);
/// an interval of `violations` opens or extends there (`outside`: whether the previous sample was).
fn track_violation(
    rule: &ModeRule,
    (t, u): (f64, f64),
    outside: bool,
    violations: &mut Vec<[f64; 2]>,
) -> bool {
    let tol = rule.tolerance;
    let out = rule.input_min.is_some_and(|lo| u < lo - tol)
        || rule.input_max.is_some_and(|hi| u > hi + tol);
    match (out, outside) {
        (true, false) => violations.push([t, t]),
        (true, true) => {
            if let Some(v) = violations.last_mut() {
                v[1] = t;
            }
        }
        _ => {}
    }
    out
}

/// The bound of `rule` that `u` lies beyond (the lower one below it, else the upper one).
fn crossed_bound(rule: &ModeRule, u: f64) -> f64 {
    match (rule.input_min, rule.input_max) {
        (Some(lo), _) if u < lo => lo,
        (_, Some(hi)) => hi,
        (lo, None) => lo.unwrap_or(u),
    }
}

/// Of the excursion so far and `here`, the one farther beyond its bound.
fn farther(so_far: Option<Excursion>, here: Excursion) -> Excursion {
    match so_far {
        Some(e) if (e.u - e.bound).abs() >= (here.u - here.bound).abs() => e,
        _ => here,
    }
}
