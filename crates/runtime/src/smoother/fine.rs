//! The reference and the signals of the zero dynamics (a causal run's, a mode's) at any time of an interval,
//! from a fine sub-grid: the smoothed cycle (and each smoothed signal) is evaluated with
//! [`Smoother::eval_grid`] on the grid t_i = t_0 + i·h, h = dt/⌈dt/h_max⌉ (h_max below), block by block,
//! orders 0 … q + 2 (q the highest relative degree of a mode with internal dynamics), and the order k ≤ q
//! between t_i and t_{i+1} is the quintic Hermite interpolant of f = y^(k) from f, f', f'' at both ends
//! (s = (t − t_i)/h):
//!
//! ```text
//! f(t) ≈ f_i H_0(s) + h f'_i H_1(s) + h² f''_i H_2(s) + f_{i+1} H_3(s) + h f'_{i+1} H_4(s) + h² f''_{i+1} H_5(s),
//! H_0 = 1 − 10s³ + 15s⁴ − 6s⁵,  H_1 = s − 6s³ + 8s⁴ − 3s⁵,  H_2 = (s² − 3s³ + 3s⁴ − s⁵)/2,
//! H_3 = 10s³ − 15s⁴ + 6s⁵,      H_4 = −4s³ + 7s⁴ − 3s⁵,     H_5 = (s³ − 2s⁴ + s⁵)/2,
//! |f(t) − interpolant| ≤ max |f^(6)| h⁶ / 46 080          (max |(s(1 − s))³| = 1/64, 6! = 720).
//! ```
//!
//! With the look-ahead a = 5 s, max |k^(m)| is 5.9, 84 and 2 200 for m = 4, 5, 6, so with the slope changes of
//! the built-in cycles (a few m/s³ within ±a) and h ≤ 0.02 s the bound is below 10⁻¹² for y and y' and about
//! 10⁻¹¹ for y''. Since k^(m) scales as a^(−m−1), y^(k+6) h⁶ depends on h/a alone, and so one h_max/a serves
//! every look-ahead; the bound grows with the order, so the step follows the highest order interpolated:
//! h_max = a/250 where y'' is (q ≥ 2), a/125 where y and y' alone are (q ≤ 1, the brake and idle modes of a
//! car whose output is its speed: half the points). Measured against the pointwise [`Smoother::eval`] on NEDC,
//! UDDS and WLTC 3b at a = 5 s and 1 s (the test below): the largest deviation relative to 1 + the order's
//! largest magnitude is 6·10⁻¹² for y'' at a/250, and 4.5·10⁻¹² for y' at a/125 (a/100 would give
//! 1.2·10⁻¹¹). The adaptive integrator's stage times then cost a few multiply-adds each instead of a
//! pointwise evaluation of every corner's kernel terms.
//!
//! A block keeps each cell's interpolant in monomial form, computed once when the block is evaluated: with
//! a = f_i, b = h f'_i, c = h² f''_i, d = f_{i+1}, e = h f'_{i+1}, g = h² f''_{i+1} the sum above is
//!
//! ```text
//! f(t) ≈ c₀ + s(c₁ + s(c₂ + s(c₃ + s(c₄ + s c₅)))),   c₀ = a,  c₁ = b,  c₂ = c/2,
//! c₃ = 10(d − a) − 6b − 4e − (3c − g)/2,   c₄ = 15(a − d) + 8b + 7e + (3c − 2g)/2,
//! c₅ = 6(d − a) − 3(b + e) − (c − g)/2,
//! ```
//!
//! so that a stage time costs five multiply-adds per order and no weights (about 125 instructions against
//! 183 with the weights): the runs that share a table (a sweep's, a model's repeated runs) pay the conversion
//! once. The polynomial is evaluated by Estrin's scheme, (c₀ + s c₁) + s²((c₂ + s c₃) + s²(c₄ + s c₅)): the
//! same operations as Horner's plus s², in a chain of dependent operations half as long (six against ten), which
//! is what a stage time waits for (the integrator's stages follow one another); it rounds differently from
//! Horner's form, by an ulp or so of the interpolant.

use std::sync::{Arc, OnceLock};

use crate::smoother::Smoother;

