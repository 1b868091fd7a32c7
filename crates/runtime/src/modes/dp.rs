//! Deterministic dynamic programming of a hybrid's energy management (docs/hybrids.md, "Dynamic
//! programming"; Bellman 1957; the grids and the interpolation of Sundström & Guzzella, "A generic dynamic
//! programming Matlab function", IEEE CCA 2009, DPM). The state is the charge alone, on a grid g_0 … g_{N−1}
//! over the window [SOC(0) − w, SOC(0) + w] (clipped to [0, 1]); the control at sample k is a candidate mode
//! of ECMS's enumeration ([`super::ecms::candidates`]) with, in a mode that decides an input, a value of that
//! input's grid of M values over its bounds. The cost of a control is the fuel energy over [t_k, t_k+1] (the
//! trapezoid of P_fuel at t_k and t_k+1, as the summary integrates it), its SOC change one Runge–Kutta step of
//! the zero dynamics ([`Ecms::interval`]). Backwards from the terminal cost
//!
//!   J_N(soc) = μ |soc − SOC(0)|,
//!   J_k(g_i) = min over feasible controls c of  fuel_k(c, g_i) + J_{k+1}(g_i + Δsoc_k(c, g_i)),
//!
//! J_{k+1} between grid points linear in the charge, beyond the window its edge value plus μ per unit of
//! charge (a soft state constraint: an infinite cost would creep inwards by a cell per step under the
//! interpolation). μ is ten times the battery's chemical energy per unit of charge (read off the controls:
//! ∫P_batt dt / (−Δsoc)), above any plausible marginal fuel cost of the charge (ECMS's s ≈ 2.5 … 4).
//!
//! The forward pass starts at SOC(0) and, at every sample, minimises fuel_k + J_{k+1}(soc_{k+1}) at the
//! run's own charge, the decided input refined between its grid values as ECMS refines it
//! ([`super::minimise`], the feasible set's edge next to the best grid value found by regula falsi on the
//! free input's excess over its bounds); it ends within a grid cell or so of SOC(0). The last samples that decide an input
//! (scanning back from the end) then move their decided value, by bisection on the final charge, until
//! |ΔSOC| ≤ the tolerance; a final charge this cannot reach is an error naming `--strategy dp`.
//!
//! Where the inverse and the zero dynamics do not depend on the charge (hev_p2: constant open-circuit voltage
//! and resistance), every control's fuel and Δsoc are one evaluation per sample; a sample whose evaluations at
//! the window's ends and centre differ is evaluated at every grid point.
//!
//! Internal states besides the charge (an engine's temperature) are not in the grid: they ride along, an
//! approximation. The first pass evaluates the controls with them at their start values; a second pass
//! evaluates them along the first forward run's states (each sample's, its charge the grid's). Every forward
//! run integrates them exactly; only the cost-to-go holds them as a time-varying parameter. A mode whose
//! decided input acts on the fuel and battery powers only through them (a decided throttle on a manifold's
//! pressure) is refused: the grid would not see the decision.

use rayon::prelude::*;

use super::ecms::{Ecms, Eval, Outcome};
use super::minimise::{minimise_probed, Probe};
use super::strategy::DpOptions;
use super::ModalError;

/// Most cells of the cost-to-go (samples × SOC points) and of the controls' tables.
pub(crate) const MAX_CELLS: usize = 25_000_000;
/// Most decided samples the final correction moves.
const MAX_CORRECTED: usize = 200;
/// Most bisection steps of the final correction per sample.
const MAX_BISECT: usize = 80;
/// The terminal penalty μ over the battery's energy per unit of charge.
const PENALTY_FACTOR: f64 = 10.0;

/// A control at a sample: the mode, the decided value, the fuel energy over the interval, the SOC change.
#[derive(Clone, Copy, PartialEq)]
struct Control {
    m: usize,
    d: f64,
    fuel: f64,
    dsoc: f64,
    /// ∫ P_batt dt over the interval, J.
    battery: f64,
}

