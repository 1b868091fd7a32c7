//! The smoother's corner terms on a regular grid as one discrete convolution, for cycles whose corners
//! fill the grid (a 1 Hz cycle on a 1 s grid): the same sums as the corner-by-corner scatter of `grid.rs`,
//! in the same order, over whole columns instead of a window per corner.
//!
//! When every corner in range has the same phase `δ` (see `grid.rs`) and a grid slot of its own
//! `m_j = s`, put its slope change on its slot, `J_s = Δs_j`, with `T_s = t_j` and a mark `o_s`. The scatter
//! adds to sample `k` of order `n`, corner after corner (increasing `j`, so increasing slot `s = k − i`,
//! so decreasing row `i`),
//!
//! ```text
//! out_n[k] += J_s c_n(u_i)                                    (n < 2)
//! out_n[k] += J_s c_n(u_i) + J_s ((t_k − T_s) − u_i) c_{n+1}(u_i)   (n ≥ 2),   u_i = (i − δ)·h,
//! ```
//!
//! for the marked slots `s = k − i`, `|i| ≤ m`. Taking the rows from `i = m` down to `−m`, each row a pass
//! over all samples, adds the same terms to each sample in the same order, so the sums are bit for bit the
//! scatter's. An unmarked slot (`J_s = 0`) adds a signed zero, which changes no sum that is not −0, and
//! none is: the base of every order (the cycle's value and slope, stored without −0, and 0) is not −0, and
//! in round-to-nearest `x + y = −0` only for `x = y = −0`. The one discontinuous term, `c_1`
//! at `u = 0`, is settled at row 0 right after that row is added, as the scatter does after each corner.
//! The work is `(2m + 1)·n` multiply-adds per order against the scatter's `(2m + 1)` per corner and order,
//! so this pays where the corners are about as many as the samples ([`worthwhile`]).

/// Whether the convolution is worth it for `corners` corners on `samples` samples of step `h` with the
/// kernel's half-width `a`: the corners are at least half as many as the samples (the scatter's cost per
/// corner is then above the convolution's per sample), and the tables are short.
pub(super) fn worthwhile(corners: usize, samples: usize, a: f64, h: f64) -> bool {
    2 * corners >= samples && samples >= 16 && a / h <= 64.0
}

/// The corners on their slots `s = −m … n + m − 1` (stored at `s + m`): slope change, time and mark.
pub(super) struct Slots {
    /// The common phase δ.
    pub(super) delta: f64,
    m: usize,
    jump: Vec<f64>,
    time: Vec<f64>,
    marked: Vec<bool>,
}

/// The corners `(times, jumps)` on the slots of a grid of `samples` samples with tables of half-length
/// `m`, `phase(t_j) = (m_j, δ_j)`; `None` if two corners differ in phase or share a slot, or a slot is out
/// of range (then the scatter takes them).
pub(super) fn slots(
    (times, jumps): (&[f64], &[f64]),
    samples: usize,
    m: usize,
    phase: impl Fn(f64) -> (i64, f64),
) -> Option<Slots> {
    let len = samples + 2 * m;
    // LANES unmarked slots past the end: a block of lanes reads whole (see `accumulate`).
    let mut slots = Slots {
        delta: 0.0,
        m,
        jump: vec![0.0; len + LANES],
        time: vec![0.0; len + LANES],
        marked: vec![false; len + LANES],
    };
    for (j, (&tj, &jump)) in times.iter().zip(jumps).enumerate() {
        let (mj, delta) = phase(tj);
        if j == 0 {
            slots.delta = delta;
        } else if delta.to_bits() != slots.delta.to_bits() {
            return None;
        }
        let at = mj + m as i64;
        if at < 0 || at as usize >= len || slots.marked[at as usize] {
            return None;
        }
        let at = at as usize;
        (slots.jump[at], slots.time[at], slots.marked[at]) = (jump, tj, true);
    }
    Some(slots)
}

/// The phase table's rows `i = −m..=m` (stored at `i + m`): `c_n(u_i)` for `n ≤ width` in `columns[n]`,
/// then `u_i` in `columns[width + 1]`.
pub(super) struct Rows<'a> {
    pub(super) columns: Vec<&'a [f64]>,
}

/// Samples accumulated together: each keeps its sum in a register over all the rows (the rows' loop
/// carries one addition's latency; the lanes hide it and vectorise).
const LANES: usize = 8;

/// `out[n][k] += Σ_s J_s c_n(t_k − T_s)` over the marked slots (module docs), `out.len()` orders,
/// `times` the grid. `out` must hold the base, none of it −0 (module docs).
pub(super) fn add(slots: &Slots, rows: &Rows<'_>, times: &[f64], out: &mut [&mut [f64]]) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor has the feature `add_avx2` is compiled for.
        return unsafe { x86::add_avx2(slots, rows, times, out) };
    }
    add_lanes(slots, rows, times, out);
}

/// A copy of [`add_lanes`] compiled for AVX2 (four lanes a vector; no fused multiply-adds: the same
/// operations, the same numbers), chosen at run time by [`add`].
#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Rows, Slots};

    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn add_avx2(
        slots: &Slots,
        rows: &Rows<'_>,
        times: &[f64],
        out: &mut [&mut [f64]],
    ) {
        super::add_lanes(slots, rows, times, out);
    }
}

