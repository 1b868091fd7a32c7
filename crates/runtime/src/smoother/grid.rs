//! The smoother's corner terms on a regular grid (Fröberg & Nielsen 2004, eq. 33–35): tables of the kernel
//! terms per grid phase, cached across calls, scattered over each corner's window as multiply-adds.
//!
//! A corner `t_j` contributes `Δs_j c_n(t_k − t_j)` to sample `k` of order `n`, with
//!
//! ```text
//! c_0(u) = R(u) − u₊,   c_1(u) = K(u) − H(u),   c_n(u) = k^(n−2)(u)  (n ≥ 2),   zero for |u| ≥ a.
//! ```
//!
//! On the grid `t_k = t_0 + k·h` write `t_j = t_0 + (m_j + δ_j)·h` with `m_j` a whole number and
//! `δ_j ∈ (−½, ½]` the corner's phase; then `t_k − t_j = (k − m_j − δ_j)·h`, so the terms of corner `j`
//! are the rows `i = k − m_j` of the table `c_n(u_i)`, `u_i = (i − δ)·h`, `|i| ≤ ⌈a/h⌉ + 1`, of its phase.
//! Every corner sharing a phase shares the table — on a 1 Hz cycle with `h` dividing 1 s all corners have
//! phase 0 — and so do later calls on the same grid (the simulation evaluates its grid block by block): a
//! table is built once, with one kernel evaluation per row, and each corner then costs a few multiply-adds
//! per order and sample of its window, over contiguous columns.
//!
//! The grid times are rounded (`t_k` is the double nearest `t_0 + k·h`, a few 10⁻¹⁶·|t| off), and for the
//! highest orders that rounding, amplified by `c_{n+1}/c_n`, reaches 10⁻¹² of the scale: the table
//! therefore holds one order more and the offsets `u_i`, and the scatter evaluates the kernel's derivatives
//! as `c_n(t_k − t_j) = c_n(u_i) + c_{n+1}(u_i)·d_k`, `d_k = (t_k − t_j) − u_i`, exact to `c_{n+2}·d_k²` —
//! the values the sample-by-sample evaluation gets at the same times, to rounding (`y_d` and `y_d'` need
//! no correction).
//! Phases closer than `tol = 8 ε · max(|t|)` (`ε` the double-precision epsilon) share a table, a phase within
//! `tol` of 0 is 0. The one term that is not continuous, `c_1` at `u = 0`, is settled for the row `i = 0`
//! by the sign of `t_k − t_j` itself, as the base `s(t)` is. Tables are kept up to [`CACHE_BUDGET`] values;
//! those not used by the latest call are dropped first, and a corner whose table does not fit is evaluated
//! sample by sample.

use std::sync::{Arc, Mutex, MutexGuard};

use super::convolve;
use crate::kernel::Kernel;

/// Most `f64` values kept in the tables of one smoother (16 MiB).
pub(super) const CACHE_BUDGET: usize = 1 << 21;

/// `terms[n] = c_n(u)` for `n < terms.len()` (see the module docs).
pub(super) fn corner_terms(kernel: &Kernel, u: f64, terms: &mut [f64]) {
    let (k, r) = kernel.integral_and_ramp_offset(u);
    if let Some(c0) = terms.first_mut() {
        *c0 = r;
    }
    if let Some(c1) = terms.get_mut(1) {
        *c1 = k - if u >= 0.0 { 1.0 } else { 0.0 };
    }
    if terms.len() > 2 {
        kernel.derivatives(u, &mut terms[2..]);
    }
}

/// `u_i = (i − δ)·h` and `c_n(u_i)` for `i = −m..=m` and `n ≤ width` (one order more than it serves, for
/// the first-order correction of `scatter`), column by column.
#[derive(Debug)]
struct PhaseTable {
    h: f64,
    delta: f64,
    m: usize,
    /// Orders served (`c_0 … c_{width−1}`; the table holds `c_width` too).
    width: usize,
    /// `width + 1` columns `c_0 … c_width`, then the column of `u_i`.
    values: Vec<f64>,
}