/// Where the zero dynamics (a causal run's, a mode's with r < n) take the reference y^(0 … r) and the signals
/// at the integrator's stage times ([`SimulationOptions`](crate::SimulationOptions)`::zero_dynamics_reference`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ZeroDynamicsReference {
    /// The quintic Hermite interpolant of the smoothed cycle on a sub-grid of step ≤ a/250 (0.02 s at the
    /// look-ahead a = 5 s; a/125 where no order above y' is interpolated) evaluated block by block (this
    /// file; within 10⁻¹¹ of the pointwise values).
    #[default]
    SubGrid,
    /// The smoother evaluated at every stage time (the reference the sub-grid is tested against).
    Pointwise,
}

/// The largest sub-grid step per second of look-ahead where orders up to q are interpolated: a/125 for
/// q ≤ 1, a/250 for q ≥ 2 (module docs).
fn h_max_per_lookahead(q: usize) -> f64 {
    if q <= 1 {
        0.008
    } else {
        0.004
    }
}
/// Sub-grid intervals per block: block b holds the points b·BLOCK … (b + 1)·BLOCK.
const BLOCK: usize = 128;
/// The most values a table keeps (64 MB, allocated block by block as runs need them: a UDDS or WLTC class
/// 3b at a one-second look-ahead, relative degree 2 and no signal, six coefficients per order and cell,
/// fits); a larger sub-grid (a shorter look-ahead on a longer cycle) computes a block again whenever it is
/// needed anew, as does a table made for one reader (a single run: its integrator moves forward, and a
/// block kept would be written to fresh memory and read once).
const KEPT_MAX: usize = 1 << 23;

/// A block's values, shared by the table and its readers (the values behind the `Arc`'s counts: a read
/// follows one pointer, not two; [`writable`] makes one in place).
type Block = Arc<[f64]>;

/// The sub-grid of a run and its blocks, each evaluated once when first needed and kept (within
/// [`KEPT_MAX`]) for every [`FineReference`] on the table: a run's stages, its gradient's, a sweep's runs on
/// one cycle. The blocks lie at fixed places on the sub-grid, so a value is the same bits whichever run or
/// order of evaluation computed it.
pub(crate) struct FineTable {
    t0: f64,
    h: f64,
    inv_h: f64,
    /// Sub-grid intervals of the run (points 0 … last).
    last: usize,
    /// The last cell a time reads, last − 1 (0 for a run of one point).
    last_cell: usize,
    /// Values per cell, stored·(q + 1)·6.
    cell_len: usize,
    /// Orders held per smoothed quantity (q + 3), and the quantities (the cycle, then each signal).
    orders: usize,
    quantities: usize,
    /// The quantities the cells hold, in order: the cycle (0) and each signal c (c ≥ 1) that is not a
    /// constant; a constant signal's values (c, [S, 0, …, 0] in the orders 0 … q) are written as they are.
    stored: Vec<usize>,
    constants: Vec<(usize, Vec<f64>)>,
    /// Per block, its cells' interpolants (module docs): `[p·cell + (i·(q + 1) + j)·6 + m]` = c_m of order j
    /// of the i-th quantity stored on the block's cell p, cell = stored·(q + 1)·6 (an interpolation reads one
    /// short run of memory). `None`: made for one reader, or over the budget: nothing kept.
    kept: Option<Vec<OnceLock<Block>>>,
}

impl FineTable {
    /// The sub-grid of a run on t_0 + k·dt, k = 0 … n, with look-ahead `lookahead`, for relative degrees up
    /// to `q` and the signals of `smoother`; its blocks kept where `shared` (more than one reader, or a
    /// reader that comes back: a sweep's runs, a gradient's pass, a replay).
    pub(crate) fn new(
        smoother: &Smoother,
        (t0, dt, n): (f64, f64, usize),
        (lookahead, q): (f64, usize),
        shared: bool,
    ) -> FineTable {
        let sub = (dt / (h_max_per_lookahead(q) * lookahead)).ceil().max(1.0) as usize;
        let orders = q + 3;
        let quantities = 1 + smoother.signals().len();
        let (mut stored, mut constants) = (vec![0], Vec::new());
        for (i, signal) in smoother.signals().iter().enumerate() {
            if signal.is_constant() {
                let mut values = vec![0.0; q + 1];
                signal.eval(t0, &mut values);
                constants.push((i + 1, values));
            } else {
                stored.push(i + 1);
            }
        }
        let h = dt / sub as f64;
        let last = n.saturating_mul(sub);
        let blocks = last / BLOCK + 1;
        let cell_len = stored.len() * (q + 1) * 6;
        let values = blocks.saturating_mul(BLOCK).saturating_mul(cell_len);
        FineTable {
            t0,
            h,
            inv_h: 1.0 / h,
            last,
            last_cell: last.saturating_sub(1),
            cell_len,
            orders,
            quantities,
            stored,
            constants,
            kept: (shared && values <= KEPT_MAX)
                .then(|| (0..blocks).map(|_| OnceLock::new()).collect()),
        }
    }

