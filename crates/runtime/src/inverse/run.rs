//! The inverse run: validation, the zero-dynamics plan, the columns, the run block by block and the summary.

use invsim_model_api::{InverseModel, ModelInfo};

use super::checks;
use super::error::SimulateError;
use super::inverter::{Block, Inverter};
use super::options::SimulationOptions;
use super::reference::Reference;
use super::result::SimulationResult;
use super::summary::{InputBeforeStart, StableInversionStats, Summary};
use super::verify::verify_forward;
use crate::cycle::Cycle;
use crate::error::RunError;
use crate::gradient::DirectSensitivities;
use crate::grid::{check_samples, Grid, MAX_DERIVATIVES};
use crate::headline::Headline;
use crate::operating_points::OperatingPointTally;
use crate::progress::Progress;
use crate::reference_deviation::DeviationTally;
use crate::report::{
    columns_with_units, fmt_sig, format_eigenvalues, CycleInfo, Intervals, Totals,
};
use crate::smoother::Smoother;
use crate::stable::{self, StableOptions, ZeroDynamicsPlan};

/// Samples per block of the run (see [`run`]).
const BLOCK: usize = 4096;

/// The cycle's start time and duration, or why it cannot be simulated.
fn check_cycle(cycle: &Cycle) -> Result<(f64, f64), RunError> {
    let bad_cycle = |reason: String| RunError::InvalidCycle {
        cycle: cycle.name.clone(),
        reason,
    };
    if cycle.time.is_empty() || cycle.time.len() != cycle.speed.len() {
        return Err(bad_cycle(format!(
            "it has {} time stamps and {} speeds (need at least one of each, equally many)",
            cycle.time.len(),
            cycle.speed.len()
        )));
    }
    let t0 = cycle.time[0];
    let duration = cycle.duration();
    if !(t0.is_finite() && duration.is_finite() && duration >= 0.0) {
        return Err(bad_cycle(format!(
            "start time {t0} s and duration {duration} s must be finite, duration ≥ 0"
        )));
    }
    Ok((t0, duration))
}

/// The given η(t_0), checked against the model.
fn check_eta0(
    info: &ModelInfo,
    opts: &SimulationOptions,
) -> Result<Option<Vec<f64>>, SimulateError> {
    let ne = info.n_eta;
    match &opts.eta0 {
        Some(e) if e.len() != ne => Err(SimulateError::InvalidEta0 {
            reason: format!(
                "model `{}` has {ne} internal coordinates, {} values were given",
                info.name,
                e.len()
            ),
        }),
        Some(e) if e.iter().any(|v| !v.is_finite()) => Err(SimulateError::InvalidEta0 {
            reason: format!("values must be finite, got {e:?}"),
        }),
        other => Ok(other.clone()),
    }
}

/// The column names (`t`, `yd_0` … `yd_r`, per signal S `S`, `S_d1` … `S_dr` (contract §5), the input, the
/// states, `eta1` …, the outputs) and the input's index.
fn column_names(info: &ModelInfo) -> (Vec<String>, usize) {
    let r = info.relative_degree;
    let mut columns = Vec::with_capacity(
        2 + r + 1 + info.n_w() + info.n_states() + info.n_eta + info.outputs.len(),
    );
    columns.push("t".to_string());
    columns.extend((0..=r).map(|k| format!("yd_{k}")));
    for s in &info.signals {
        columns.push(s.name.clone());
        columns.extend((1..=r).map(|k| format!("{}_d{k}", s.name)));
    }
    let input_column = columns.len();
    columns.push(info.input.clone());
    columns.extend(info.states.iter().cloned());
    columns.extend((1..=info.n_eta).map(|k| format!("eta{k}")));
    columns.extend(info.outputs.iter().map(|o| o.name.clone()));
    (columns, input_column)
}

/// `width` columns of `stored` entries, reusing `spare`'s buffers, with the grid's times in the first.
fn allocate(mut spare: Vec<Vec<f64>>, width: usize, stored: usize, grid: &Grid) -> Vec<Vec<f64>> {
    spare.truncate(width);
    spare.resize_with(width, Vec::new);
    for column in &mut spare {
        // Fresh columns come zeroed from the allocator without being touched; every entry is overwritten.
        if column.capacity() < stored {
            *column = vec![0.0; stored];
        } else {
            column.resize(stored, 0.0);
        }
    }
    // t_k for the whole grid up front (keeps the division off the per-sample path).
    for (k, t) in spare[0].iter_mut().enumerate() {
        *t = grid.time(k);
    }
    spare
}

