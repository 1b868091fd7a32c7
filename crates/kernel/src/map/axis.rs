//! One axis of a lookup map: its grid, its extrapolation rule, its kernel, and the smoothed (hat) basis
//! functions `Φ_i = K_h * φ_i` with their derivatives at a point.
//!
//! # The basis
//!
//! The piecewise-linear interpolant on a grid `x_0 < … < x_{n−1}` is `L(a) = Σ_i v_i φ_i(a)` with the hat
//! functions `φ_i` (1 at `x_i`, 0 at the other grid points, linear between them), continued outside the grid
//! by the extrapolation rule: `linear` (and `error`) continue the end segments, so `φ_0, φ_1` (and
//! `φ_{n−2}, φ_{n−1}`) keep the slopes of the first (last) interval; `clamp` holds the edge values, so
//! `φ_0 = 1` left of `x_0` and `φ_{n−1} = 1` right of `x_{n−1}`, all other `φ_i = 0` there.
//!
//! Each `φ_i` is its linear interpolation weight plus a sum of corners: with `s_i(k)` the slope of `φ_i` on
//! region `k` (`k = −1` left of the grid, `k = 0 … n−2` the intervals, `k = n−1` right of the grid) its kink
//! at grid point `x_c` has weight `w_ic = s_i(c) − s_i(c − 1)` (zero at the end points under `linear`).
//! Convolution with the even kernel `k_h` of half-width `h` (`∫ k_h = 1`) leaves linear pieces unchanged and
//! turns a corner `(a − x_c)₊` into the smoothed ramp `R(a − x_c)` (see the drive-cycle smoother), so
//!
//! ```text
//! Φ_i(a)     = φ_i(a)  + Σ_{|a − x_c| < h} w_ic [R(a − x_c) − (a − x_c)₊]
//! Φ_i'(a)    = φ_i'(a) + Σ_{|a − x_c| < h} w_ic [K(a − x_c) − H(a − x_c)]
//! Φ_i^(n)(a) =           Σ_{|a − x_c| < h} w_ic k_h^(n−2)(a − x_c)              (n ≥ 2)
//! ```
//!
//! with `H` the unit step (`H(0) = 0`; `φ_i'` is then the slope of the region `x_k < a ≤ x_{k+1}`, the same
//! convention). Only the corners within `±h` of `a` and the two weights of `a`'s region contribute, so a
//! point costs a binary search and one kernel evaluation per corner in the window; everything is closed-form.
//! Without a kernel (`interp = "linear"`) the same code gives the plain interpolant and its slope.

use crate::Kernel;

use super::extrapolate::Extrapolate;

/// An axis of a map (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Axis {
    pub(crate) grid: Vec<f64>,
    pub(crate) extrapolate: Extrapolate,
    /// `None` for plain (bi)linear interpolation.
    pub(crate) kernel: Option<Kernel>,
    /// Per grid point `c`: the kink weights `w_ic` of `φ_{c−1}, φ_c, φ_{c+1}` (0 where `i` is off the grid).
    pub(crate) weights: Vec<[f64; 3]>,
    /// [`Axis::max_count`], computed once.
    pub(crate) max_count: usize,
}

/// The smoothed basis functions at a point: `Φ_i^(n)` for `i = first … first + count − 1`, `n = 0 … orders−1`,
/// stored `values[(i − first) · orders + n]`.
pub(crate) struct Basis<'a> {
    pub(crate) first: usize,
    pub(crate) count: usize,
    pub(crate) values: &'a [f64],
}

impl Axis {
    /// An axis on a checked grid (strictly increasing, at least two points).
    pub(crate) fn new(grid: Vec<f64>, extrapolate: Extrapolate, kernel: Option<Kernel>) -> Axis {
        let mut axis = Axis {
            grid,
            extrapolate,
            kernel,
            weights: Vec::new(),
            max_count: 0,
        };
        let n = axis.grid.len();
        axis.weights = (0..n)
            .map(|c| {
                std::array::from_fn(|k| match (c + k).checked_sub(1) {
                    Some(i) if i < n => axis.corner_weight(i, c),
                    _ => 0.0,
                })
            })
            .collect();
        axis.max_count = axis.count_bound();
        axis
    }

    /// The number of grid points.
    pub(crate) fn len(&self) -> usize {
        self.grid.len()
    }

    /// An upper bound on the number of basis functions [`Axis::basis`] returns at any point.
    pub(crate) fn max_count(&self) -> usize {
        self.max_count
    }

    fn count_bound(&self) -> usize {
        let n = self.grid.len();
        let Some(kernel) = self.kernel else {
            return 2;
        };
        let h = kernel.half_width();
        // Corners strictly inside a window of width 2h, plus one basis function on each side.
        let mut most = 0;
        let mut hi = 0;
        for lo in 0..n {
            while hi < n && self.grid[hi] - self.grid[lo] < 2.0 * h {
                hi += 1;
            }
            most = most.max(hi - lo);
        }
        (most + 2).min(n).max(2)
    }