/// The controls of one sample: one list for every charge, or one per grid point.
enum Table {
    Same(Vec<Control>),
    PerSoc(Vec<Vec<Control>>),
}

impl Table {
    fn at(&self, i: usize) -> &[Control] {
        match self {
            Table::Same(c) => c,
            Table::PerSoc(c) => &c[i],
        }
    }
}

/// The SOC grid and the cost-to-go's extension beyond it.
struct SocGrid {
    lo: f64,
    step: f64,
    n: usize,
    target: f64,
    mu: f64,
}

impl SocGrid {
    fn at(&self, i: usize) -> f64 {
        self.lo + self.step * i as f64
    }

    /// J_N: μ |soc − SOC(0)|.
    fn terminal(&self, soc: f64) -> f64 {
        self.mu * (soc - self.target).abs()
    }

    /// The row `j` (J at the grid points) at `soc`: linear between grid points, beyond the window the edge's
    /// value plus μ per unit of charge.
    fn interp(&self, j: &[f64], soc: f64) -> f64 {
        let x = (soc - self.lo) / self.step;
        if x <= 0.0 {
            return j[0] + self.mu * (-x) * self.step;
        }
        let last = (self.n - 1) as f64;
        if x >= last {
            return j[self.n - 1] + self.mu * (x - last) * self.step;
        }
        let i = (x.floor() as usize).min(self.n - 2);
        let f = x - i as f64;
        (1.0 - f) * j[i] + f * j[i + 1]
    }
}

/// What a DP run gives: the run, the correction slope d(fuel)/d(ΔSOC) from the cost-to-go at SOC(0), the SOC
/// window and μ.
pub(super) struct DpRun {
    pub(super) outcome: Outcome,
    pub(super) slope: f64,
    pub(super) window: [f64; 2],
    pub(super) mu: f64,
}

/// The DP run: the grids' checks, the tables, the backward pass, the forward pass and the final correction.
pub(super) fn dynamic_programming(
    run: &Ecms<'_, '_, '_>,
    opts: &DpOptions,
    x0: &[f64],
    tol: f64,
) -> Result<DpRun, ModalError> {
    check(run, opts)?;
    check_riders(run, x0)?;
    let soc_idx = run.h.soc;
    let soc0 = x0[soc_idx];
    let lo = (soc0 - opts.soc_window).max(0.0);
    let hi = (soc0 + opts.soc_window).min(1.0);
    if hi <= lo || hi.is_nan() || lo.is_nan() {
        return Err(ModalError::Setup(format!(
            "--soc-window {}: the window around SOC(0) = {soc0} within [0, 1] is empty",
            opts.soc_window
        )));
    }
    let mut grid = SocGrid {
        lo,
        step: (hi - lo) / (opts.soc_grid - 1) as f64,
        n: opts.soc_grid,
        target: soc0,
        mu: 0.0,
    };
    // The first pass holds the internal states other than the charge at their start values; with any, a
    // second pass evaluates the controls along the first forward run's states.
    let ns = run.samples.t.len();
    let start = vec![x0.to_vec(); ns];
    let mut pass = one_pass(run, opts, (x0, &start), &mut grid)?;
    if run.other_internal_states() {
        let along = std::mem::take(&mut pass.states);
        pass = one_pass(run, opts, (x0, &along), &mut grid)?;
    }
    let Pass {
        mut policy,
        states,
        first,
        slope,
    } = pass;
    let outcome = if first.delta_soc().abs() <= tol {
        first
    } else {
        correct_final(run, (&mut policy, &states), soc0, (tol, opts.split_grid))?;
        let mut replay = |k: usize, x: &[f64], _on: bool| replay_at(run, k, x, policy[k]);
        run.run_policy(f64::NAN, x0, &[], &mut replay)?
    };
    if outcome.delta_soc().abs() > tol {
        return Err(unreachable(outcome.delta_soc(), tol));
    }
    Ok(DpRun {
        outcome,
        slope,
        window: [lo, hi],
        mu: grid.mu,
    })
}

