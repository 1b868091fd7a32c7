//! Batched evaluation: the value and every partial derivative up to order 2 per argument of a map at many
//! points at once ([`Map::partials2_batch`]), the same numbers as [`Map::partials2`] point by point.
//!
//! # Fixed-width basis
//!
//! On an axis whose kernel window `2h` is at most its smallest spacing (`smooth ≤ 0.5`; `Axis::max_count`
//! ≤ 3), at most one corner lies strictly inside `(a − h, a + h)`, and it can only be the grid point `x_c`
//! nearest `a` among the two ends `x_r, x_{r+1}` of `a`'s region `r` (`x_r < a ≤ x_{r+1}`, clamped to the
//! grid's end intervals). The corner at `x_c` touches `φ_{c−1}, φ_c, φ_{c+1}` and the region's weights are
//! those of `φ_r, φ_{r+1}`, both among these three, so the basis at `a` is always the three functions
//! `Φ_{c−1}, Φ_c, Φ_{c+1}` (orders 0–2):
//!
//! ```text
//! Φ_{c−1+k}^(m)(a) = φ_{c−1+k}^(m)(a) + w_{c−1+k, c} E_m(a − x_c),   k = 0, 1, 2,
//! E = [R(t) − t₊, K(t) − H(t), k_h(t)]   (zero outside the window: `Kernel::corner_excess`)
//! ```
//!
//! and `∂^(p+q) M / ∂a^p ∂b^q = Σ_kl v_{c_x−1+k, c_y−1+l} Φ_k^(p) Ψ_l^(q)`: a fixed 3 × 3 contraction, with
//! the values padded by one row and column of zeros on each side for the indices `−1` and `n`. Every term
//! the point-by-point path (`small.rs`) leaves out is an exact zero here, and the sums run in its order, so
//! the numbers are the same.
//!
//! # Stages
//!
//! A chunk of points goes through each stage before the next starts (locate the region and the nearest
//! corner on each axis, add the corner terms, contract), so the independent work of different points
//! overlaps instead of waiting on one point's chain of dependent loads and products. The region comes from a
//! branch-free binary search; no stage branches on the data.

use super::axis::Axis;
use super::extrapolate::Extrapolate;
use super::Map;

/// Points per chunk.
const CHUNK: usize = 32;

/// One axis at a chunk's points: the padded index `c` of each point's basis (`Φ_0` is `φ_{c−1}`, padded
/// index `c`), the offset `a − x_c` to the corner and the basis `phi[i][k][m] = Φ_{c−1+k}^(m)`.
struct AxisChunk {
    base: [usize; CHUNK],
    t: [f64; CHUNK],
    phi: [[[f64; 3]; 3]; CHUNK],
}

impl AxisChunk {
    fn new() -> AxisChunk {
        AxisChunk {
            base: [0; CHUNK],
            t: [0.0; CHUNK],
            phi: [[[0.0; 3]; 3]; CHUNK],
        }
    }
}

/// Whether every axis of the map has the fixed-width basis (at most one corner in a window).
pub(super) fn fits(x: &Axis, y: Option<&Axis>) -> bool {
    x.max_count <= 3 && y.is_none_or(|y| y.max_count <= 3)
}

/// The values with zeros around them for the padded indices `−1` and `n`: 2-D `(nx + 2) × (ny + 2)`
/// row-major, 1-D `nx + 2`.
pub(super) fn pad(values: &[f64], nx: usize, ny: Option<usize>) -> Vec<f64> {
    let Some(ny) = ny else {
        let mut out = Vec::with_capacity(nx + 2);
        out.push(0.0);
        out.extend_from_slice(values);
        out.push(0.0);
        return out;
    };
    let w = ny + 2;
    let mut out = vec![0.0; (nx + 2) * w];
    for (i, row) in values.chunks_exact(ny).enumerate() {
        out[(i + 1) * w + 1..][..ny].copy_from_slice(row);
    }
    out
}

/// The number of grid points below `a` (`partition_point(|x| x < a)`) without a data-dependent branch.
#[inline(always)]
fn lower_bound(g: &[f64], a: f64) -> usize {
    let mut base = 0;
    let mut len = g.len();
    while len > 1 {
        let half = len / 2;
        base = if g[base + half - 1] < a {
            base + half
        } else {
            base
        };
        len -= half;
    }
    base + usize::from(g[base] < a)
}