/// [`add`] on whatever vector unit the build targets.
#[inline(always)]
fn add_lanes(slots: &Slots, rows: &Rows<'_>, times: &[f64], out: &mut [&mut [f64]]) {
    let n = times.len();
    let width = out.len();
    let u = rows.columns[width + 1];
    for (order, col) in out.iter_mut().enumerate() {
        let order_rows = OrderRows {
            c: rows.columns[order],
            dc: (order >= 2).then(|| rows.columns[order + 1]),
            u,
            settle: order == 1,
        };
        let col = &mut col[..n];
        let body = n - n % LANES;
        for k0 in (0..body).step_by(LANES) {
            accumulate::<LANES>(slots, &order_rows, times, k0, col);
        }
        for k0 in body..n {
            accumulate::<1>(slots, &order_rows, times, k0, col);
        }
    }
}

/// One order's rows: `c_n(u_i)`, and for the orders n ≥ 2, which take the first-order corrections,
/// `c_{n+1}(u_i)`.
struct OrderRows<'a> {
    c: &'a [f64],
    dc: Option<&'a [f64]>,
    u: &'a [f64],
    /// Order 1: settle the step of `c_1` after row 0.
    settle: bool,
}

/// Samples `k0 … k0 + L − 1` of one order: every row from `i = m` down to `−m` (stored `2m` … 0) added to
/// each sample's sum in turn, the step settled right after row 0, as the scatter orders them.
#[inline(always)]
fn accumulate<const L: usize>(
    slots: &Slots,
    rows: &OrderRows<'_>,
    times: &[f64],
    k0: usize,
    col: &mut [f64],
) {
    let m = slots.m;
    let mut acc = [0.0; L];
    acc.copy_from_slice(&col[k0..k0 + L]);
    // Window w of the slots (stored from k0 + w) serves row i = 2m − w.
    let jump = &slots.jump[k0..k0 + 2 * m + L];
    match rows.dc {
        // Orders ≥ 2: the term and its correction (no step to settle).
        Some(dc) => {
            let t = &times[k0..k0 + L];
            let t_s = &slots.time[k0..k0 + 2 * m + L];
            let rows = rows.c.iter().zip(dc).zip(rows.u).rev();
            for ((((&c, &dc), &u_i), jump), t_s) in rows.zip(jump.windows(L)).zip(t_s.windows(L)) {
                for l in 0..L {
                    let jd = jump[l] * ((t[l] - t_s[l]) - u_i);
                    acc[l] += jump[l] * c + jd * dc;
                }
            }
        }
        None => {
            let (upper, lower) = rows.c.split_at(m); // rows 0 … m − 1 and m … 2m
            let mut windows = jump.windows(L);
            // (The rows first: zip takes from its first iterator first, and must not take a window past them.)
            for (&c, window) in lower.iter().rev().zip(windows.by_ref()) {
                add_row(&mut acc, window, c);
            }
            if rows.settle {
                for (l, a) in acc.iter_mut().enumerate() {
                    *a += step_correction(slots, times[k0 + l], k0 + l + m);
                }
            }
            for (&c, window) in upper.iter().rev().zip(windows) {
                add_row(&mut acc, window, c);
            }
        }
    }
    col[k0..k0 + L].copy_from_slice(&acc);
}

/// `acc[l] += jump[l]·c`.
#[inline(always)]
fn add_row<const L: usize>(acc: &mut [f64; L], jump: &[f64], c: f64) {
    for (a, &j) in acc.iter_mut().zip(jump) {
        *a += j * c;
    }
}

/// Row 0 (`u = −δh`): the table's `H(u)` in `c_1` against the base's "corner passed" (`t_j ≤ t_k`) for the
/// corner on the slot stored at `at` (sample `k` at time `t`), as the scatter settles it: ∓J_s where the two
/// disagree, 0 otherwise (adding 0 changes no sum that is not −0).
fn step_correction(slots: &Slots, t: f64, at: usize) -> f64 {
    if !slots.marked[at] {
        return 0.0;
    }
    let table_passed = -slots.delta >= 0.0;
    let (tj, jump) = (slots.time[at], slots.jump[at]);
    let passed = t >= tj;
    match (table_passed != passed, passed) {
        (false, _) => 0.0,
        (true, true) => -jump,
        (true, false) => jump,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The AVX2 copy and the build's own give the same bits (arbitrary tables: the two compile the same
    /// operations), with and without the first-order corrections, and a tail shorter than the lanes.
    #[test]
    fn vector_copies_agree() {
        let n = 1003;
        let corners: Vec<f64> = (0..n).map(|j| j as f64 * 0.5 + 0.25).collect();
        let jumps: Vec<f64> = (0..n).map(|j| ((j * 37) % 11) as f64 - 5.0).collect();
        let m = 4;
        let phase = |t: f64| ((t / 0.5).floor() as i64, 0.5);
        let slots = slots((&corners, &jumps), n, m, phase).expect("one corner a slot");
        let rows_n = 2 * m + 1;
        let width = 4;
        let table: Vec<Vec<f64>> = (0..=width + 1)
            .map(|c| {
                (0..rows_n)
                    .map(|i| ((c * 7 + i * 3) % 13) as f64 * 0.1 - 0.4)
                    .collect()
            })
            .collect();
        let rows = Rows {
            columns: table.iter().map(|c| &c[..]).collect(),
        };
        let times: Vec<f64> = (0..n)
            .map(|k| k as f64 * 0.5 + 1e-9 * (k % 3) as f64)
            .collect();
        let run = |f: &dyn Fn(&mut [&mut [f64]])| {
            let mut cols = vec![vec![1.0; n]; width];
            let mut views: Vec<&mut [f64]> = cols.iter_mut().map(|c| &mut c[..]).collect();
            f(&mut views);
            cols
        };
        let own = run(&|out| add_lanes(&slots, &rows, &times, out));
        let dispatched = run(&|out| add(&slots, &rows, &times, out));
        for (a, b) in own.iter().flatten().zip(dispatched.iter().flatten()) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }
}
