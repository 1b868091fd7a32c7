//! The fast path of a map evaluation: value, slope and curvature of the smoothed basis (orders 0–2 per
//! axis) in fixed-size arrays on the stack, and the 2-D contraction over them.
//!
//! Same formulas as `axis` (`Φ_i = φ_i + Σ_c w_ic [R(a − x_c) − (a − x_c)₊]`, `Φ_i' = φ_i' + Σ_c w_ic
//! [K − H]`, `Φ_i'' = Σ_c w_ic k(a − x_c)` over the corners within `±h` of `a`), with the three corner terms
//! from one table look-up ([`Kernel::corner_excess`], no exponential) and the kink weights precomputed per
//! grid point. It serves axes whose window holds at most `SMALL − 2` corners — every axis with
//! `smooth ≤ 0.5`, where the window `2h` is at most the smallest spacing and holds one corner — and gives
//! the general path's numbers: orders 0 and 1 bit for bit, order 2 within 10⁻¹⁵ of the kernel's peak.

use super::axis::Axis;
use super::extrapolate::Extrapolate;

/// Basis functions per axis the fast path holds.
pub(super) const SMALL: usize = 4;

/// `values[i][n] = Φ_{first + i}^(n)(a)` for `i < count`, `n = 0, 1, 2`.
pub(super) struct SmallBasis {
    pub(super) first: usize,
    pub(super) count: usize,
    pub(super) values: [[f64; 3]; SMALL],
}

impl Axis {
    /// Whether [`Axis::small_basis`] serves this axis.
    pub(super) fn is_small(&self) -> bool {
        self.max_count <= SMALL
    }

    /// The basis at `a` (not NaN) with orders 0–2; the axis must be [`Axis::is_small`].
    #[inline(always)]
    pub(super) fn small_basis(&self, a: f64) -> SmallBasis {
        let g = &self.grid;
        let n = g.len();
        // p: the first grid point ≥ a; region r: x_r < a ≤ x_{r+1}.
        let p = g.partition_point(|&x| x < a);
        let region = p.saturating_sub(1).min(n - 2);
        // Corners strictly inside (a − h, a + h): x_c < a for c < p, x_c ≥ a for c ≥ p.
        let (mut lo, mut hi) = (p, p);
        if let Some(kernel) = self.kernel {
            let h = kernel.half_width();
            while lo > 0 && g[lo - 1] > a - h {
                lo -= 1;
            }
            while hi < n && g[hi] < a + h {
                hi += 1;
            }
        }
        let (mut first, mut last) = (region, region + 1);
        if lo < hi {
            first = first.min(lo.saturating_sub(1));
            last = last.max(hi.min(n - 1));
        }
        let mut b = SmallBasis {
            first,
            count: last - first + 1,
            values: [[0.0; 3]; SMALL],
        };
        self.plain(a, p, 2, |i, m, v| b.values[i - first][m] += v);
        if let Some(kernel) = self.kernel {
            for (c, &xc) in g.iter().enumerate().take(hi).skip(lo) {
                let terms = kernel.corner_excess(a - xc);
                for (k, &w) in self.weights[c].iter().enumerate() {
                    // φ_{c−1+k}; w = 0 off the grid and for the end kinks under `linear`.
                    if w != 0.0 {
                        let row = &mut b.values[c + k - 1 - first];
                        for (r, &t) in row.iter_mut().zip(&terms) {
                            *r += w * t;
                        }
                    }
                }
            }
        }
        b
    }
}

impl Axis {
    /// A 1-D map without a kernel (`interp = "linear"`) at `a` (not NaN): entry `order` (≤ 2) of
    /// `Map::eval_1d_small`, the same sum in the same order (`0 + v_r φ_r^(m) + v_{r+1} φ_{r+1}^(m)` with the
    /// weights and slopes of `Axis::plain`; under `clamp` outside the grid the edge value, slopes 0) without
    /// building the basis.
    #[inline]
    pub(super) fn plain_one(&self, values: &[f64], a: f64, order: usize) -> f64 {
        let g = &self.grid;
        let n = g.len();
        let p = g.partition_point(|&x| x < a);
        let k = p.saturating_sub(1).min(n - 2);
        let clamp = self.extrapolate == Extrapolate::Clamp;
        let (phi0, phi1) = if clamp && p == 0 {
            ([1.0, 0.0], [0.0, 0.0])
        } else if clamp && p == n {
            ([0.0, 0.0], [1.0, 0.0])
        } else {
            let d = g[k + 1] - g[k];
            ([(g[k + 1] - a) / d, -1.0 / d], [(a - g[k]) / d, 1.0 / d])
        };
        let (w0, w1) = match order {
            0 => (phi0[0], phi1[0]),
            1 => (phi0[1], phi1[1]),
            _ => (0.0, 0.0),
        };
        0.0 + values[k] * w0 + values[k + 1] * w1
    }
}

/// `out[p][q] = Σ_ij v_ij Φ_i^(p) Ψ_j^(q)` for `p, q ≤ 2`, in the general path's order of summation (per
/// row `i` first `t_q = Σ_j v_ij Ψ_j^(q)`, then the outer product with `Φ_i^(p)`).
#[inline(always)]
pub(super) fn contract(
    values: &[f64],
    ny: usize,
    bx: &SmallBasis,
    by: &SmallBasis,
) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    for (ki, phi) in bx.values.iter().enumerate().take(bx.count) {
        let row = &values[(bx.first + ki) * ny + by.first..][..by.count];
        let mut t = [0.0; 3];
        for (&v, psi) in row.iter().zip(&by.values) {
            for (tq, &s) in t.iter_mut().zip(psi) {
                *tq += v * s;
            }
        }
        for (o, &ph) in out.iter_mut().zip(phi) {
            for (oq, &tq) in o.iter_mut().zip(&t) {
                *oq += ph * tq;
            }
        }
    }
    out
}
