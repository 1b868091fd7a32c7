//! Stage 4 of the batched map path (`batch.rs`): the values around each point's nearest corners gathered
//! (scalar loads, structure of arrays over the chunk's points) and contracted with the two axes' bases
//! (vectorised across the points),
//!
//! ```text
//! ∂^(p+q) M / ∂a^p ∂b^q = Σ_k Φ_k^(p) Σ_l v_{c_x−1+k, c_y−1+l} Ψ_l^(q),   k, l, p, q = 0, 1, 2,
//! ```
//!
//! each sum from 0 in the order of the point-by-point path (`small::contract`, `Map::eval_1d_small`), so the
//! same numbers; and the value alone (`p = q = 0`), the same terms in the same order.

// The sums index several arrays by the point `i` and small fixed orders: the form the vectoriser turns into
// fixed-width loops across points.
#![allow(clippy::needless_range_loop)]

use super::chunk::{AxisChunk, CHUNK};

/// Stage 4, 2-D: `res[3p + q] = Σ_k Φ_k^(p) Σ_l v_kl Ψ_l^(q)` (`small::contract`'s order, from 0).
#[inline(always)]
pub(super) fn contract_2d(
    padded: &[f64],
    ny: usize,
    (x, y): (&AxisChunk, &AxisChunk),
    v: &mut [[[f64; CHUNK]; 3]; 3],
    res: [&mut [f64; CHUNK]; 9],
) {
    let w = ny + 2;
    for i in 0..CHUNK {
        for k in 0..3 {
            let row = &padded[(x.c[i] + k) * w + y.c[i]..][..3];
            [v[k][0][i], v[k][1][i], v[k][2][i]] = [row[0], row[1], row[2]];
        }
    }
    // t[k][q][i] = Σ_l v_kl Ψ_l^(q) (from 0), then each result row res[3p + q] = Σ_k Φ_k^(p) t[k][q] (from 0) in
    // a loop of its own: one store stream per loop over local arrays, which vectorises across the points (nine
    // rows written in one loop do not: the vectoriser cannot tell them apart from its inputs).
    let (phi, psi) = (&x.phi, &y.phi);
    let mut t = [[[0.0; CHUNK]; 3]; 3];
    for k in 0..3 {
        for q in 0..3 {
            for i in 0..CHUNK {
                let mut s = 0.0;
                for l in 0..3 {
                    s += v[k][l][i] * psi[l][q][i];
                }
                t[k][q][i] = s;
            }
        }
    }
    for (pq, row) in res.into_iter().enumerate() {
        let (p, q) = (pq / 3, pq % 3);
        for i in 0..CHUNK {
            let mut s = 0.0;
            for k in 0..3 {
                s += phi[k][p][i] * t[k][q][i];
            }
            row[i] = s;
        }
    }
}

/// Stage 4, 1-D: `res[m] = Σ_k v_k Φ_k^(m)` (`Map::eval_1d_small`'s order, from 0).
#[inline(always)]
pub(super) fn contract_1d(
    padded: &[f64],
    x: &AxisChunk,
    v: &mut [[f64; CHUNK]; 3],
    res: [&mut [f64; CHUNK]; 3],
) {
    for i in 0..CHUNK {
        let vals = &padded[x.c[i]..][..3];
        [v[0][i], v[1][i], v[2][i]] = [vals[0], vals[1], vals[2]];
    }
    let phi = &x.phi;
    for i in 0..CHUNK {
        let mut sum = [0.0; 3];
        for k in 0..3 {
            for m in 0..3 {
                sum[m] += v[k][i] * phi[k][m][i];
            }
        }
        for m in 0..3 {
            res[m][i] = sum[m];
        }
    }
}

/// Stage 4, 2-D, the value alone: `res = Σ_k Φ_k Σ_l v_kl Ψ_l` (entry 0 of [`contract_2d`], its terms in
/// its order).
#[inline(always)]
pub(super) fn contract_2d_value(
    padded: &[f64],
    ny: usize,
    (x, y): (&AxisChunk, &AxisChunk),
    v: &mut [[[f64; CHUNK]; 3]; 3],
    res: &mut [f64; CHUNK],
) {
    let w = ny + 2;
    for i in 0..CHUNK {
        for k in 0..3 {
            let row = &padded[(x.c[i] + k) * w + y.c[i]..][..3];
            [v[k][0][i], v[k][1][i], v[k][2][i]] = [row[0], row[1], row[2]];
        }
    }
    for i in 0..CHUNK {
        let mut sum = 0.0;
        for k in 0..3 {
            let mut t = 0.0;
            for l in 0..3 {
                t += v[k][l][i] * y.phi[l][0][i];
            }
            sum += x.phi[k][0][i] * t;
        }
        res[i] = sum;
    }
}

/// Stage 4, 1-D, the value alone: `res = Σ_k v_k Φ_k` (entry 0 of [`contract_1d`]).
#[inline(always)]
pub(super) fn contract_1d_value(
    padded: &[f64],
    x: &AxisChunk,
    v: &mut [[f64; CHUNK]; 3],
    res: &mut [f64; CHUNK],
) {
    for i in 0..CHUNK {
        let vals = &padded[x.c[i]..][..3];
        [v[0][i], v[1][i], v[2][i]] = [vals[0], vals[1], vals[2]];
    }
    for i in 0..CHUNK {
        let mut sum = 0.0;
        for k in 0..3 {
            sum += v[k][i] * x.phi[k][0][i];
        }
        res[i] = sum;
    }
}