/// The per-sample bookkeeping: integrals, input range, bound violations and engine operating points over the
/// reported samples [k_lo, k_hi], the reference's departure from the cycle over the cycle's samples, and the
/// input before t_0.
struct Tally<'c> {
    accumulate: Vec<usize>,
    integrals: Vec<f64>,
    previous: Vec<f64>,
    bounds: [Option<f64>; 2],
    range: [f64; 2],
    violations: Intervals,
    /// Whether the last sample pushed to `violations` was outside the bounds (an interval is open).
    outside: bool,
    /// The time of the reported sample farthest beyond the bounds, and how far beyond.
    farthest: Option<(f64, f64)>,
    before_start: Vec<[f64; 2]>,
    window: (usize, usize),
    k0: usize,
    dt: f64,
    /// The cycle's last sample (k0 + the cycle's steps).
    cycle_end: usize,
    cycle: &'c Cycle,
    deviation: DeviationTally,
    operating: Option<OperatingPointTally>,
    progress: Progress,
}

impl<'c> Tally<'c> {
    fn new<M: InverseModel + ?Sized>(
        model: &M,
        (cycle, steps): (&'c Cycle, usize),
        grid: &Grid,
        window: (usize, usize),
        opts: &SimulationOptions,
    ) -> Tally<'c> {
        let info = model.info();
        let no = info.outputs.len();
        let accumulate: Vec<usize> = (0..no).filter(|&i| info.outputs[i].accumulate).collect();
        Tally {
            integrals: vec![0.0; accumulate.len()],
            previous: vec![0.0; accumulate.len()],
            accumulate,
            bounds: [info.input_min, info.input_max],
            range: [f64::INFINITY, f64::NEG_INFINITY],
            violations: Intervals::default(),
            outside: false,
            farthest: None,
            before_start: Vec::with_capacity(grid.k0),
            window,
            k0: grid.k0,
            dt: grid.dt,
            cycle_end: grid.k0 + steps,
            cycle,
            deviation: DeviationTally::new(model.reference(), grid.dt, cycle.tolerance),
            operating: OperatingPointTally::new(info, window.1 - window.0 + 1)
                .filter(|_| opts.operating_points),
            progress: opts.progress.clone(),
        }
    }

    /// The samples of block `b`, in order: the ones before t_0, then those in the window [k_lo, k_hi] (one
    /// pass per quantity over the block's reported range; every sum in the order of the samples).
    fn record_block(&mut self, b: &Block<'_, '_>) {
        let len = b.time.len();
        // Pre-actuation (t < t_0, and t_0 itself when there is pre-actuation) is summarised on its own.
        if self.k0 > 0 && b.k0 <= self.k0 {
            let last = (self.k0 - b.k0).min(len - 1);
            for i in 0..=last {
                self.before_start.push([b.time[i], b.u[i]]);
            }
        }
        // Samples outside [k_lo, k_hi] are not reported.
        let (k_lo, k_hi) = self.window;
        let (first, end) = (k_lo.max(b.k0), (k_hi + 1).min(b.k0 + len));
        if first >= end {
            return;
        }
        let (i0, i1) = (first - b.k0, end - b.k0);
        // Trapezoidal rule over the grid: ∫ o dt ≈ Σ_k dt·(o_k + o_{k+1})/2, the sum from k_lo on.
        let h = 0.5 * self.dt;
        // The deviation over the samples in [t_0, cycle end].
        let lo = self.k0.max(first).min(end);
        let (d0, d1) = (lo - b.k0, (self.cycle_end + 1).min(end).max(lo) - b.k0);
        self.deviation
            .push_block(self.cycle, &b.time[d0..d1], &b.yd[0][d0..d1]);
        if let Some(op) = &mut self.operating {
            op.extend(b.out, i0..i1);
        }
        for ((acc, prev), &o) in self
            .integrals
            .iter_mut()
            .zip(&mut self.previous)
            .zip(&self.accumulate)
        {
            let column = &b.out[o][i0..i1];
            let mut p = if first > k_lo { *prev } else { column[0] };
            let skip = usize::from(first == k_lo);
            for &v in &column[skip..] {
                *acc += h * (p + v);
                p = v;
            }
            *prev = p;
        }
        self.record_input(&b.time[i0..i1], &b.u[i0..i1]);
    }