    /// Block b's values, kept or evaluated (`cols`: a buffer for [`FineTable::evaluate`]; `spare`: a block
    /// its reader no longer needs, written over where the table keeps nothing and no one else holds it).
    fn block(&self, smoother: &Smoother, b: usize, cols: &mut Vec<f64>, spare: Block) -> Block {
        match &self.kept {
            Some(kept) => kept[b]
                .get_or_init(|| self.evaluate(smoother, b, cols, None))
                .clone(),
            None => self.evaluate(smoother, b, cols, Some(spare)),
        }
    }

    /// Evaluate block b: the smoothed cycle and signals at its points by [`Smoother::eval_grid`], column by
    /// column into `cols` (`cols[c·len + p]`, every value written), then point by point into `spare` where it
    /// can be written over, else into a new block.
    #[inline(never)]
    fn evaluate(
        &self,
        smoother: &Smoother,
        b: usize,
        cols: &mut Vec<f64>,
        spare: Option<Block>,
    ) -> Block {
        let first = b * BLOCK;
        let end = (first + BLOCK).min(self.last);
        let times: Vec<f64> = (first..=end).map(|p| self.t0 + p as f64 * self.h).collect();
        let (len, stride) = (times.len(), self.quantities * self.orders);
        cols.resize(len * stride, 0.0);
        let (reference, signals) = cols[..len * stride].split_at_mut(self.orders * len);
        let mut refs: Vec<&mut [f64]> = reference.chunks_exact_mut(len).collect();
        smoother.eval_grid(&times, Some(self.h), &mut refs);
        // The signals the cells hold (a constant's columns are not read).
        let per_signal = self.orders * len;
        for &c in &self.stored[1..] {
            let columns = &mut signals[(c - 1) * per_signal..c * per_signal];
            let mut refs: Vec<&mut [f64]> = columns.chunks_exact_mut(len).collect();
            smoother.signals()[c - 1].eval_grid(&times, Some(self.h), &mut refs);
        }
        // Cell p (from point p to p + 1), group g = c·(q + 1) + j: order j of quantity c from its orders j,
        // j + 1, j + 2 at both points (columns c·orders + j + 0 … 2, entries p and p + 1).
        let (interpolated, cell) = (self.interpolated(), self.cell_len);
        let mut block = writable(spare, (len - 1) * cell);
        let Some(coefficients) = Arc::get_mut(&mut block) else {
            return block;
        };
        let (h, h2) = (self.h, self.h * self.h);
        for g in 0..self.stored.len() * interpolated {
            let c = self.stored[g / interpolated];
            let first = (c * self.orders + g % interpolated) * len;
            let (f, rest) = cols[first..first + 3 * len].split_at(len);
            let (d1, d2) = rest.split_at(len);
            for (p, out) in coefficients.chunks_exact_mut(cell).enumerate() {
                let at = (f[p], h * d1[p], h2 * d2[p]);
                let end = (f[p + 1], h * d1[p + 1], h2 * d2[p + 1]);
                out[6 * g..6 * g + 6].copy_from_slice(&monomial(at, end));
            }
        }
        block
    }

    /// Orders interpolated per quantity, q + 1 (the table holds q + 3: each needs the next two).
    fn interpolated(&self) -> usize {
        self.orders - 2
    }
}

/// `spare` where it has `size` values and no other holder, else a new block of `size` zeros (written in place:
/// no copy from a vector).
fn writable(spare: Option<Block>, size: usize) -> Block {
    if let Some(mut s) = spare {
        if s.len() == size && Arc::get_mut(&mut s).is_some() {
            return s;
        }
    }
    (0..size).map(|_| 0.0).collect()
}

/// The smoothed cycle and signals at any time of a run, read from a [`FineTable`] with the two blocks read
/// last in hand (a step's stage times are not in order — DOP853's c_7 = 0.25 follows c_6 = 1/3 — and a
/// rejected step is retried from its start, so a step across a block's end reads both).
#[derive(Clone)]
pub(crate) struct FineReference {
    table: Arc<FineTable>,
    /// The blocks in hand, the latest first: (block, values); `usize::MAX`: none.
    slots: [(usize, Block); 2],
    /// The buffer of a block's evaluation.
    cols: Vec<f64>,
}

