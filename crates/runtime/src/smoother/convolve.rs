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
    let mut slots = Slots {
        delta: 0.0,
        m,
        jump: vec![0.0; len],
        time: vec![0.0; len],
        marked: vec![false; len],
    };
    for (j, (&tj, &jump)) in times.iter().zip(jumps).enumerate() {
        let (mj, delta) = phase(tj);
        if j == 0 {
            slots.delta = delta;
        } else if delta.to_bits() != slots.delta.to_bits() {
            return None;
        }
        let at = usize::try_from(mj + m as i64).ok().filter(|&at| at < len)?;
        if slots.marked[at] {
            return None;
        }
        (slots.jump[at], slots.time[at], slots.marked[at]) = (jump, tj, true);
    }
    Some(slots)
}

/// The phase table's rows `i = −m..=m` (stored at `i + m`): `c_n(u_i)` for `n ≤ width` in `columns[n]`,
/// then `u_i` in `columns[width + 1]`.
pub(super) struct Rows<'a> {
    pub(super) columns: Vec<&'a [f64]>,
}

/// `out[n][k] += Σ_s J_s c_n(t_k − T_s)` over the marked slots (module docs), `out.len()` orders,
/// `times` the grid.
///
/// `out` must hold the base, none of it −0 (module docs): then a row whose corrections `J_s d_k` all vanish
/// (a grid on whole multiples of the step, such as 1 s on a 1 Hz cycle: `t_k − T_s = u_i` exactly) may
/// drop them, `o + (J c + ±0) = o + J c` bit for bit.
pub(super) fn add(slots: &Slots, rows: &Rows<'_>, times: &[f64], out: &mut [&mut [f64]]) {
    let (m, n) = (slots.m, times.len());
    let width = out.len();
    let u = rows.columns[width + 1];
    let mut jd = vec![0.0; if width > 2 { n } else { 0 }];
    for i in (0..=2 * m).rev() {
        // Sample k takes slot s = k − (i − m), stored at k + 2m − i.
        let at = 2 * m - i;
        let jump = &slots.jump[at..at + n];
        let corrected =
            width > 2 && corrections(&mut jd, times, &slots.time[at..at + n], jump, u[i]);
        for (order, col) in out.iter_mut().enumerate() {
            let c = rows.columns[order][i];
            let col = &mut col[..n];
            match order {
                2.. if corrected => {
                    let dc = rows.columns[order + 1][i];
                    for ((o, &j), &d) in col.iter_mut().zip(jump).zip(&jd) {
                        *o += j * c + d * dc;
                    }
                }
                _ => {
                    for (o, &j) in col.iter_mut().zip(jump) {
                        *o += j * c;
                    }
                }
            }
        }
        if i == m {
            settle_step(slots, times, out);
        }
    }
}

/// `jd[k] = J_s ((t_k − T_s) − u_i)` for one row; whether any is nonzero.
fn corrections(jd: &mut [f64], times: &[f64], t_s: &[f64], jump: &[f64], u_i: f64) -> bool {
    let mut bits = 0;
    for (((d, &t), &ts), &j) in jd.iter_mut().zip(times).zip(t_s).zip(jump) {
        *d = j * ((t - ts) - u_i);
        bits |= d.to_bits() << 1; // the sign bit shifted out: ±0 gives 0
    }
    bits != 0
}

/// Row 0 (`u = −δh`): the table's `H(u)` in `c_1` against the base's "corner passed" (`t_j ≤ t_k`) for the
/// corner on slot `k`, as the scatter settles it.
fn settle_step(slots: &Slots, times: &[f64], out: &mut [&mut [f64]]) {
    let Some(col) = out.get_mut(1) else {
        return;
    };
    let table_passed = -slots.delta >= 0.0;
    let m = slots.m;
    for (k, &t) in times.iter().enumerate() {
        if slots.marked[k + m] {
            let (tj, jump) = (slots.time[k + m], slots.jump[k + m]);
            let passed = t >= tj;
            if table_passed != passed {
                col[k] += if passed { -jump } else { jump };
            }
        }
    }
}