impl PhaseTable {
    fn build(kernel: &Kernel, h: f64, delta: f64, m: usize, width: usize) -> PhaseTable {
        let rows = 2 * m + 1;
        let mut values = vec![0.0; rows * (width + 2)];
        let mut terms = vec![0.0; width + 1];
        for row in 0..rows {
            let u = (row as f64 - m as f64 - delta) * h;
            corner_terms(kernel, u, &mut terms);
            for (n, &c) in terms.iter().enumerate() {
                values[n * rows + row] = c;
            }
            values[(width + 1) * rows + row] = u;
        }
        PhaseTable {
            h,
            delta,
            m,
            width,
            values,
        }
    }

    /// `c_n(u_i)` for `n ≤ width`, or `u_i` for `n = width + 1`.
    fn column(&self, n: usize) -> &[f64] {
        let rows = 2 * self.m + 1;
        &self.values[n * rows..(n + 1) * rows]
    }
}

/// The tables of one smoother, shared by the threads that evaluate it.
#[derive(Debug, Default)]
pub(super) struct GridCache {
    state: Mutex<CacheState>,
}

#[derive(Debug, Default, Clone)]
struct CacheState {
    /// Each table with the number of the last call that used it.
    tables: Vec<(Arc<PhaseTable>, u64)>,
    /// Number of the latest call.
    call: u64,
    /// Values held by `tables`.
    size: usize,
}

impl Clone for GridCache {
    fn clone(&self) -> GridCache {
        GridCache {
            state: Mutex::new(self.lock().clone()),
        }
    }
}

impl GridCache {
    fn lock(&self) -> MutexGuard<'_, CacheState> {
        // A panic elsewhere cannot leave the state inconsistent (every update is a single push or retain).
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Number of tables held (for tests).
    #[cfg(test)]
    pub(super) fn len(&self) -> usize {
        self.lock().tables.len()
    }

    /// Starts a call: returns its number.
    fn begin(&self) -> u64 {
        let mut st = self.lock();
        st.call += 1;
        st.call
    }

    /// The table for step `h`, phase `delta` (within `tol` steps) and at least `width` orders, built if
    /// missing; `None` when it does not fit into the budget.
    fn get(&self, kernel: &Kernel, key: Key, call: u64) -> Option<Arc<PhaseTable>> {
        let m = key.m;
        let size = (2 * m + 1) * (key.width + 2);
        {
            let mut st = self.lock();
            let found = st.tables.iter_mut().find(|(t, _)| {
                t.h == key.h
                    && t.m == m
                    && t.width >= key.width
                    && (t.delta - key.delta).abs() <= key.tol
            });
            if let Some((table, used)) = found {
                *used = call;
                return Some(Arc::clone(table));
            }
            if st.size + size > CACHE_BUDGET {
                // Drop what the latest call has not used.
                st.tables.retain(|(_, used)| *used == call);
                st.size = st.tables.iter().map(|(t, _)| t.values.len()).sum();
            }
            if st.size + size > CACHE_BUDGET {
                return None;
            }
        }
        let table = Arc::new(PhaseTable::build(kernel, key.h, key.delta, m, key.width));
        let mut st = self.lock();
        st.size += size;
        st.tables.push((Arc::clone(&table), call));
        Some(table)
    }
}

/// What identifies a table: step, phase (in steps, with its tolerance), half-length and orders.
#[derive(Clone, Copy)]
struct Key {
    h: f64,
    delta: f64,
    tol: f64,
    m: usize,
    width: usize,
}