/// One pass of DP: the controls' tables along `along` (every sample's state, its charge replaced by the
/// grid's), the backward pass and the forward pass from x0.
struct Pass {
    policy: Vec<(usize, f64)>,
    /// The forward run's state at every sample.
    states: Vec<Vec<f64>>,
    first: Outcome,
    slope: f64,
}

fn one_pass(
    run: &Ecms<'_, '_, '_>,
    opts: &DpOptions,
    (x0, along): (&[f64], &[Vec<f64>]),
    grid: &mut SocGrid,
) -> Result<Pass, ModalError> {
    let tables = tables(run, opts, along, grid)?;
    grid.mu = PENALTY_FACTOR * energy_per_charge(&tables);
    let cost = backward(grid, &tables);
    let slope = slope_at_start(grid, &cost[..grid.n]);
    let ns = run.samples.t.len();
    let mut policy: Vec<(usize, f64)> = Vec::with_capacity(ns);
    let mut states: Vec<Vec<f64>> = Vec::with_capacity(ns);
    let mut pick = |k: usize, x: &[f64], _on: bool| {
        let row = (k + 1 < ns).then(|| &cost[(k + 1) * grid.n..(k + 2) * grid.n]);
        let e = choose(run, (k, x), row, (grid, opts.split_grid))?;
        policy.push((e.m, e.d));
        states.push(x.to_vec());
        Ok(e)
    };
    let first = run.run_policy(f64::NAN, x0, &[], &mut pick)?;
    Ok(Pass {
        policy,
        states,
        first,
        slope,
    })
}

/// Samples probed per mode by [`check_riders`].
const PROBES: usize = 20;

/// The internal states besides the charge ride along (docs/hybrids.md, DP): refused where a mode's decided
/// input acts on the cost only through them — its fuel and battery powers at t_k the same at both ends of
/// its bounds at each of the first [`PROBES`] samples the mode is a candidate at (from the start state),
/// as a decided throttle acts only through the manifold's pressure: DP's grid, over the charge alone, would
/// not see the decision.
fn check_riders(run: &Ecms<'_, '_, '_>, x0: &[f64]) -> Result<(), ModalError> {
    for (m, mode) in run.ctx.spec.modes.iter().enumerate() {
        let riders = mode.model.info().eta_states.iter().any(|&j| j != run.h.soc);
        if riders && blind(run, m, x0) {
            return Err(ModalError::Setup(format!(
                "--strategy dp: mode `{}` has internal states besides the charge, and its decided input acts on \
                 the fuel and battery powers only through them; DP's state is the charge alone",
                mode.name
            )));
        }
    }
    Ok(())
}

/// Whether mode m decides an input whose two bounds give the same fuel and battery powers at t_k (within
/// 10⁻¹²) at every one of the first [`PROBES`] samples where the mode is a candidate and has an inverse
/// from x0 (and at one such sample at least).
fn blind(run: &Ecms<'_, '_, '_>, m: usize, x0: &[f64]) -> bool {
    let Some((a, b)) = bounds(run, m) else {
        return false;
    };
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * (1.0 + x.abs().max(y.abs()));
    let pairs: Vec<(Eval, Eval)> = (0..run.samples.t.len())
        .filter(|&k| run.samples.candidates[k].contains(&m))
        .take(PROBES)
        .filter_map(|k| Some((run.eval((m, k), x0, a)?, run.eval((m, k), x0, b)?)))
        .collect();
    !pairs.is_empty()
        && pairs
            .iter()
            .all(|(p, q)| close(p.p_fuel, q.p_fuel) && close(p.p_batt, q.p_batt))
}