    /// Slope of `φ_i` on region `k` (−1 left of the grid, `n − 1` right of it).
    fn slope(&self, i: usize, k: isize) -> f64 {
        let n = self.grid.len() as isize;
        let k = match (k, self.extrapolate) {
            (-1, Extrapolate::Clamp) => return 0.0,
            (k, Extrapolate::Clamp) if k == n - 1 => return 0.0,
            (k, _) => k.clamp(0, n - 2) as usize,
        };
        let d = self.grid[k + 1] - self.grid[k];
        if i == k {
            -1.0 / d
        } else if i == k + 1 {
            1.0 / d
        } else {
            0.0
        }
    }

    /// Weight of the kink of `φ_i` at grid point `c`.
    fn corner_weight(&self, i: usize, c: usize) -> f64 {
        let c = c as isize;
        self.slope(i, c) - self.slope(i, c - 1)
    }

    /// Writes the unsmoothed weights `φ_i(a)`, slopes `φ_i'(a)` of `a`'s region into `add(i, n, value)`;
    /// `p` is the number of grid points below `a` (region r: x_r < a ≤ x_{r+1}; −1 for a ≤ x_0, n − 1 for
    /// a > x_{n−1}).
    #[inline(always)]
    pub(crate) fn plain(
        &self,
        a: f64,
        p: usize,
        orders: usize,
        mut add: impl FnMut(usize, usize, f64),
    ) {
        let g = &self.grid;
        let n = g.len();
        let clamp = self.extrapolate == Extrapolate::Clamp;
        if clamp && p == 0 {
            add(0, 0, 1.0);
            return;
        }
        if clamp && p == n {
            add(n - 1, 0, 1.0);
            return;
        }
        let k = p.saturating_sub(1).min(n - 2);
        let d = g[k + 1] - g[k];
        // φ_k = (x_{k+1} − a)/d, φ_{k+1} = (a − x_k)/d (L(a) = v_k + (v_{k+1} − v_k)(a − x_k)/d).
        add(k, 0, (g[k + 1] - a) / d);
        add(k + 1, 0, (a - g[k]) / d);
        if orders > 1 {
            add(k, 1, -1.0 / d);
            add(k + 1, 1, 1.0 / d);
        }
    }

    /// The basis at `a` with derivatives of orders `0 … orders − 1`; `scratch` must hold at least
    /// `max_count() · orders + orders` values. `a` must not be NaN (callers check).
    pub(crate) fn basis<'s>(&self, a: f64, orders: usize, scratch: &'s mut [f64]) -> Basis<'s> {
        let g = &self.grid;
        let n = g.len();
        let p = g.partition_point(|&x| x < a);
        let region = p.saturating_sub(1).min(n - 2);
        // Corners strictly inside (a − h, a + h).
        let (c_lo, c_hi) = match self.kernel {
            Some(k) => {
                let h = k.half_width();
                (
                    g.partition_point(|&x| x <= a - h),
                    g.partition_point(|&x| x < a + h),
                )
            }
            None => (0, 0),
        };
        let mut first = region;
        let mut last = region + 1;
        if c_lo < c_hi {
            first = first.min(c_lo.saturating_sub(1));
            // The kink at x_c belongs to φ_{c−1}, φ_c and φ_{c+1}.
            last = last.max(c_hi.min(n - 1));
        }
        let count = last - first + 1;
        let (values, corner) = scratch.split_at_mut(count * orders);
        values.fill(0.0);
        self.plain(a, p, orders, |i, m, v| {
            values[(i - first) * orders + m] += v
        });
        if let Some(kernel) = self.kernel {
            for (c, &xc) in g.iter().enumerate().take(c_hi).skip(c_lo) {
                corner_terms(&kernel, a - xc, &mut corner[..orders]);
                for i in c.saturating_sub(1)..=(c + 1).min(n - 1) {
                    let w = self.corner_weight(i, c);
                    if w != 0.0 {
                        let row = &mut values[(i - first) * orders..(i - first + 1) * orders];
                        for (r, &t) in row.iter_mut().zip(corner.iter()) {
                            *r += w * t;
                        }
                    }
                }
            }
        }
        Basis {
            first,
            count,
            values,
        }
    }
}

/// `out[n]` = the smoothed corner's excess over the sharp one: `R(t) − t₊`, `K(t) − H(t)`, `k^(n−2)(t)`;
/// the first three from [`Kernel::corner_excess`] (as the fast path of `small.rs` takes them, so both paths
/// give the same numbers), the higher orders in closed form.
fn corner_terms(kernel: &Kernel, t: f64, out: &mut [f64]) {
    let low = kernel.corner_excess(t);
    if out.len() > 3 {
        kernel.derivatives(t, &mut out[2..]);
    }
    let n = out.len().min(3);
    out[..n].copy_from_slice(&low[..n]);
}