/// The corners' part of the smoother on the grid `times`: `out[n][k] += Σ_j jumps[j] · c_n(times[k] − t_j)`.
///
/// `times` must be increasing. When `h` is given and `times[k] = times[0] + k·h` (to rounding; checked),
/// the terms come from the phase tables in `cache`; otherwise, and for a corner whose table does not fit,
/// they are evaluated sample by sample.
pub(super) fn add_corners(
    kernel: &Kernel,
    cache: &GridCache,
    (corners, jumps): (&[f64], &[f64]),
    times: &[f64],
    h: Option<f64>,
    out: &mut [&mut [f64]],
) {
    let (Some(&t0), Some(&t_end)) = (times.first(), times.last()) else {
        return;
    };
    let a = kernel.half_width();
    // Corners whose window (t_j − a, t_j + a) meets [t0, t_end].
    let first = corners.partition_point(|&c| c <= t0 - a);
    let last_corner = corners.partition_point(|&c| c < t_end + a);
    if first >= last_corner {
        return;
    }
    let tol = 8.0 * f64::EPSILON * (t0.abs().max(t_end.abs()) + a);
    let grid = h.filter(|&h| is_regular(times, h, tol) && a / h < 1e9);
    let call = cache.begin();
    let width = out.len();
    let corners = (&corners[first..last_corner], &jumps[first..last_corner]);
    let m_of = |h: f64| (a / h).ceil() as usize + 1;
    let key = |h: f64, delta: f64| Key {
        h,
        delta,
        tol: tol / h,
        m: m_of(h),
        width,
    };
    if let Some(h) = grid.filter(|&h| convolve::worthwhile(corners.0.len(), times.len(), a, h)) {
        let phase = |tj| corner_phase(tj, t0, h, tol / h);
        // Corners filling the grid, one phase: one convolution over whole columns (`convolve.rs`).
        let slots = convolve::slots(corners, times.len(), m_of(h), phase);
        let table = slots
            .as_ref()
            .and_then(|s| cache.get(kernel, key(h, s.delta), call));
        if let (Some(slots), Some(table)) = (slots, table) {
            let mut columns: Vec<&[f64]> = (0..=width).map(|n| table.column(n)).collect();
            columns.push(table.column(table.width + 1));
            convolve::add(&slots, &convolve::Rows { columns }, times, out);
            return;
        }
    }
    let mut terms = vec![0.0; width];
    let mut jd = Vec::new();
    // The table of the previous corner with its phase: corners of one phase (every corner of a 1 Hz cycle
    // on a grid dividing 1 s) take it without the cache's lock. The same key gives the same table.
    let mut last: Option<(f64, Arc<PhaseTable>)> = None;
    for (&tj, &jump) in corners.0.iter().zip(corners.1) {
        let table = grid.and_then(|h| {
            let (mj, delta) = corner_phase(tj, t0, h, tol / h);
            if last
                .as_ref()
                .is_none_or(|(d, _)| d.to_bits() != delta.to_bits())
            {
                last = Some((delta, cache.get(kernel, key(h, delta), call)?));
            }
            Some(mj)
        });
        match (table, &last) {
            (Some(mj), Some((_, table))) => scatter(table, mj, tj, jump, times, &mut jd, out),
            _ => add_pointwise(kernel, tj, jump, times, &mut terms, out),
        }
    }
}

/// The grid index `m_j` and phase `δ_j` of the corner at `tj` on the grid `t0 + k·h`: `(tj − t0)/h = m_j +
/// δ_j` with `δ_j ∈ (−½ + tol, ½ + tol]` (a phase of ½ is one phase whichever way the rounding went), a
/// phase within `tol` (in steps) of 0 taken as 0.
#[inline(always)]
fn corner_phase(tj: f64, t0: f64, h: f64, tol_steps: f64) -> (i64, f64) {
    let steps = (tj - t0) / h;
    let mut mj = nearest_whole(steps);
    if steps - mj < -0.5 + tol_steps {
        mj -= 1.0;
    }
    let delta = Some(steps - mj)
        .filter(|d| d.abs() > tol_steps)
        .unwrap_or(0.0);
    (mj as i64, delta)
}

/// A whole number nearest to `x` (`|x| < 2⁵²`; ties either way, which [`corner_phase`] settles):
/// truncation and one correction, as `f64::round` is a library call on the baseline x86-64 target.
#[inline(always)]
fn nearest_whole(x: f64) -> f64 {
    let t = (x as i64) as f64;
    let frac = x - t; // exact: t holds the leading bits of x
    if frac > 0.5 {
        t + 1.0
    } else if frac < -0.5 {
        t - 1.0
    } else {
        t
    }
}

/// Whether `times[k] = times[0] + k·h` within `tol` for every `k` (and `h` a usable step).
fn is_regular(times: &[f64], h: f64, tol: f64) -> bool {
    if !(h.is_finite() && h > 1e6 * tol) {
        return false;
    }
    let t0 = times[0];
    times
        .iter()
        .enumerate()
        .all(|(k, &t)| (t - (t0 + k as f64 * h)).abs() <= tol)
}