/// The grids' sizes: at least 2 points each, and within the budget of cells.
fn check(run: &Ecms<'_, '_, '_>, opts: &DpOptions) -> Result<(), ModalError> {
    if opts.soc_grid < 2 {
        return Err(ModalError::Setup(format!(
            "--soc-grid must be at least 2, got {}",
            opts.soc_grid
        )));
    }
    if opts.split_grid < 2 {
        return Err(ModalError::Setup(format!(
            "--split-grid must be at least 2, got {}",
            opts.split_grid
        )));
    }
    if !(opts.soc_window > 0.0 && opts.soc_window.is_finite()) {
        return Err(ModalError::Setup(format!(
            "--soc-window must be a positive number, got {}",
            opts.soc_window
        )));
    }
    let ns = run.samples.t.len();
    if ns.saturating_mul(opts.soc_grid) > MAX_CELLS {
        return Err(ModalError::Setup(format!(
            "--soc-grid {}: {ns} samples × {} points exceed the budget of {MAX_CELLS} cells of the \
             cost-to-go; take fewer points or a longer --dt",
            opts.soc_grid, opts.soc_grid
        )));
    }
    let controls: usize = run
        .samples
        .candidates
        .iter()
        .map(|c| c.len().saturating_mul(opts.split_grid))
        .fold(0, usize::saturating_add);
    if controls > MAX_CELLS {
        return Err(ModalError::Setup(format!(
            "--split-grid {}: {controls} controls over the run exceed the budget of {MAX_CELLS}",
            opts.split_grid
        )));
    }
    if run.h.start_penalty != 0.0 {
        return Err(ModalError::Setup(
            "--strategy dp: the model's start_penalty is not 0; DP's state is the charge alone (no engine \
             state), so it takes no start penalty yet"
                .into(),
        ));
    }
    Ok(())
}

/// A final charge the correction cannot reach.
fn unreachable(dsoc: f64, tol: f64) -> ModalError {
    ModalError::Setup(format!(
        "--strategy dp: no policy found ends charge-sustaining: the run ends at ΔSOC = {dsoc:+.3e}, beyond the \
         tolerance {tol:.1e} (--soc-tolerance); the final charge is unreachable"
    ))
}

/// The values of mode m's decided input on its grid of `n` (the one value 0 for a mode without one).
fn split_values(run: &Ecms<'_, '_, '_>, m: usize, n: usize) -> Vec<f64> {
    match bounds(run, m) {
        None => vec![0.0],
        Some((a, b)) => (0..n)
            .map(|i| {
                if i + 1 == n {
                    b
                } else {
                    a + (b - a) * i as f64 / (n - 1) as f64
                }
            })
            .collect(),
    }
}

/// The bounds of mode m's decided input, if it has one.
fn bounds(run: &Ecms<'_, '_, '_>, m: usize) -> Option<(f64, f64)> {
    run.ctx.decided[m].first().map(|&(i, _)| {
        let input = &run.ctx.spec.inputs[i];
        (input.min.unwrap_or(0.0), input.max.unwrap_or(0.0))
    })
}

/// The control (m, d) at sample k from the state x: its interval's fuel, battery energy and SOC change, and
/// how far its free input lies beyond its bounds; `None` where the inverse fails.
fn evaluate(
    run: &Ecms<'_, '_, '_>,
    (k, x): (usize, &[f64]),
    (m, d): (usize, f64),
) -> Option<(Control, f64)> {
    let e = run.eval((m, k), x, d)?;
    let end = run.interval(k, &e).ok()?;
    let h = run.samples.t[k + 1] - run.samples.t[k];
    let soc = run.h.soc;
    let c = Control {
        m,
        d,
        fuel: 0.5 * h * (e.p_fuel + end.p_fuel),
        battery: 0.5 * h * (e.p_batt + end.p_batt),
        dsoc: end.x[soc] - e.x[soc],
    };
    let excess = e.excess.max(run.excess(m, end.u));
    (c.fuel.is_finite() && c.dsoc.is_finite()).then_some((c, excess))
}