impl FineReference {
    /// The sub-grid of a run on t_0 + k·dt, k = 0 … n, with look-ahead `lookahead`, for relative degrees up
    /// to `q`, on a table of its own (its blocks kept where `shared`: [`FineTable::new`]).
    pub(crate) fn new(
        smoother: &Smoother,
        span: (f64, f64, usize),
        lookahead_q: (f64, usize),
        shared: bool,
    ) -> Self {
        Self::on(Arc::new(FineTable::new(
            smoother,
            span,
            lookahead_q,
            shared,
        )))
    }

    /// The table it reads (to share with another reader).
    pub(crate) fn table(&self) -> &Arc<FineTable> {
        &self.table
    }

    /// Reading `table` (shared with every other reader of it).
    pub(crate) fn on(table: Arc<FineTable>) -> Self {
        let none: Block = Arc::from(Vec::new());
        FineReference {
            table,
            slots: [(usize::MAX, none.clone()), (usize::MAX, none)],
            cols: Vec::new(),
        }
    }

    /// y_c^(0 … r) at t into `y` (r = y.len() − 1 ≤ q) and the signals in a mode's layout
    /// [S, S', …, S^(r)] per signal into `w` (empty without signals).
    pub(crate) fn eval(&mut self, smoother: &Smoother, t: f64, y: &mut [f64], w: &mut [f64]) {
        let table = &*self.table;
        // i = ⌊(t − t_0)/h⌋ within 0 … last − 1 (the cast truncates, which is the floor of a positive number;
        // through i64, a single conversion each way).
        let pos = (t - table.t0) * table.inv_h;
        let i = (pos as i64).clamp(0, table.last_cell as i64);
        let x = (t - (table.t0 + i as f64 * table.h)) * table.inv_h;
        let i = i as usize;
        let (b, k) = (i / BLOCK, i % BLOCK);
        if self.slots[0].0 != b {
            self.take_block(smoother, b);
        }
        let len = self.table.cell_len;
        let cell = &self.slots[0].1[k * len..][..len];
        quintic(x, cell, y);
        // Order j of the i-th quantity stored from its group of six (its groups start at i·(q + 1)); signal
        // c's r + 1 values (r + 1 = y.len()) go to w[(c − 1)·(r + 1) …] (what follows the signals in w, a
        // mode's decided inputs, is left as it is).
        let per = y.len();
        let groups = 6 * self.table.interpolated();
        for (i, &c) in self.table.stored.iter().enumerate().skip(1) {
            quintic(x, &cell[i * groups..], &mut w[(c - 1) * per..c * per]);
        }
        for (c, values) in &self.table.constants {
            w[(c - 1) * per..c * per].copy_from_slice(&values[..per]);
        }
    }

    /// Block b in hand as the latest: the other one kept if it is b, else b's values from the table.
    #[cold]
    #[inline(never)]
    fn take_block(&mut self, smoother: &Smoother, b: usize) {
        if self.slots[1].0 == b {
            self.slots.swap(0, 1);
        } else {
            let spare = std::mem::take(&mut self.slots[1].1);
            let values = self.table.block(smoother, b, &mut self.cols, spare);
            self.slots[1] = std::mem::replace(&mut self.slots[0], (b, values));
        }
    }
}

/// out[j] = c₀ + s(c₁ + … + s c₅) of order j's group of six coefficients in `cell` (module docs: Estrin's
/// scheme). The usual lengths (relative degrees 0 … 3) get loops of a fixed length, which the compiler
/// unrolls.
#[inline(always)]
fn quintic(s: f64, cell: &[f64], out: &mut [f64]) {
    match out.len() {
        1 => quintic_n::<1>(s, cell, out),
        2 => quintic_n::<2>(s, cell, out),
        3 => quintic_n::<3>(s, cell, out),
        4 => quintic_n::<4>(s, cell, out),
        _ => {
            for (v, c) in out.iter_mut().zip(cell.chunks_exact(6)) {
                *v = quintic_one(s, c);
            }
        }
    }
}

#[inline(always)]
fn quintic_n<const N: usize>(s: f64, cell: &[f64], out: &mut [f64]) {
    let (cell, out) = (&cell[..6 * N], &mut out[..N]);
    for j in 0..N {
        out[j] = quintic_one(s, &cell[6 * j..6 * j + 6]);
    }
}

#[inline(always)]
fn quintic_one(s: f64, c: &[f64]) -> f64 {
    let s2 = s * s;
    (c[0] + s * c[1]) + s2 * ((c[2] + s * c[3]) + s2 * (c[4] + s * c[5]))
}