/// `out[n][k] += jump · c_n(times[k] − t_j)` over the samples the table covers, from the table's row
/// `i = k − m_j`, as contiguous multiply-adds. For the kernel's derivatives (`n ≥ 2`) to first order in the
/// grid's rounding `d_k = (times[k] − t_j) − u_i` (a few 10⁻¹⁶ s·|t|): `c_n(u_i + d_k) = c_n(u_i) +
/// c_{n+1}(u_i)·d_k`; `y_d` and `y_d'` take `c_0(u_i)`, `c_1(u_i)` as they are (their slopes `c_1`, `c_2` are
/// at most 1 and `1/(C₀a)`, so the rounding moves them by 10⁻¹⁵ of their scale, and a `K(u) − H(u)` that
/// rounds to 0 stays 0). The step of `c_1` at `u = 0` is decided by the sign of `times[m_j] − t_j` itself.
fn scatter(
    table: &PhaseTable,
    mj: i64,
    tj: f64,
    jump: f64,
    times: &[f64],
    jd: &mut Vec<f64>,
    out: &mut [&mut [f64]],
) {
    let m = table.m as i64;
    let n = times.len() as i64;
    let k_lo = (mj - m).clamp(0, n);
    let k_hi = (mj + m + 1).clamp(0, n);
    if k_lo >= k_hi {
        return;
    }
    let row_lo = (k_lo - (mj - m)) as usize;
    let len = (k_hi - k_lo) as usize;
    let k_lo = k_lo as usize;
    let rows = row_lo..row_lo + len;
    if out.len() > 2 {
        // jd_k = jump · d_k
        jd.clear();
        jd.extend(
            times[k_lo..k_lo + len]
                .iter()
                .zip(&table.column(table.width + 1)[rows.clone()])
                .map(|(&t, &u)| jump * ((t - tj) - u)),
        );
    }
    for (order, col) in out.iter_mut().enumerate() {
        let c = &table.column(order)[rows.clone()];
        let col = &mut col[k_lo..k_lo + len];
        if order < 2 {
            for (o, &c) in col.iter_mut().zip(c) {
                *o += jump * c;
            }
        } else {
            let dc = &table.column(order + 1)[rows.clone()];
            for (((o, &c), &dc), &jd) in col.iter_mut().zip(c).zip(dc).zip(&*jd) {
                *o += jump * c + jd * dc;
            }
        }
    }
    // Row 0 (u = −δh): the table's H(u) against the base's "corner passed" (t_j ≤ t_k).
    if let (Some(col), Ok(k)) = (out.get_mut(1), usize::try_from(mj)) {
        if k < times.len() {
            let table_passed = -table.delta >= 0.0;
            let passed = times[k] >= tj;
            if table_passed != passed {
                col[k] += if passed { -jump } else { jump };
            }
        }
    }
}

/// `out[n][k] += jump · c_n(times[k] − t_j)` for the samples with `|times[k] − t_j| < a`, one kernel
/// evaluation each.
fn add_pointwise(
    kernel: &Kernel,
    tj: f64,
    jump: f64,
    times: &[f64],
    terms: &mut [f64],
    out: &mut [&mut [f64]],
) {
    let a = kernel.half_width();
    let lo = times.partition_point(|&t| t <= tj - a);
    let hi = times.partition_point(|&t| t < tj + a);
    for k in lo..hi {
        corner_terms(kernel, times[k] - tj, terms);
        for (col, &c) in out.iter_mut().zip(terms.iter()) {
            col[k] += jump * c;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::nearest_whole;

    /// `nearest_whole` is `f64::round` away from ties, and a tie goes to one of its two neighbours.
    #[test]
    fn nearest_whole_rounds() {
        for i in -4000..4000 {
            let probes = [
                i as f64 * 0.37 + 1e-3,
                -(i as f64) * 1.13,
                i as f64 * 1e6 + 0.4999,
            ];
            for x in probes.into_iter().filter(|x| (x - x.trunc()).abs() != 0.5) {
                assert_eq!(nearest_whole(x), x.round(), "x = {x}");
            }
            let tie = i as f64 + 0.5;
            let r = nearest_whole(tie);
            assert!(r == tie - 0.5 || r == tie + 0.5, "tie {tie} -> {r}");
        }
    }
}