/// The controls of sample k from the charge `soc`: the feasible ones (free input within its bounds, 10⁻⁹ of
/// its range, at t_k and, the decided value held, at t_k+1), or where none is, the one nearest its bounds.
fn controls(run: &Ecms<'_, '_, '_>, k: usize, x0: &[f64], soc: f64, split: usize) -> Vec<Control> {
    let mut x = x0.to_vec();
    x[run.h.soc] = soc;
    let mut feasible = Vec::new();
    let mut nearest: Option<(f64, Control)> = None;
    for &m in &run.samples.candidates[k] {
        for d in split_values(run, m, split) {
            let Some((c, excess)) = evaluate(run, (k, &x), (m, d)) else {
                continue;
            };
            if excess <= 1e-9 {
                feasible.push(c);
            } else if nearest.is_none_or(|(e, _)| excess < e) {
                nearest = Some((excess, c));
            }
        }
    }
    if feasible.is_empty() {
        feasible.extend(nearest.map(|(_, c)| c));
    }
    feasible
}

/// Whether two lists of controls agree within 10⁻¹² of their values.
fn same(a: &[Control], b: &[Control]) -> bool {
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * (1.0 + x.abs().max(y.abs()));
    a.len() == b.len()
        && a.iter().zip(b).all(|(p, q)| {
            p.m == q.m && p.d == q.d && close(p.fuel, q.fuel) && close(p.dsoc, q.dsoc)
        })
}

/// Every sample's controls (the last sample has none), in parallel over the samples.
fn tables(
    run: &Ecms<'_, '_, '_>,
    opts: &DpOptions,
    along: &[Vec<f64>],
    grid: &SocGrid,
) -> Result<Vec<Table>, ModalError> {
    let ns = run.samples.t.len();
    let probes = [grid.at(0), grid.at(grid.n / 2), grid.at(grid.n - 1)];
    let out: Vec<Table> = (0..ns - 1)
        .into_par_iter()
        .map(|k| {
            let x0 = &along[k];
            let first = controls(run, k, x0, probes[0], opts.split_grid);
            let uniform = probes[1..]
                .iter()
                .all(|&p| same(&first, &controls(run, k, x0, p, opts.split_grid)));
            if uniform {
                Table::Same(first)
            } else {
                Table::PerSoc(
                    (0..grid.n)
                        .map(|i| controls(run, k, x0, grid.at(i), opts.split_grid))
                        .collect(),
                )
            }
        })
        .collect();
    let cells: usize = out
        .iter()
        .map(|t| match t {
            Table::Same(c) => c.len(),
            Table::PerSoc(c) => c.iter().map(Vec::len).sum(),
        })
        .sum();
    if cells > MAX_CELLS {
        return Err(ModalError::Setup(format!(
            "--soc-grid {}: the controls depend on the charge, and {cells} of them exceed the budget of \
             {MAX_CELLS}; take fewer points",
            opts.soc_grid
        )));
    }
    Ok(out)
}

/// The battery's chemical energy per unit of charge, J: the largest |∫P_batt dt / Δsoc| over the controls
/// (1 where no control changes the charge).
fn energy_per_charge(tables: &[Table]) -> f64 {
    let mut best: f64 = 0.0;
    for t in tables {
        let lists: Vec<&[Control]> = match t {
            Table::Same(c) => vec![c],
            Table::PerSoc(c) => c.iter().map(Vec::as_slice).collect(),
        };
        for c in lists.into_iter().flatten() {
            if c.dsoc.abs() > 1e-12 {
                best = best.max((c.battery / c.dsoc).abs());
            }
        }
    }
    if best > 0.0 && best.is_finite() {
        best
    } else {
        1.0
    }
}