    /// The input's range and its bound violations (maximal runs of consecutive samples outside the bounds)
    /// over reported samples.
    fn record_input(&mut self, time: &[f64], u: &[f64]) {
        let [mut lo, mut hi] = self.range;
        for &v in u {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        self.range = [lo, hi];
        let (below, above) = match self.bounds {
            [None, None] => return,
            [l, h] => (l.unwrap_or(f64::NEG_INFINITY), h.unwrap_or(f64::INFINITY)),
        };
        for (&t, &v) in time.iter().zip(u) {
            let outside = v < below || v > above;
            // Pushing an inside sample changes the intervals only when one is open.
            if outside || self.outside {
                self.violations.push(t, outside);
                self.outside = outside;
            }
            let beyond = (below - v).max(v - above);
            let farther = match self.farthest {
                Some((_, b)) => beyond > b,
                None => true,
            };
            if outside && farther {
                self.farthest = Some((t, beyond));
            }
        }
    }
}

/// Split a block's columns after y_d … y_d^(r) and the signals (`rest`: the input, the states, η, the
/// outputs) into a [`Block`] with the times, the y_d columns `yd` and the signal columns `w`.
fn split<'c, 'd>(
    (time, yd, w): (&'c [f64], &'c [&'c [f64]], &'c [&'c [f64]]),
    rest: &'c mut [&'d mut [f64]],
    k0: usize,
    info: &ModelInfo,
) -> Block<'c, 'd> {
    let (n, ne) = (info.n_states(), info.n_eta);
    let (u_col, rest) = rest.split_at_mut(1);
    let (x, rest) = rest.split_at_mut(n);
    let (eta, out) = rest.split_at_mut(ne);
    Block {
        k0,
        time,
        yd,
        w,
        u: &mut *u_col[0],
        x,
        eta,
        out,
    }
}

/// y_d … y_d^(r) of the block [k0, k1) into its columns `cols[1..=r+1]` (after the times in `cols[0]`): from the
/// smoother, or copied from the shared reference when the columns are kept (the result needs them; a run
/// that keeps no series reads the shared reference directly).
fn fill_reference(
    (smoother, shared): (&Smoother, Option<&[Vec<f64>]>),
    grid: &Grid,
    cols: &mut [&mut [f64]],
    (k0, k1): (usize, usize),
    keep: bool,
) {
    let (time, yd) = cols.split_at_mut(1);
    match shared {
        // The reference computed once for all runs on this grid (the same blocks, the same numbers).
        Some(s) if keep => {
            for (c, s) in yd.iter_mut().zip(s) {
                c.copy_from_slice(&s[k0..k1]);
            }
        }
        Some(_) => {}
        None => smoother.eval_grid(time[0], Some(grid.dt), yd),
    }
}

/// The run, block by block. Per block of samples: y_d … y_d^(r) on the grid at once (Smoother::eval_grid,
/// or a shared reference's columns where given, [`fill_reference`]); then the inverse ([`Inverter`]); then
/// the extra outputs (InverseModel::outputs_batch) and the bookkeeping (finiteness, integrals, input range,
/// bounds). With `keep` a block is a view into the result's columns, without it into block-sized scratch
/// columns.
fn run_blocks<M: InverseModel + ?Sized>(
    model: &M,
    (smoother, shared): (&Smoother, Option<super::reference::SharedColumns<'_>>),
    grid: &Grid,
    (inverter, mut direct): (&mut Inverter<'_, M>, Option<&mut DirectSensitivities>),
    tally: &mut Tally<'_>,
    data: &mut [Vec<f64>],
    keep: bool,
) -> Result<(), SimulateError> {
    let info = model.info();
    let samples = grid.samples();
    let mut scratch = if keep {
        Vec::new()
    } else {
        block_scratch(data.len(), BLOCK.min(samples))
    };
    super::map_check::clear();
    let mut k0 = 0;
    while k0 < samples {
        let k1 = (k0 + BLOCK).min(samples);
        let len = k1 - k0;
        let mut cols: Vec<&mut [f64]> = if keep {
            data.iter_mut().map(|c| &mut c[k0..k1]).collect()
        } else {
            scratch.iter_mut().map(|c| &mut c[..len]).collect()
        };
        if !keep {
            for (i, t) in cols[0].iter_mut().enumerate() {
                *t = grid.time(k0 + i);
            }
        }
        let r1 = info.relative_degree + 2;
        let nw = info.n_w();
        let (shared_yd, shared_w) = (shared.map(|s| s.0), shared.map(|s| s.1));
        fill_reference((smoother, shared_yd), grid, &mut cols[..r1], (k0, k1), keep);
        // The smoothed signals on the same grid block, or the shared reference's.
        {
            let (time, w) = cols.split_at_mut(r1);
            match shared_w {
                Some(sw) if keep => {
                    for (c, s) in w[..nw].iter_mut().zip(sw) {
                        c.copy_from_slice(&s[k0..k1]);
                    }
                }
                Some(_) => {}
                None => smoother.eval_signals_grid(time[0], Some(grid.dt), &mut w[..nw]),
            }
        }
        let (head, rest) = cols.split_at_mut(r1 + nw);
        let (head, w_cols) = head.split_at(r1);
        let yd: Vec<&[f64]> = match shared_yd {
            Some(s) if !keep => s.iter().map(|c| &c[k0..k1]).collect(),
            _ => head[1..].iter().map(|c| &**c).collect(),
        };
        let w: Vec<&[f64]> = match shared_w {
            Some(sw) if !keep => sw.iter().map(|c| &c[k0..k1]).collect(),
            _ => w_cols.iter().map(|c| &**c).collect(),
        };
        let mut b = split((&*head[0], &yd, &w), rest, k0, info);
        inverter.fill(&mut b)?;
        {
            let xs: Vec<&[f64]> = b.x.iter().map(|c| &**c).collect();
            model.outputs_batch(&xs, b.w, b.u, b.out);
            if let Some(d) = direct.as_deref_mut() {
                d.block(model, (b.time, b.w, &xs, b.u))?;
            }
        }
        check_finite(model, &b)?;
        super::map_check::check(model, &b)?;
        tally.record_block(&b);
        tally.progress.report(k1, samples);
        k0 = k1;
    }
    SCRATCH.with(|s| *s.borrow_mut() = scratch);
    Ok(())
}

thread_local! {
    /// The block columns of this thread's last summary-only run, reused by the next one (a sweep runs one
    /// variant after another on each thread: fresh columns of this size would be mapped and unmapped by the
    /// allocator, and their pages faulted in, for every variant).
    static SCRATCH: std::cell::RefCell<Vec<Vec<f64>>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// `width` zeroed columns of `len` values, this thread's last ones where there are.
fn block_scratch(width: usize, len: usize) -> Vec<Vec<f64>> {
    let mut cols = SCRATCH.with(|s| std::mem::take(&mut *s.borrow_mut()));
    cols.resize_with(width, Vec::new);
    for c in &mut cols {
        c.clear();
        c.resize(len, 0.0);
    }
    cols
}

/// NaN exactly when an entry of `c` is not finite: Σ c_i·0 (x·0 is NaN for x = ±∞ or NaN, ±0 otherwise),
/// summed in eight independent lanes the compiler vectorises.
fn nan_probe(c: &[f64]) -> f64 {
    let mut lanes = [0.0_f64; 8];
    let chunks = c.chunks_exact(8);
    let rest = chunks.remainder();
    for chunk in chunks {
        for (l, &v) in lanes.iter_mut().zip(chunk) {
            *l += v * 0.0;
        }
    }
    rest.iter()
        .fold(lanes.iter().sum::<f64>(), |s, &v| s + v * 0.0)
}

/// Every sample of the block must be finite: one vectorised probe per column (the input, y_d, the states, the
/// outputs); if one fails, the first sample with a non-finite quantity is the error.
fn check_finite<M: InverseModel + ?Sized>(
    model: &M,
    b: &Block<'_, '_>,
) -> Result<(), SimulateError> {
    let mut probe = nan_probe(b.u);
    for c in b.yd.iter() {
        probe += nan_probe(c);
    }
    for c in b.x.iter().chain(b.out.iter()) {
        probe += nan_probe(c);
    }
    if !probe.is_nan() {
        return Ok(());
    }
    let finite_at = |i: usize| {
        b.u[i].is_finite()
            && b.yd.iter().all(|c| c[i].is_finite())
            && (b.x.iter().chain(b.out.iter())).all(|c| c[i].is_finite())
    };
    let i = (0..b.time.len()).find(|&i| !finite_at(i)).unwrap_or(0);
    let at = |cs: &[&mut [f64]]| cs.iter().map(|c| c[i]).collect::<Vec<f64>>();
    let yd_i: Vec<f64> = b.yd.iter().map(|c| c[i]).collect();
    let w_i: Vec<f64> = b.w.iter().map(|c| c[i]).collect();
    let (x_i, eta_i, outs_i) = (at(b.x), at(b.eta), at(b.out));
    Err(non_finite(
        model,
        b.time[i],
        (&yd_i, &w_i),
        &eta_i,
        b.u[i],
        &x_i,
        &outs_i,
    ))
}

/// y_d … y_d^(r) on the cycle's grid, evaluated over the blocks [`run_blocks`] uses.
fn reference_columns(smoother: &Smoother, grid: &Grid, r: usize) -> Vec<Vec<f64>> {
    grid_columns(grid, r + 1, |t, cols| {
        smoother.eval_grid(t, Some(grid.dt), cols)
    })
}

/// The signals (command line, cycle column or default), to be smoothed with the reference's kernel; a route
/// profile is read along the smoothed reference's distance.
fn resolve_signals(
    info: &invsim_model_api::ModelInfo,
    cycle: &Cycle,
    opts: &SimulationOptions,
) -> Result<Vec<crate::signals::ResolvedSignal>, SimulateError> {
    let along = crate::elevation::Along::Smoothed {
        lookahead: opts.lookahead,
    };
    Ok(crate::signals::resolve_along(info, cycle, &opts.signals, along).map_err(RunError::from)?)
}

/// S_i^(k) of the smoother's signals on the grid, computed over the blocks a run uses (the same numbers).
fn signal_columns(smoother: &Smoother, grid: &Grid, nw: usize) -> Vec<Vec<f64>> {
    grid_columns(grid, nw, |t, cols| {
        smoother.eval_signals_grid(t, Some(grid.dt), cols)
    })
}

/// `n` columns over the whole grid, filled by `eval(times, columns)` block by block (the blocks a run
/// evaluates, so that the samples are bit for bit the run's own).
fn grid_columns(grid: &Grid, n: usize, eval: impl Fn(&[f64], &mut [&mut [f64]])) -> Vec<Vec<f64>> {
    let samples = grid.samples();
    let time: Vec<f64> = (0..samples).map(|k| grid.time(k)).collect();
    let mut out = vec![vec![0.0; samples]; n];
    let mut k0 = 0;
    while k0 < samples {
        let k1 = (k0 + BLOCK).min(samples);
        let mut cols: Vec<&mut [f64]> = out.iter_mut().map(|c| &mut c[k0..k1]).collect();
        eval(&time[k0..k1], &mut cols);
        k0 = k1;
    }
    out
}

/// The smoothed reference of `cycle` for runs of models like `info` (relative degree, signals) with reference
/// map `map`, with `opts`' look-ahead, dt and signal sources (see [`Reference`]).
pub(super) fn reference(
    cycle: &Cycle,
    info: &invsim_model_api::ModelInfo,
    map: invsim_model_api::ReferenceMap,
    opts: &SimulationOptions,
) -> Result<Reference, SimulateError> {
    let r = info.relative_degree;
    opts.validate()?;
    if r + 1 > MAX_DERIVATIVES {
        return Err(SimulateError::RelativeDegreeTooHigh {
            relative_degree: r,
            max: MAX_DERIVATIVES - 1,
        });
    }
    let (t0, duration) = check_cycle(cycle)?;
    let grid = Grid::new(t0, duration, opts.dt)?;
    checks::check_lookahead(opts.lookahead, duration, opts.dt)?;
    let raw = Smoother::new(cycle, opts.lookahead)?;
    let distance_warning = checks::reference_distance_warning(&raw, cycle);
    let signals = resolve_signals(info, cycle, opts)?;
    let smoother = raw
        .with_reference(map)
        .with_signals(crate::signals::smoothers(&signals, opts.lookahead));
    let yd = reference_columns(&smoother, &grid, r);
    let w = signal_columns(&smoother, &grid, info.n_w());
    Ok(Reference {
        smoother,
        distance_warning,
        cycle: cycle.name.clone(),
        lookahead: opts.lookahead,
        grid,
        yd,
        signal_names: info.signals.iter().map(|s| s.name.clone()).collect(),
        signal_inputs: opts.signals.clone(),
        signals,
        w,
    })
}

/// The inverse run; `shared` is a reference computed beforehand, used where it fits the model and options.
pub(super) fn run<M: InverseModel + ?Sized>(
    model: &M,
    cycle: &Cycle,
    opts: &SimulationOptions,
    spare: Vec<Vec<f64>>,
    shared: Option<&Reference>,
) -> Result<SimulationResult, SimulateError> {
    opts.validate()?;
    let info = model.info();
    let r = info.relative_degree;
    if r + 1 > MAX_DERIVATIVES {
        return Err(SimulateError::RelativeDegreeTooHigh {
            relative_degree: r,
            max: MAX_DERIVATIVES - 1,
        });
    }
    let (t0, duration) = check_cycle(cycle)?;
    let mut grid = Grid::new(t0, duration, opts.dt)?;
    checks::check_lookahead(opts.lookahead, duration, opts.dt)?;
    let steps = grid.n;
    let eta0 = check_eta0(info, opts)?;
    let gradient_params = match &opts.gradient {
        Some(names) => {
            let maps: Vec<&invsim_model_api::map::Map> = model.maps().iter().collect();
            Some(crate::gradient::resolve(info, &maps, names).map_err(SimulateError::from)?)
        }
        None => None,
    };
    // Start values of the internal states (`initial =`, `--initial`), used by a causal run.
    let initial = crate::initial::initial_eta(info, &opts.initial).map_err(RunError::from)?;
    let names: Vec<String> = info.signals.iter().map(|s| s.name.clone()).collect();
    let shared = shared.filter(|s| {
        s.fits(opts.lookahead, opts.dt, r, model.reference())
            && s.cycle == cycle.name
            && s.signals_fit(&names, &opts.signals)
    });
    let resolved = match shared {
        Some(s) => s.signals.clone(),
        None => resolve_signals(info, cycle, opts)?,
    };
    let own;
    let (smoother, distance_warning) = match shared {
        Some(s) => (&s.smoother, s.distance_warning.clone()),
        None => {
            let raw = Smoother::new(cycle, opts.lookahead)?;
            let warning = checks::reference_distance_warning(&raw, cycle);
            own = raw
                .with_reference(model.reference())
                .with_signals(crate::signals::smoothers(&resolved, opts.lookahead));
            (&own, warning)
        }
    };

    // Zero dynamics: classified along the reference; unstable ones are inverted stably (non-causally) on a
    // grid extended by pre- and post-actuation (crate::stable), the series reports the cycle's samples
    // [k_lo, k_hi] unless `include_extension` asks for all.
    let stable_opts = StableOptions {
        tol: opts.stable_tol,
        max_pre_actuation: opts.max_pre_actuation,
        lookahead: opts.lookahead,
        causal: opts.causal || eta0.is_some(),
    };
    let zd = stable::plan_run(
        model,
        cycle,
        smoother,
        (t0, grid.time(grid.n), opts.dt),
        &stable_opts,
    )?;
    let mut start_warnings = initial.warnings;
    let eta0 = match (eta0, initial.eta) {
        (Some(e), _) => Some(e),
        (None, Some(e)) if zd.stable.is_none() => Some(e),
        (None, Some(_)) => {
            start_warnings.push(
                "the internal states' initial values are ignored: stable inversion keeps its boundary \
                 conditions (η bounded before the start and after the end of the cycle)"
                    .to_string(),
            );
            None
        }
        (None, None) => None,
    };
    if let Some(st) = &zd.stable {
        let extended = steps as f64 + (st.k_pre + st.k_post) as f64;
        check_samples(extended, extended * opts.dt, opts.dt)?;
        grid.k0 = st.k_pre;
        grid.n += st.k_pre + st.k_post;
    }
    let window = match (&zd.stable, opts.include_extension) {
        (Some(_), false) => (grid.k0, grid.k0 + steps),
        _ => (0, grid.n),
    };

    let (columns, input_column) = column_names(info);
    let keep = opts.keep_series || opts.verify;
    let stored = if keep { grid.samples() } else { 0 };
    crate::grid::check_record(stored, columns.len(), opts.dt)?;
    let mut data = allocate(spare, columns.len(), stored, &grid);
    let wrt = gradient_params.as_ref();
    let mut inverter = Inverter::new(model, (smoother, grid), &zd, (eta0, wrt), opts)?;
    // Without internal states (and grid values) the run's blocks are differentiated as they are solved.
    let mut direct = wrt
        .filter(|w| zd.stable.is_none() && info.n_eta == 0 && w.grid.is_empty())
        .map(|w| DirectSensitivities::new(model, w, grid.dt));
    let mut tally = Tally::new(model, (cycle, steps), &grid, window, opts);
    let yd = (smoother, shared.and_then(|s| s.columns_for(&grid)));
    let solvers = (&mut inverter, direct.as_mut());
    run_blocks(model, yd, &grid, solvers, &mut tally, &mut data, keep)?;
    let along_run = (inverter.gradient_integrals()).or_else(|| direct.map(|d| d.integrals()));
    let gradient = match &gradient_params {
        Some(params) => Some(run_gradient(
            model,
            (smoother, &grid),
            params,
            (&tally, cycle.distance(), along_run),
            (
                zd.stable
                    .as_ref()
                    .map(|run| crate::gradient::StableFigures { run, window }),
                opts,
            ),
        )?),
        None => None,
    };

    let run = Finished {
        smoother,
        start_warnings,
        grid,
        window,
        input_column,
        keep,
        duration,
        distance_warning,
    };
    let mut summary = summarise(model, cycle, opts, &zd, &run, tally, &mut data)?;
    summary.gradient = gradient;
    summary.columns = columns_with_units(info, &columns);
    summary.signals = crate::signals::signal_uses(&resolved, "smoothed");
    Ok(SimulationResult {
        summary,
        columns,
        data,
        input_column,
        input_bounds: [info.input_min, info.input_max],
        reference: smoother.reference(),
        signals: resolved,
    })
}

/// The gradient of the finished run (`tally`: its integrals; `along_run`: their derivatives the run summed as
/// it went, causal or without internal states; `stable`: its stable inversion and reported samples, if non-causal) with respect to
/// `params` (parameters and grid values), along the reference on the run's grid ([`crate::gradient`]).
fn run_gradient<M: InverseModel + ?Sized>(
    model: &M,
    (smoother, grid): (&Smoother, &Grid),
    params: &crate::gradient::Derivatives,
    (tally, distance_m, along_run): (&Tally<'_>, f64, Option<Vec<Vec<f64>>>),
    (stable, opts): (
        Option<crate::gradient::StableFigures<'_>>,
        &SimulationOptions,
    ),
) -> Result<crate::gradient::Gradient, SimulateError> {
    let along = crate::gradient::Along { smoother, grid };
    let figures = crate::gradient::RunFigures {
        accumulate: &tally.accumulate,
        integrals: &tally.integrals,
        distance_m,
        along_run,
        stable,
    };
    crate::gradient::of_run(model, params, &along, figures, opts)
}

/// What the summary needs of the finished run.
struct Finished<'s> {
    /// The reference's smoother with the signals (the replay takes them from it).
    smoother: &'s Smoother,
    /// About the initial values of `initial =` / `--initial`.
    start_warnings: Vec<String>,
    grid: Grid,
    window: (usize, usize),
    input_column: usize,
    keep: bool,
    duration: f64,
    /// The smoothed reference's distance, when it is far from the cycle's.
    distance_warning: Option<String>,
}

/// The warnings about the cycle and the input bounds (`farthest`: the time of the sample farthest beyond them).
fn run_warnings(
    info: &ModelInfo,
    cycle: &Cycle,
    (distance, farthest): (f64, Option<f64>),
    totals: &Totals,
) -> Vec<String> {
    let mut warnings = Vec::new();
    let has_distance = distance > 0.0 && distance.is_finite();
    let per_distance = info.outputs.iter().any(|o| o.accumulate && o.per_distance);
    if per_distance && !has_distance {
        warnings.push(format!(
            "the cycle covers no distance ({distance} m): no per-100-km figures"
        ));
    }
    warnings.extend(crate::signals::grade_warning(info, cycle));
    let violations = &totals.input_bound_violations;
    if !violations.is_empty() {
        let total: f64 = violations.iter().map(|[a, b]| b - a).sum();
        let bounds = format!(
            "[{}, {}]",
            info.input_min.map_or("-inf".to_string(), |b| fmt_sig(b, 6)),
            info.input_max.map_or("inf".to_string(), |b| fmt_sig(b, 6))
        );
        let at = farthest.map_or(String::new(), |t| {
            format!("; the farthest beyond them at t = {} s", fmt_sig(t, 6))
        });
        warnings.push(format!(
            "input {} leaves its bounds {bounds} in {} interval(s), {} s in total (reached {} … {}{at}); not \
             clipped",
            info.input,
            violations.len(),
            fmt_sig(total, 4),
            fmt_sig(totals.input_min, 4),
            fmt_sig(totals.input_max, 4)
        ));
    }
    warnings
}

/// How η was obtained, the pre- and post-actuation (s) and the stable inversion's numbers, with its warnings.
fn inversion_report(
    zd: &ZeroDynamicsPlan,
    ne: usize,
    opts: &SimulationOptions,
    warnings: &mut Vec<String>,
) -> (&'static str, f64, f64, Option<StableInversionStats>) {
    let Some(st) = &zd.stable else {
        return (if ne == 0 { "none" } else { "causal" }, 0.0, 0.0, None);
    };
    let sol = &st.solution;
    if let Some((t, eigs)) = &sol.dichotomy_change {
        warnings.push(format!(
            "stable inversion: at t = {} s the frozen linearisation ∂q/∂η has eigenvalues {}, not {} \
             unstable one(s) as at the ends; the bounded solution was found, but check it (e.g. with \
             --verify)",
            fmt_sig(*t, 6),
            format_eigenvalues(eigs),
            st.plan.unstable
        ));
    }
    if sol.estimated_error > opts.stable_tol {
        warnings.push(format!(
            "stable inversion: the estimated error {} of η exceeds the tolerance {} at the finest node \
             spacing {} s",
            fmt_sig(sol.estimated_error, 2),
            opts.stable_tol,
            fmt_sig(sol.h, 3)
        ));
    }
    let stats = StableInversionStats {
        nodes: sol.nodes(),
        node_spacing_s: sol.h,
        newton_iterations: sol.iterations,
        estimated_error: sol.estimated_error,
        unstable_dimension: st.plan.unstable,
    };
    (
        "stable",
        st.k_pre as f64 * opts.dt,
        st.k_post as f64 * opts.dt,
        Some(stats),
    )
}

/// The summary of a finished run; the verification replays `data`, then the pre- and post-actuation rows
/// leave the series unless they are asked for.
fn summarise<M: InverseModel + ?Sized>(
    model: &M,
    cycle: &Cycle,
    opts: &SimulationOptions,
    zd: &ZeroDynamicsPlan,
    run: &Finished<'_>,
    tally: Tally<'_>,
    data: &mut [Vec<f64>],
) -> Result<Summary, SimulateError> {
    let info = model.info();
    let distance = cycle.distance();
    let before_start = tally.before_start;
    let totals = Totals::new(
        info,
        &tally.accumulate,
        &tally.integrals,
        distance,
        tally.range,
        tally.violations.finish(),
    );
    let farthest = tally.farthest.map(|(t, _)| t);
    let mut warnings = run_warnings(info, cycle, (distance, farthest), &totals);
    warnings.extend(run.distance_warning.clone());
    warnings.extend(run.start_warnings.iter().cloned());
    let (max_abs_tracking_error, rms_tracking_error) = if opts.verify {
        let state_column = run.input_column + 1;
        let (max_abs, rms, verify_warnings) = verify_forward(
            model,
            run.smoother,
            &run.grid,
            data,
            run.input_column,
            state_column,
            opts,
        )?;
        warnings.extend(verify_warnings);
        (Some(max_abs), Some(rms))
    } else {
        (None, None)
    };
    let (k_lo, k_hi) = run.window;
    let reference = tally.deviation.finish();
    warnings.extend(reference.tolerance_band.warning());
    if run.keep && (k_lo, k_hi) != (0, run.grid.n) {
        for column in data.iter_mut() {
            column.truncate(k_hi + 1);
            column.drain(..k_lo);
        }
    }
    let (inversion, pre_actuation_s, post_actuation_s, stable_inversion) =
        inversion_report(zd, info.n_eta, opts, &mut warnings);
    let input_before_start = InputBeforeStart::from_samples(
        &before_start,
        [totals.input_min, totals.input_max],
        opts.dt,
    );
    Ok(Summary {
        headline: Headline::of(info, model.params(), &totals.integrals, distance),
        run: CycleInfo::new(info, cycle, run.duration),
        relative_degree: info.relative_degree,
        engine: opts.engine.clone(),
        samples: k_hi - k_lo + 1,
        lookahead_s: opts.lookahead,
        lookahead_choice: None,
        dt_s: opts.dt,
        reference,
        totals,
        max_abs_tracking_error,
        rms_tracking_error,
        inversion: inversion.to_string(),
        zero_dynamics_class: zd.class,
        zero_dynamics_eigenvalues: zd.eigenvalues.clone(),
        pre_actuation_s,
        post_actuation_s,
        input_before_start,
        stable_inversion,
        engine_operating_points: tally.operating.map(|op| op.finish(info, opts.dt)),
        gradient: None,
        columns: Vec::new(),
        signals: Vec::new(),
        provenance: None,
        warnings,
    })
}

/// The first non-finite quantity of a sample, in column order, as an error; a non-finite input is blamed on a
/// vanishing β(ξ, η) if that is the cause.
fn non_finite<M: InverseModel + ?Sized>(
    model: &M,
    t: f64,
    (yd, w): (&[f64], &[f64]),
    eta: &[f64],
    u: f64,
    x: &[f64],
    outs: &[f64],
) -> SimulateError {
    let info = model.info();
    let error = |quantity: String, value: f64| RunError::NonFinite { t, quantity, value }.into();
    if let Some(i) = yd.iter().position(|v| !v.is_finite()) {
        return error(format!("yd_{i}"), yd[i]);
    }
    if !u.is_finite() {
        let r = info.relative_degree;
        let beta = model.beta(&yd[..r], eta, w);
        if beta == 0.0 || !beta.is_finite() {
            return SimulateError::SingularDecoupling { t, beta };
        }
        return error(info.input.clone(), u);
    }
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        return error(info.states[i].clone(), x[i]);
    }
    match outs.iter().position(|v| !v.is_finite()) {
        Some(i) => error(info.outputs[i].name.clone(), outs[i]),
        None => error("a value".to_string(), f64::NAN),
    }
}
