//! A map's value as a linear function of its grid values: the weights w_ij with
//! `∂^(I+J) M / ∂a^I ∂b^J (a, b) = Σ_ij w_ij v_ij` at one point, for the derivatives of a run with respect to
//! the grid values (`invsim simulate --gradient bsfc[3,4]`).
//!
//! The map is `M(a, b) = Σ_ij v_ij Φ_i(a) Ψ_j(b)` (the module documentation of [`super`]: the smoothed hat
//! functions of `axis`; without a kernel the hat functions themselves), continued outside the grid by the
//! extrapolation rule, which is linear in the values as well. So
//!
//! ```text
//! w_ij = ∂(∂^(I+J) M / ∂a^I ∂b^J)/∂v_ij = Φ_i^(I)(a) Ψ_j^(J)(b)      (1-D: w_i = Φ_i^(K)(a))
//! ```
//!
//! and only the basis functions whose support holds the point are nonzero: two per axis for plain
//! interpolation, those of the grid corners within the kernel's half-width for a smooth map.

use super::axis::Axis;
use super::{scratch_len, with_scratch, Map};

impl Map {
    /// The grid values' weights in `∂^(I+J) M / ∂a^I ∂b^J` at `args` (`orders = [I, J]`; 1-D: `[K, _]`,
    /// `args[0]` alone): `out` is cleared and receives the pairs (flat index into [`Map::values`], weight) of
    /// every grid value whose weight the point's basis holds (zeros included where a basis function vanishes
    /// there), each index once. Σ weight · values[index] is the partial derivative [`Map::partial`] gives.
    /// A NaN argument gives every grid value the weight NaN.
    pub fn weights(&self, args: &[f64], orders: [usize; 2], out: &mut Vec<(usize, f64)>) {
        out.clear();
        if args.iter().take(self.arity()).any(|a| a.is_nan()) {
            out.extend((0..self.values.len()).map(|i| (i, f64::NAN)));
            return;
        }
        match &self.y {
            None => axis_weights(&self.x, args[0], orders[0], |i, w| out.push((i, w))),
            Some(y) => {
                let ny = y.len();
                let mut column = Vec::with_capacity(y.max_count());
                axis_weights(y, args[1], orders[1], |j, w| column.push((j, w)));
                axis_weights(&self.x, args[0], orders[0], |i, wi| {
                    out.extend(column.iter().map(|&(j, wj)| (i * ny + j, wi * wj)));
                });
            }
        }
    }
}

/// `Φ_i^(order)(a)` for every basis function of `axis` nonzero near `a`, as `each(i, value)`.
fn axis_weights(axis: &Axis, a: f64, order: usize, mut each: impl FnMut(usize, f64)) {
    let orders = order + 1;
    with_scratch(scratch_len(axis.max_count(), orders), |scratch| {
        let basis = axis.basis(a, orders, scratch);
        for (k, row) in basis.values.chunks_exact(orders).enumerate() {
            each(basis.first + k, row[order]);
        }
    });
}