/// The cost-to-go J_k(g_i), row k at [k·N, (k+1)·N), by the Bellman recursion backwards from J_N.
fn backward(grid: &SocGrid, tables: &[Table]) -> Vec<f64> {
    let n = grid.n;
    let ns = tables.len() + 1;
    let mut cost = vec![0.0; ns * n];
    for i in 0..n {
        cost[(ns - 1) * n + i] = grid.terminal(grid.at(i));
    }
    for k in (0..ns - 1).rev() {
        let (head, tail) = cost.split_at_mut((k + 1) * n);
        let next = &tail[..n];
        let row = &mut head[k * n..];
        for (i, r) in row.iter_mut().enumerate() {
            let g = grid.at(i);
            *r = tables[k]
                .at(i)
                .iter()
                .map(|c| c.fuel + grid.interp(next, g + c.dsoc))
                .fold(f64::INFINITY, f64::min);
        }
    }
    cost
}

/// d(fuel)/d(ΔSOC) at the start: −∂J_0/∂soc at SOC(0), the cost-to-go's central difference (a run starting
/// δ lower and ending at SOC(0) is one ending δ higher). SAE J1711's correction uses it as its slope.
fn slope_at_start(grid: &SocGrid, row: &[f64]) -> f64 {
    let h = grid.step;
    -(grid.interp(row, grid.target + h) - grid.interp(row, grid.target - h)) / (2.0 * h)
}

/// The forward pass's choice at sample k from state x: the candidate and decided value of least
/// fuel_k + J_{k+1}(soc_{k+1}) (at the last sample, `row` `None`, of least fuel power), the decided value
/// refined between its grid values; where no candidate is feasible, the one nearest its bounds.
fn choose(
    run: &Ecms<'_, '_, '_>,
    (k, x): (usize, &[f64]),
    row: Option<&[f64]>,
    (grid, split): (&SocGrid, usize),
) -> Result<Eval, ModalError> {
    let soc = run.h.soc;
    // (fuel_k + J_k+1, or +∞ beyond the free input's bounds at t_k or t_k+1; the signed margin of that
    // feasibility, ≤ 0 within): the minimiser finds the feasible set's edge as ECMS's does (where the free
    // input reaches a bound, a cost may drop: an engine at zero power burns its idle fuel only).
    let probe = |e: &Eval| -> Probe {
        let end = match row {
            None => None,
            Some(_) => match run.interval(k, e) {
                Ok(end) => Some(end),
                Err(_) => return (f64::INFINITY, f64::NAN),
            },
        };
        let excess = e
            .excess
            .max(end.as_ref().map_or(0.0, |end| run.excess(e.m, end.u)));
        let cost = match (row, end) {
            (Some(next), Some(end)) => {
                let h = run.samples.t[k + 1] - run.samples.t[k];
                0.5 * h * (e.p_fuel + end.p_fuel) + grid.interp(next, end.x[soc])
            }
            _ => e.p_fuel,
        };
        let cost = if excess <= 1e-9 { cost } else { f64::INFINITY };
        (cost, excess - 1e-9)
    };
    let mut best: Option<(f64, Eval)> = None;
    let mut nearest: Option<Eval> = None;
    let mut consider = |e: Eval, c: f64| {
        if nearest.as_ref().is_none_or(|n| e.excess < n.excess) {
            nearest = Some(e.clone());
        }
        if e.excess <= 1e-9 && c.is_finite() && best.as_ref().is_none_or(|(b, _)| c < *b) {
            best = Some((c, e));
        }
    };
    for &m in &run.samples.candidates[k] {
        let d = match bounds(run, m) {
            None => 0.0,
            Some(b) => {
                let mut f = |d: f64| match run.eval((m, k), x, d) {
                    Some(e) if e.excess <= 1e-9 => probe(&e),
                    Some(e) => {
                        let margin = e.excess - 1e-9;
                        consider(e, f64::INFINITY);
                        (f64::INFINITY, margin)
                    }
                    None => (f64::INFINITY, f64::NAN),
                };
                match minimise_probed(&mut f, b, split.max(3)) {
                    Some((d, _)) => d,
                    None => continue,
                }
            }
        };
        if let Some(e) = run.eval((m, k), x, d) {
            let c = probe(&e).0;
            consider(e, c);
        }
    }
    best.map(|(_, e)| e)
        .or(nearest)
        .ok_or_else(|| run.no_candidate(k))
}