/// Stage 1 of an axis: region, nearest corner and the unsmoothed weights and slopes of `a`'s region
/// (`Axis::plain`'s numbers), placed at the fixed-width offsets.
#[inline(always)]
fn locate(axis: &Axis, a: &[f64], ch: &mut AxisChunk) {
    let g = axis.grid.as_slice();
    let n = g.len();
    let clamp = axis.extrapolate == Extrapolate::Clamp;
    for (i, &a) in a.iter().enumerate() {
        let p = lower_bound(g, a);
        let r = p.saturating_sub(1).min(n - 2);
        let (x0, x1) = (g[r], g[r + 1]);
        let near_r = a - x0 <= x1 - a;
        let c = if near_r { r } else { r + 1 };
        let d = x1 - x0;
        // φ_r = (x_{r+1} − a)/d, φ_{r+1} = (a − x_r)/d; under clamp the edge value outside the grid.
        let mut plain = [[(x1 - a) / d, -1.0 / d, 0.0], [(a - x0) / d, 1.0 / d, 0.0]];
        if clamp && p == 0 {
            plain = [[1.0, 0.0, 0.0], [0.0; 3]];
        }
        if clamp && p == n {
            plain = [[0.0; 3], [1.0, 0.0, 0.0]];
        }
        ch.phi[i] = if near_r {
            [[0.0; 3], plain[0], plain[1]]
        } else {
            [plain[0], plain[1], [0.0; 3]]
        };
        ch.base[i] = c;
        ch.t[i] = a - g[c];
    }
}

/// Stage 2 of a smoothed axis: `Φ_{c−1+k} += w_{c−1+k, c} E(a − x_c)`.
#[inline(always)]
fn add_corners(axis: &Axis, len: usize, ch: &mut AxisChunk) {
    let Some(kernel) = axis.kernel else {
        return;
    };
    for i in 0..len {
        let e = kernel.corner_excess_lanes(ch.t[i]);
        let w = axis.weights[ch.base[i]];
        for (row, &wk) in ch.phi[i].iter_mut().zip(&w) {
            for (r, &em) in row.iter_mut().zip(&e) {
                *r += wk * em;
            }
        }
    }
}

/// Stage 3, 2-D: `out[(3p + q) · stride + i] = Σ_k Φ_k^(p) Σ_l v_kl Ψ_l^(q)` (`small::contract`'s order).
#[inline(always)]
fn contract_2d(
    padded: &[f64],
    ny: usize,
    (cx, cy): (&AxisChunk, &AxisChunk),
    len: usize,
    out: &mut [f64],
    stride: usize,
) {
    let w = ny + 2;
    for i in 0..len {
        let mut sum = [[0.0; 3]; 3];
        for (k, phi) in cx.phi[i].iter().enumerate() {
            let row = &padded[(cx.base[i] + k) * w + cy.base[i]..][..3];
            let mut t = [0.0; 3];
            for (&v, psi) in row.iter().zip(&cy.phi[i]) {
                for (tq, &s) in t.iter_mut().zip(psi) {
                    *tq += v * s;
                }
            }
            for (o, &ph) in sum.iter_mut().zip(phi) {
                for (oq, &tq) in o.iter_mut().zip(&t) {
                    *oq += ph * tq;
                }
            }
        }
        for (k, &s) in sum.iter().flatten().enumerate() {
            out[k * stride + i] = s;
        }
    }
}

/// Stage 3, 1-D: `out[m · stride + i] = Σ_k v_k Φ_k^(m)` (`Map::eval_1d_small`'s order).
#[inline(always)]
fn contract_1d(padded: &[f64], cx: &AxisChunk, len: usize, out: &mut [f64], stride: usize) {
    for i in 0..len {
        let mut sum = [0.0; 3];
        for (k, phi) in cx.phi[i].iter().enumerate() {
            let v = padded[cx.base[i] + k];
            for (o, &f) in sum.iter_mut().zip(phi) {
                *o += v * f;
            }
        }
        for (m, &s) in sum.iter().enumerate() {
            out[m * stride + i] = s;
        }
    }
}

/// The fixed-width path over all points (the map [`fits`]); `out` as [`Map::partials2_batch`] lays it out.
#[inline(always)]
fn run(map: &Map, a: &[f64], b: &[f64], out: &mut [f64]) {
    let n = a.len();
    let (mut cx, mut cy) = (AxisChunk::new(), AxisChunk::new());
    let mut start = 0;
    while start < n {
        let len = CHUNK.min(n - start);
        let o = &mut out[start..];
        locate(&map.x, &a[start..start + len], &mut cx);
        add_corners(&map.x, len, &mut cx);
        match &map.y {
            None => contract_1d(&map.padded, &cx, len, o, n),
            Some(y) => {
                locate(y, &b[start..start + len], &mut cy);
                add_corners(y, len, &mut cy);
                contract_2d(&map.padded, y.len(), (&cx, &cy), len, o, n);
            }
        }
        start += len;
    }
}

/// [`run`] compiled for AVX2 with FMA (chosen at run time; the arithmetic has no fused operations, so the
/// numbers are those of the portable build).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2(map: &Map, a: &[f64], b: &[f64], out: &mut [f64]) {
    run(map, a, b, out)
}

/// [`run`] with the best instruction set this processor has.
pub(super) fn dispatch(map: &Map, a: &[f64], b: &[f64], out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        // SAFETY: the processor has the features `run_avx2` is compiled for.
        return unsafe { run_avx2(map, a, b, out) };
    }
    run(map, a, b, out)
}