/// The monomial coefficients c₀ … c₅ in s = (t − t_i)/h of the quintic Hermite interpolant from
/// (a, b, c) = (f, h f', h² f'') at the cell's start and (d, e, g) at its end (module docs).
#[inline(always)]
fn monomial((a, b, c): (f64, f64, f64), (d, e, g): (f64, f64, f64)) -> [f64; 6] {
    [
        a,
        b,
        0.5 * c,
        10.0 * (d - a) - 6.0 * b - 4.0 * e - 0.5 * (3.0 * c - g),
        15.0 * (a - d) + 8.0 * b + 7.0 * e + 0.5 * (3.0 * c - 2.0 * g),
        6.0 * (d - a) - 3.0 * (b + e) - 0.5 * (c - g),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cycle::Cycle;

    /// The interpolant against the pointwise smoother (cycle and a grade signal, orders 0 … q) at 20 000
    /// times spread over the cycle, on the sub-grid of a run with step `dt` and look-ahead `a` for relative
    /// degrees up to q (≤ 2): the largest deviation of each order relative to 1 + its largest magnitude; and a
    /// constant signal before the grade (which the cells do not hold) equal to the pointwise one bit for bit.
    fn check(cycle: &Cycle, a: f64, dt: f64, q: usize) {
        let golden = 0.5 * (5f64.sqrt() - 1.0);
        let grade: Vec<f64> = cycle
            .time
            .iter()
            .map(|t| 0.02 * (std::f64::consts::TAU * t / 60.0).sin())
            .collect();
        let signal = Smoother::from_samples(&cycle.time, &grade, a);
        let constant = Smoother::from_samples(&cycle.time, &vec![0.013; grade.len()], a);
        let smoother = Smoother::new(cycle, a)
            .expect("smoother")
            .with_signals(vec![constant, signal]);
        assert!(smoother.signals()[0].is_constant() && !smoother.signals()[1].is_constant());
        let (t0, span) = (cycle.time[0], cycle.duration());
        let n = (span / dt).floor() as usize;
        let mut fine = FineReference::new(&smoother, (t0, dt, n), (a, q), false);
        let points = 20_000;
        let (mut worst, mut scale) = ([0.0f64; 6], [0.0f64; 6]);
        for i in 0..points {
            let t = t0 + n as f64 * dt * (i as f64 + golden) / points as f64;
            let (mut y, mut w) = ([0.0; 3], [0.0; 6]);
            fine.eval(&smoother, t, &mut y[..=q], &mut w[..2 * (q + 1)]);
            let (mut ye, mut we) = ([0.0; 3], [0.0; 6]);
            smoother.eval(t, &mut ye[..=q]);
            smoother.eval_signals(t, &mut we[..2 * (q + 1)]);
            assert_eq!(w[..=q], we[..=q], "the constant signal at t = {t}");
            assert_eq!((we[0], we[q]), (0.013, 0.0));
            for k in 0..=q {
                worst[k] = worst[k].max((y[k] - ye[k]).abs());
                scale[k] = scale[k].max(ye[k].abs());
                let (g, e) = (w[q + 1 + k], we[q + 1 + k]);
                worst[3 + k] = worst[3 + k].max((g - e).abs());
                scale[3 + k] = scale[3 + k].max(e.abs());
            }
        }
        for k in (0..6).filter(|k| k % 3 <= q) {
            let rel = worst[k] / (1.0 + scale[k]);
            let name = &cycle.name;
            assert!(rel < 1e-11, "{name} a {a} dt {dt} column {k}: {rel:e}");
        }
    }

    /// The monomial form is the quintic Hermite interpolant (module docs): at s = 0 and 1 it takes f, f', f''
    /// of both ends (the derivatives by s divided by h, h²), and in between it equals the weighted sum
    /// f_i H_0 + h f'_i H_1 + h² f''_i H_2 + f_{i+1} H_3 + h f'_{i+1} H_4 + h² f''_{i+1} H_5 written out.
    #[test]
    fn the_monomial_form_is_the_hermite_interpolant() {
        let (f0, f1, h) = ([1.3, -0.7, 2.9], [0.4, 1.1, -3.2], 0.04);
        let c = monomial(
            (f0[0], h * f0[1], h * h * f0[2]),
            (f1[0], h * f1[1], h * h * f1[2]),
        );
        let p = |s: f64| quintic_one(s, &c);
        let dp =
            |s: f64| c[1] + s * (2.0 * c[2] + s * (3.0 * c[3] + s * (4.0 * c[4] + s * 5.0 * c[5])));
        let ddp = |s: f64| 2.0 * c[2] + s * (6.0 * c[3] + s * (12.0 * c[4] + s * 20.0 * c[5]));
        for (s, f) in [(0.0, f0), (1.0, f1)] {
            let got = [p(s), dp(s) / h, ddp(s) / (h * h)];
            for (g, e) in got.iter().zip(f) {
                assert!(
                    (g - e).abs() < 1e-10 * (1.0 + e.abs()),
                    "s = {s}: {got:?} against {f:?}"
                );
            }
        }
        for s in [0.1f64, 0.37, 0.5, 0.81] {
            let (s2, s3, s4, s5) = (s * s, s * s * s, s.powi(4), s.powi(5));
            let hermite = f0[0] * (1.0 - 10.0 * s3 + 15.0 * s4 - 6.0 * s5)
                + h * f0[1] * (s - 6.0 * s3 + 8.0 * s4 - 3.0 * s5)
                + h * h * f0[2] * (s2 - 3.0 * s3 + 3.0 * s4 - s5) / 2.0
                + f1[0] * (10.0 * s3 - 15.0 * s4 + 6.0 * s5)
                + h * f1[1] * (-4.0 * s3 + 7.0 * s4 - 3.0 * s5)
                + h * h * f1[2] * (s3 - 2.0 * s4 + s5) / 2.0;
            assert!(
                (p(s) - hermite).abs() < 1e-14,
                "s = {s}: {} against {hermite}",
                p(s)
            );
        }
    }

    /// A value read from a table is the same bits whichever reader evaluated its block and in whatever order
    /// the times came, kept or not: readers of one table (a sweep's runs) equal a run on its own.
    #[test]
    fn a_shared_table_reads_as_a_table_of_its_own() {
        let cycle = Cycle::builtin("udds").expect("built-in");
        let smoother = Smoother::new(&cycle, 2.0).expect("smoother");
        let span = (
            cycle.time[0],
            0.5,
            (cycle.duration() / 0.5).floor() as usize,
        );
        let shared = Arc::new(FineTable::new(&smoother, span, (2.0, 1), true));
        let unkept = FineTable::new(&smoother, span, (2.0, 1), false);
        assert!(shared.kept.is_some() && unkept.kept.is_none());
        let (mut a, mut b) = (FineReference::on(shared.clone()), FineReference::on(shared));
        let mut c = FineReference::on(Arc::new(unkept));
        let mut own = FineReference::new(&smoother, span, (2.0, 1), true);
        let times: Vec<f64> = (0..3000).map(|i| 0.4567 * i as f64).collect();
        // b reads the blocks a evaluated, backwards; c evaluates every block anew, in a scattered order.
        let read = |f: &mut FineReference, t: f64| {
            let mut y = [0.0; 2];
            f.eval(&smoother, t, &mut y, &mut []);
            y.map(f64::to_bits)
        };
        let first: Vec<_> = times.iter().map(|&t| read(&mut a, t)).collect();
        for (i, &t) in times.iter().enumerate().rev() {
            assert_eq!(read(&mut b, t), first[i], "t = {t}");
        }
        for i in (0..times.len()).map(|i| (i * 7919) % times.len()) {
            assert_eq!(read(&mut c, times[i]), first[i], "t = {}", times[i]);
            assert_eq!(read(&mut own, times[i]), first[i], "t = {}", times[i]);
        }
    }

    #[test]
    fn sub_grid_interpolant_equals_the_pointwise_smoother() {
        for name in ["nedc", "udds", "wltc3b"] {
            let cycle = Cycle::builtin(name).expect("built-in");
            for dt in [0.01, 0.1, 1.0] {
                for q in [1, 2] {
                    check(&cycle, 5.0, dt, q);
                }
            }
        }
        // A short look-ahead (a finer sub-grid), and a cycle that starts at 12.5 s on a step that does not
        // divide its 1 s samples (every corner at its own phase of the sub-grid).
        let mut udds = Cycle::builtin("udds").expect("built-in");
        check(&udds, 1.0, 1.0, 1);
        check(&udds, 1.0, 1.0, 2);
        for t in udds.time.iter_mut() {
            *t += 12.5;
        }
        check(&udds, 5.0, 0.37, 1);
        check(&udds, 5.0, 0.37, 2);
    }
}