/// The policy's control at sample k from state x.
fn replay_at(
    run: &Ecms<'_, '_, '_>,
    k: usize,
    x: &[f64],
    (m, d): (usize, f64),
) -> Result<Eval, ModalError> {
    run.eval((m, k), x, d).ok_or_else(|| {
        run.ctx.err(
            m,
            run.samples.t[k],
            "the DP policy's inverse failed on its replay".into(),
        )
    })
}

/// The final charge of the policy replayed from sample k with the state `xk` (the forward run's there);
/// `None` where a replayed control fails or the first one is infeasible.
fn final_soc(
    run: &Ecms<'_, '_, '_>,
    policy: &[(usize, f64)],
    (k, xk): (usize, &[f64]),
) -> Option<f64> {
    let mut x = xk.to_vec();
    for (j, &(m, d)) in policy.iter().enumerate().take(policy.len() - 1).skip(k) {
        let e = run.eval((m, j), &x, d)?;
        if j == k && e.excess > 1e-9 {
            return None;
        }
        x = run.interval(j, &e).ok()?.x;
    }
    Some(x[run.h.soc])
}

/// The final correction: from the last sample that decides an input backwards, move its decided value (by
/// bisection on the final charge between the present value and a grid value on the other side of the target)
/// until |ΔSOC| ≤ tol; a sample that cannot bridge the gap takes its grid value nearest the target and the
/// search goes on at the previous one, at most [`MAX_CORRECTED`] samples.
fn correct_final(
    run: &Ecms<'_, '_, '_>,
    (policy, states): (&mut [(usize, f64)], &[Vec<f64>]),
    target: f64,
    (tol, split): (f64, usize),
) -> Result<(), ModalError> {
    let ns = policy.len();
    let mut moved = 0;
    for k in (0..ns.saturating_sub(1)).rev() {
        let (m, d_now) = policy[k];
        if bounds(run, m).is_none() {
            continue;
        }
        moved += 1;
        if moved > MAX_CORRECTED {
            break;
        }
        let gap = |p: &mut [(usize, f64)], d: f64| {
            p[k].1 = d;
            final_soc(run, p, (k, &states[k])).map(|s| s - target)
        };
        let Some(g_now) = gap(policy, d_now) else {
            policy[k].1 = d_now;
            continue;
        };
        if g_now.abs() <= tol {
            policy[k].1 = d_now;
            return Ok(());
        }
        let mut other: Option<(f64, f64)> = None;
        let mut closest = (g_now.abs(), d_now);
        for d in split_values(run, m, split) {
            if let Some(g) = gap(policy, d) {
                if g.signum() != g_now.signum() && other.is_none_or(|(_, go)| g.abs() < go.abs()) {
                    other = Some((d, g));
                }
                if g.abs() < closest.0 {
                    closest = (g.abs(), d);
                }
            }
        }
        match other {
            Some((d_far, _)) => {
                let (mut a, mut b) = (d_now, d_far);
                for _ in 0..MAX_BISECT {
                    let mid = 0.5 * (a + b);
                    match gap(policy, mid) {
                        Some(g) if g.abs() <= 0.5 * tol => return Ok(()),
                        Some(g) if g.signum() == g_now.signum() => a = mid,
                        _ => b = mid,
                    }
                }
                policy[k].1 = a;
                return Ok(());
            }
            None => policy[k].1 = closest.1,
        }
    }
    Ok(())
}
