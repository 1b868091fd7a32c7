//! The fixed-width path of one point: value and partials up to order 2 per argument of a 2-D map whose
//! windows hold at most one corner per axis (`batch::fits`), the numbers of one lane of the batched path
//! (`batch.rs`), for `Map::partials2` (generated code's call, Newton's iterations).
//!
//! Per axis the basis `Φ_{c−1+k}^(m) = φ_{c−1+k}^(m) + w_{c−1+k, c} E_m(a − x_c)` (`k, m = 0, 1, 2`, see
//! `batch.rs`), the corner terms `E` from the kernel's 4-lane table ([`Kernel::corner_excess_lanes`], the
//! numbers of [`Kernel::corner_excess`]). Then the contraction
//!
//! ```text
//! T_k = Σ_l v_{c_x−1+k, c_y−1+l} Ψ_l,    res_p = Σ_k Φ_k^(p) T_k,
//! ```
//!
//! with `Ψ_l = [Ψ_l, Ψ_l', Ψ_l'', 0]` and `T_k`, `res_p` vectors over the order `q` of the second argument:
//! lane `q` of each sum adds the terms the scalar sums `t[q] += v_kl Ψ_l^(q)`, `sum[p][q] += Φ_k^(p) t[q]`
//! add, from 0 in the same order, so the same numbers as the batch.
//!
//! [`Kernel::corner_excess_lanes`]: crate::Kernel
//! [`Kernel::corner_excess`]: crate::Kernel::corner_excess

use super::axis::Axis;
use super::batch::lower_bound;
use super::extrapolate::Extrapolate;
use crate::kernel::F4;

/// One axis at one finite point `a`: the padded index `c` of `Φ_0 = φ_{c−1}` and
/// `phi[k][m] = Φ_{c−1+k}^(m)(a)`, by the operations the batched path applies to a lane of a chunk.
#[inline(always)]
fn axis_one<V: F4>(axis: &Axis, a: f64) -> (usize, [[f64; 3]; 3]) {
    let g = axis.grid.as_slice();
    let n = g.len();
    assert!(n >= 2 && axis.weights.len() == n);
    let p = lower_bound(g, a);
    let r = p.saturating_sub(1).min(n - 2);
    let (x0, x1) = (g[r], g[r + 1]);
    let near = a - x0 <= x1 - a;
    let c = r + usize::from(!near);
    let d = x1 - x0;
    // φ_r = (x_{r+1} − a)/d, φ_{r+1} = (a − x_r)/d; under `clamp` outside the grid the edge value, slopes 0.
    let (mut f, mut s) = ([(x1 - a) / d, (a - x0) / d], [-1.0 / d, 1.0 / d]);
    if axis.extrapolate == Extrapolate::Clamp && (p == 0 || p == n) {
        f = if p == 0 { [1.0, 0.0] } else { [0.0, 1.0] };
        s = [0.0, 0.0];
    }
    // φ_r, φ_{r+1} at offsets 1, 2 when c = r, at 0, 1 when c = r + 1.
    let mut phi = if near {
        [[0.0, 0.0, 0.0], [f[0], s[0], 0.0], [f[1], s[1], 0.0]]
    } else {
        [[f[0], s[0], 0.0], [f[1], s[1], 0.0], [0.0, 0.0, 0.0]]
    };
    if let Some(kernel) = axis.kernel {
        let e = kernel.corner_excess_lanes::<V>(a - if near { x0 } else { x1 });
        let w = axis.weights[c];
        for k in 0..3 {
            for m in 0..3 {
                phi[k][m] += w[k] * e[m];
            }
        }
    }
    (c, phi)
}

/// The numbers of `Map::partials2` (`out[3p + q] = ∂^(p+q) M / ∂a^p ∂b^q`) at finite `(a, b)`, `padded` as
/// `batch::pad` lays it out.
#[inline(always)]
fn partials2_with<V: F4>(x: &Axis, y: &Axis, padded: &[f64], a: f64, b: f64) -> [f64; 9] {
    let (cx, phi) = axis_one::<V>(x, a);
    let (cy, psi) = axis_one::<V>(y, b);
    let psi = psi.map(|[v, d, dd]| V::load(&[v, d, dd, 0.0]));
    let w = y.len() + 2;
    let mut sum = [V::splat(0.0); 3];
    for k in 0..3 {
        let v = &padded[(cx + k) * w + cy..][..3];
        let mut t = V::splat(0.0);
        for l in 0..3 {
            t = t.add_mul(psi[l], V::splat(v[l]));
        }
        for p in 0..3 {
            sum[p] = sum[p].add_mul(t, V::splat(phi[k][p]));
        }
    }
    let [s0, s1, s2] = sum.map(F4::to_array);
    [
        s0[0], s0[1], s0[2], s1[0], s1[1], s1[2], s2[0], s2[1], s2[2],
    ]
}

/// [`partials2_with`] compiled for AVX2 (chosen at run time; no fused operations, the portable numbers).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn partials2_avx2(x: &Axis, y: &Axis, padded: &[f64], a: f64, b: f64) -> [f64; 9] {
    partials2_with::<crate::kernel::Avx2>(x, y, padded, a, b)
}

/// [`partials2_with`] built for any processor (what [`partials2_one`] runs without AVX2), for the tests.
#[cfg(test)]
pub(super) fn portable(x: &Axis, y: &Axis, padded: &[f64], a: f64, b: f64) -> [f64; 9] {
    partials2_with::<[f64; 4]>(x, y, padded, a, b)
}

/// `Map::partials2` of a 2-D map that `batch::fits` at finite arguments, with the best instruction set
/// this processor has: the same numbers as the batch and as `Map::eval`.
pub(super) fn partials2_one(x: &Axis, y: &Axis, padded: &[f64], a: f64, b: f64) -> [f64; 9] {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        // SAFETY: the processor has the features `partials2_avx2` is compiled for.
        return unsafe { partials2_avx2(x, y, padded, a, b) };
    }
    partials2_with::<[f64; 4]>(x, y, padded, a, b)
}
