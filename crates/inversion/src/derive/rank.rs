//! The generic rank test behind the choice of η: does the r × n matrix ∂ξ/∂x, restricted to a set of
//! columns, have full row rank r?
//!
//! Two stages, both polynomial in n:
//!
//! 1. **Exact triangular elimination.** A row (or column) with a single entry that is not identically zero
//!    among the remaining columns (rows) is a pivot: if that entry is generically nonzero
//!    ([`invsim_expr::zero_test`]), rank M = 1 + rank(M without that row and column), exactly (Gaussian
//!    elimination with the pivot touches only the pivot's column). This decides structurally triangular
//!    matrices — chains x_i' = f_i(x_i, x_{i+1}), whose ∂ξ/∂x is triangular with entries growing like
//!    binomial coefficients — without rounding, where a singular-value test would call a unit-triangular
//!    matrix singular (its smallest singular value falls exponentially with n).
//! 2. **Numerical rank of the remainder** at probe points: rows scaled to unit norm, full row rank where the
//!    smallest singular value exceeds [`SINGULAR_VALUE_TOL`], at more than half of the points where every
//!    entry is finite.

use invsim_expr::{zero_test, Id, Pool, Symbol};
use std::collections::HashMap;

/// Smallest singular value of the row-scaled remainder below which it counts as rank deficient.
pub const SINGULAR_VALUE_TOL: f64 = 1e-9;

/// ∂ξ/∂x with its zero pattern, its values at the probe points and a cache of generic pivot tests.
pub(super) struct RankTest<'a> {
    pool: &'a mut Pool,
    jac: &'a [Vec<Id>],
    nominal: &'a HashMap<Symbol, f64>,
    /// `pattern[i][j]`: entry (i, j) is not the canonical zero.
    pattern: Vec<Vec<bool>>,
    /// ∂ξ/∂x at each probe point where every entry is finite.
    values: Vec<nalgebra::DMatrix<f64>>,
    /// Is entry (i, j) generically nonzero? (zero_test, cached)
    pivots: HashMap<(usize, usize), bool>,
    /// Number of rank tests run (a bound on the work: at most n + 1 per derivation).
    pub(super) tests: usize,
}

/// `jac` at `points` (those where every entry is finite), or at `wide` where it is finite at none of them.
fn probe_values(
    pool: &Pool,
    jac: &[Vec<Id>],
    points: &[HashMap<Symbol, f64>],
    wide: &[HashMap<Symbol, f64>],
) -> Vec<nalgebra::DMatrix<f64>> {
    let at = |pts: &[HashMap<Symbol, f64>]| -> Vec<nalgebra::DMatrix<f64>> {
        let rows = jac.len();
        let cols = jac.first().map_or(0, Vec::len);
        pts.iter()
            .filter_map(|p| {
                let mut m = nalgebra::DMatrix::<f64>::zeros(rows, cols);
                for (i, row) in jac.iter().enumerate() {
                    for (j, &e) in row.iter().enumerate() {
                        m[(i, j)] = pool.eval(e, p).ok().filter(|v| v.is_finite())?;
                    }
                }
                Some(m)
            })
            .collect()
    };
    let values = at(points);
    if values.is_empty() {
        at(wide)
    } else {
        values
    }
}

impl<'a> RankTest<'a> {
    pub(super) fn new(
        pool: &'a mut Pool,
        jac: &'a [Vec<Id>],
        nominal: &'a HashMap<Symbol, f64>,
        points: &[HashMap<Symbol, f64>],
        wide: &[HashMap<Symbol, f64>],
    ) -> RankTest<'a> {
        let pattern = jac
            .iter()
            .map(|row| row.iter().map(|&e| !pool.is_zero(e)).collect())
            .collect();
        let values = probe_values(pool, jac, points, wide);
        RankTest {
            pool,
            jac,
            nominal,
            pattern,
            values,
            pivots: HashMap::new(),
            tests: 0,
        }
    }

    fn generically_nonzero(&mut self, i: usize, j: usize) -> bool {
        if let Some(&known) = self.pivots.get(&(i, j)) {
            return known;
        }
        let nonzero = !zero_test(self.pool, self.jac[i][j], self.nominal).is_zero();
        self.pivots.insert((i, j), nonzero);
        nonzero
    }

    /// Does ∂ξ/∂x restricted to the columns `cols` have full row rank?
    pub(super) fn full_row_rank(&mut self, cols: &[usize]) -> bool {
        self.tests += 1;
        let mut rows: Vec<usize> = (0..self.jac.len()).collect();
        let mut cols = cols.to_vec();
        while let Some(step) = self.singleton(&rows, &cols) {
            match step {
                Peel::Pivot(i, j) => {
                    rows.retain(|&x| x != i);
                    cols.retain(|&x| x != j);
                }
                Peel::ZeroRow => return false,
                Peel::ZeroColumn(j) => cols.retain(|&x| x != j),
            }
        }
        if rows.is_empty() {
            return true;
        }
        cols.len() >= rows.len() && self.numerically_full_rank(&rows, &cols)
    }

    /// The next step of the exact elimination on the rows × cols remainder, if any.
    fn singleton(&mut self, rows: &[usize], cols: &[usize]) -> Option<Peel> {
        for &i in rows {
            let nz: Vec<usize> = cols
                .iter()
                .copied()
                .filter(|&j| self.pattern[i][j])
                .collect();
            match nz.as_slice() {
                [] => return Some(Peel::ZeroRow),
                [j] if self.generically_nonzero(i, *j) => return Some(Peel::Pivot(i, *j)),
                [_] => return Some(Peel::ZeroRow),
                _ => {}
            }
        }
        for &j in cols {
            let nz: Vec<usize> = rows
                .iter()
                .copied()
                .filter(|&i| self.pattern[i][j])
                .collect();
            match nz.as_slice() {
                [] => return Some(Peel::ZeroColumn(j)),
                [i] if self.generically_nonzero(*i, j) => return Some(Peel::Pivot(*i, j)),
                [_] => return Some(Peel::ZeroColumn(j)),
                _ => {}
            }
        }
        None
    }

    /// Full row rank of the remainder at more than half of the probe points (rows scaled to unit norm,
    /// smallest singular value above [`SINGULAR_VALUE_TOL`]).
    fn numerically_full_rank(&self, rows: &[usize], cols: &[usize]) -> bool {
        let good = self
            .values
            .iter()
            .filter(|v| {
                let mut m = v.select_rows(rows).select_columns(cols);
                for i in 0..m.nrows() {
                    let norm = m.row(i).norm();
                    if norm > 0.0 {
                        let scaled = m.row(i) / norm;
                        m.set_row(i, &scaled);
                    }
                }
                let sv = m.svd(false, false).singular_values;
                sv.iter().copied().fold(f64::INFINITY, f64::min) > SINGULAR_VALUE_TOL
            })
            .count();
        !self.values.is_empty() && good * 2 > self.values.len()
    }
}

/// One step of the exact elimination.
enum Peel {
    /// Row i has its only generically nonzero entry in column j (or column j in row i).
    Pivot(usize, usize),
    /// A row is identically zero on the remaining columns: rank deficient.
    ZeroRow,
    /// Column j is identically zero on the remaining rows: it adds nothing.
    ZeroColumn(usize),
}
