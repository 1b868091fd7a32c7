//! Batched evaluation: the value and every partial derivative up to order 2 per argument of a map at many
//! points at once (`Map::partials2_batch`), the same numbers as `Map::partials2` point by point.
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
//! Points go in chunks of [`CHUNK`] through stages that each loop over the whole chunk before the next
//! starts, structure of arrays over the points: count the grid points below each argument (fixed-width
//! compares), gather the region's ends and the nearest corner (scalar loads), form the unsmoothed weights
//! and slopes (vectorised across points), evaluate the corner terms (one 4-lane table evaluation per point,
//! [`F4`]), add them (vectorised), gather the values and contract (vectorised). The independent work of
//! different points overlaps instead of waiting on one point's chain of dependent loads and products, and
//! no stage branches on the data.

// The stages index several arrays by the point `i` and small fixed orders: the form the vectoriser turns into
// fixed-width loops across points.
#![allow(clippy::needless_range_loop)]

use std::cell::RefCell;

use super::axis::Axis;
use super::extrapolate::Extrapolate;
use crate::kernel::F4;

/// Points per chunk: every stage is a loop of this fixed length over arrays of this length (a last, shorter
/// chunk is padded with the grids' first points and its extra results dropped).
const CHUNK: usize = 32;

/// Grids up to this length are searched by counting the points below `a` (fixed-width, vectorised across
/// the chunk's points); longer ones by a branch-free binary search per point.
const COUNT_SEARCH: usize = 32;

/// One chunk's numbers on one axis, structure of arrays over the points `i`.
struct AxisChunk {
    /// The index `c_i` of the grid point nearest `a_i`: the padded index of `Φ_0 = φ_{c−1}`.
    c: [usize; CHUNK],
    /// `phi[k][m][i] = Φ_{c−1+k}^(m)(a_i)`.
    phi: [[[f64; CHUNK]; 3]; 3],
    /// The kink weights `w[k][i] = w_{c−1+k, c}` of the corner.
    w: [[f64; CHUNK]; 3],
    /// The region's ends `x_r, x_{r+1}`; masks (all ones for true): the nearest corner's side (`c = r`),
    /// whether `a ≤ x_0`, resp. `a > x_{n−1}` (the edges of `clamp`); then `t_i = a_i − x_c`.
    x0: [f64; CHUNK],
    x1: [f64; CHUNK],
    near: [u64; CHUNK],
    left: [u64; CHUNK],
    right: [u64; CHUNK],
    t: [f64; CHUNK],
}

/// Everything a chunk needs, one per thread (see [`with_scratch`]): the stages write every entry a chunk
/// reads before reading it, so nothing is cleared per chunk or per call.
struct Scratch {
    x: AxisChunk,
    y: AxisChunk,
    /// Corner terms `e[m][i] = E_m(t_i)` of the axis at hand.
    e: [[f64; CHUNK]; 3],
    /// Values `v[k][l][i] = v_{c_x−1+k, c_y−1+l}` (1-D: `v[0][k][i] = v_{c−1+k}`).
    v: [[[f64; CHUNK]; 3]; 3],
    /// Results `res[3p + q][i]` (1-D: `res[m][i]`).
    res: [[f64; CHUNK]; 9],
}

impl Scratch {
    fn new() -> Box<Scratch> {
        Box::new(Scratch {
            x: AxisChunk::new(),
            y: AxisChunk::new(),
            e: [[0.0; CHUNK]; 3],
            v: [[[0.0; CHUNK]; 3]; 3],
            res: [[0.0; CHUNK]; 9],
        })
    }
}

thread_local! {
    /// This thread's scratch, allocated at its first batched evaluation and reused by every later one.
    static SCRATCH: RefCell<Option<Box<Scratch>>> = const { RefCell::new(None) };
}

/// `f` on this thread's scratch; on a fresh one if it is in use or gone (a nested call, thread teardown).
fn with_scratch<R>(f: impl FnOnce(&mut Scratch) -> R) -> R {
    let mut f = Some(f);
    let reused = SCRATCH.try_with(|cell| {
        let mut slot = cell.try_borrow_mut().ok()?;
        let f = f.take()?;
        Some(f(slot.get_or_insert_with(Scratch::new)))
    });
    match (reused, f) {
        (Ok(Some(r)), _) => r,
        (_, Some(f)) => f(&mut Scratch::new()),
        // `f` is taken only just before it runs, and then it returned `Some`.
        (_, None) => unreachable!("the scratch closure ran and returned"),
    }
}

impl AxisChunk {
    fn new() -> AxisChunk {
        AxisChunk {
            c: [0; CHUNK],
            phi: [[[0.0; CHUNK]; 3]; 3],
            w: [[0.0; CHUNK]; 3],
            x0: [0.0; CHUNK],
            x1: [0.0; CHUNK],
            near: [0; CHUNK],
            left: [0; CHUNK],
            right: [0; CHUNK],
            t: [0.0; CHUNK],
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

/// `p[i]` = the number of grid points below `a[i]` (`NaN`: 0, as `partition_point`).
#[inline(always)]
fn count_below(g: &[f64], a: &[f64; CHUNK], p: &mut [usize; CHUNK]) {
    if g.len() <= COUNT_SEARCH {
        // Compare and add across the chunk's points, one grid point at a time.
        let mut count = [0_i64; CHUNK];
        for &x in g {
            for (c, &a) in count.iter_mut().zip(a) {
                *c += i64::from(x < a);
            }
        }
        for (p, &c) in p.iter_mut().zip(&count) {
            *p = c as usize;
        }
    } else {
        for (p, &a) in p.iter_mut().zip(a) {
            *p = lower_bound(g, a);
        }
    }
}

/// All ones for true, zeros for false.
#[inline(always)]
fn mask(b: bool) -> u64 {
    u64::from(b).wrapping_neg()
}

/// Stage 1 of an axis: the region `r` (`x_r < a ≤ x_{r+1}`, clamped to the end intervals), its ends, the
/// nearest corner `c ∈ {r, r + 1}` and the clamp's edge flags.
#[inline(always)]
fn locate(axis: &Axis, a: &[f64; CHUNK], ch: &mut AxisChunk) {
    let g = axis.grid.as_slice();
    let n = g.len();
    // A grid has at least two points (`Map::new_*` checks); stated so that the indices below need no checks.
    assert!(n >= 2 && axis.weights.len() == n);
    let weights = &axis.weights[..n];
    let mut p = [0; CHUNK];
    count_below(g, a, &mut p);
    for i in 0..CHUNK {
        let r = p[i].saturating_sub(1).min(n - 2);
        let (x0, x1) = (g[r], g[r + 1]);
        let near = a[i] - x0 <= x1 - a[i];
        (ch.x0[i], ch.x1[i], ch.near[i]) = (x0, x1, mask(near));
        let c = r + usize::from(!near);
        ch.c[i] = c;
        [ch.w[0][i], ch.w[1][i], ch.w[2][i]] = weights[c];
        (ch.left[i], ch.right[i]) = (mask(p[i] == 0), mask(p[i] == n));
    }
}

/// `mask ? a : b` on the bits (`mask` all ones or all zeros): the same number, vectorised as and/or.
#[inline(always)]
fn select(mask: u64, a: f64, b: f64) -> f64 {
    f64::from_bits((a.to_bits() & mask) | (b.to_bits() & !mask))
}

/// Stage 2 of an axis: the unsmoothed weights and slopes of `a`'s region (`Axis::plain`'s numbers) at the
/// fixed-width offsets (`φ_r, φ_{r+1}` at offsets 1, 2 when `c = r`, at 0, 1 when `c = r + 1`) and the
/// offset `t = a − x_c` to the corner.
#[inline(always)]
fn plain(a: &[f64; CHUNK], ch: &mut AxisChunk, clamp: bool) {
    let mut f = [[0.0; CHUNK]; 2];
    let mut s = [[0.0; CHUNK]; 2];
    for i in 0..CHUNK {
        let (a, x0, x1) = (a[i], ch.x0[i], ch.x1[i]);
        let d = x1 - x0;
        // φ_r = (x_{r+1} − a)/d, φ_{r+1} = (a − x_r)/d.
        (f[0][i], f[1][i]) = ((x1 - a) / d, (a - x0) / d);
        (s[0][i], s[1][i]) = (-1.0 / d, 1.0 / d);
    }
    if clamp {
        // The edge value outside the grid: φ_0 = 1 left of it, φ_{n−1} = 1 right of it, slopes 0.
        for i in 0..CHUNK {
            let (left, edge) = (ch.left[i], ch.left[i] | ch.right[i]);
            f[0][i] = select(edge, select(left, 1.0, 0.0), f[0][i]);
            f[1][i] = select(edge, select(left, 0.0, 1.0), f[1][i]);
            s[0][i] = select(edge, 0.0, s[0][i]);
            s[1][i] = select(edge, 0.0, s[1][i]);
        }
    }
    let [k0, k1, k2] = &mut ch.phi;
    for i in 0..CHUNK {
        let near = ch.near[i];
        for m in 0..2 {
            let (lo, hi) = if m == 0 {
                (f[0][i], f[1][i])
            } else {
                (s[0][i], s[1][i])
            };
            k0[m][i] = select(near, 0.0, lo);
            k1[m][i] = select(near, lo, hi);
            k2[m][i] = select(near, hi, 0.0);
        }
        (k0[2][i], k1[2][i], k2[2][i]) = (0.0, 0.0, 0.0);
        ch.t[i] = a[i] - select(near, ch.x0[i], ch.x1[i]);
    }
}

/// Stage 3 of a smoothed axis: `Φ_{c−1+k}^(m) += w_{c−1+k, c} E_m(a − x_c)`.
#[inline(always)]
fn add_corners<V: F4>(axis: &Axis, ch: &mut AxisChunk, e: &mut [[f64; CHUNK]; 3]) {
    let Some(kernel) = axis.kernel else {
        return;
    };
    kernel.corner_excess_chunk::<V, CHUNK>(&ch.t, e);
    for i in 0..CHUNK {
        for k in 0..3 {
            for m in 0..3 {
                ch.phi[k][m][i] += ch.w[k][i] * e[m][i];
            }
        }
    }
}

/// Stage 4, 2-D: `res[3p + q] = Σ_k Φ_k^(p) Σ_l v_kl Ψ_l^(q)` (`small::contract`'s order, from 0).
#[inline(always)]
fn contract_2d(padded: &[f64], ny: usize, s: &mut Scratch) {
    let w = ny + 2;
    for i in 0..CHUNK {
        for k in 0..3 {
            let row = &padded[(s.x.c[i] + k) * w + s.y.c[i]..][..3];
            [s.v[k][0][i], s.v[k][1][i], s.v[k][2][i]] = [row[0], row[1], row[2]];
        }
    }
    let (phi, psi, v) = (&s.x.phi, &s.y.phi, &s.v);
    for i in 0..CHUNK {
        let mut sum = [[0.0; 3]; 3];
        for k in 0..3 {
            let mut t = [0.0; 3];
            for l in 0..3 {
                for q in 0..3 {
                    t[q] += v[k][l][i] * psi[l][q][i];
                }
            }
            for p in 0..3 {
                for q in 0..3 {
                    sum[p][q] += phi[k][p][i] * t[q];
                }
            }
        }
        for p in 0..3 {
            for q in 0..3 {
                s.res[3 * p + q][i] = sum[p][q];
            }
        }
    }
}

/// Stage 4, 1-D: `res[m] = Σ_k v_k Φ_k^(m)` (`Map::eval_1d_small`'s order, from 0).
#[inline(always)]
fn contract_1d(padded: &[f64], s: &mut Scratch) {
    for i in 0..CHUNK {
        let vals = &padded[s.x.c[i]..][..3];
        [s.v[0][0][i], s.v[0][1][i], s.v[0][2][i]] = [vals[0], vals[1], vals[2]];
    }
    let (phi, v) = (&s.x.phi, &s.v[0]);
    for i in 0..CHUNK {
        let mut sum = [0.0; 3];
        for k in 0..3 {
            for m in 0..3 {
                sum[m] += v[k][i] * phi[k][m][i];
            }
        }
        for m in 0..3 {
            s.res[m][i] = sum[m];
        }
    }
}

/// `from` (at most [`CHUNK`] values), padded with `fill`.
#[inline(always)]
fn chunk_of(from: &[f64], fill: f64) -> [f64; CHUNK] {
    let mut out = [fill; CHUNK];
    out[..from.len()].copy_from_slice(from);
    out
}

/// One axis through stages 1–3.
#[inline(always)]
fn axis_stages<V: F4>(
    axis: &Axis,
    a: &[f64; CHUNK],
    ch: &mut AxisChunk,
    e: &mut [[f64; CHUNK]; 3],
) {
    locate(axis, a, ch);
    plain(a, ch, axis.extrapolate == Extrapolate::Clamp);
    add_corners::<V>(axis, ch, e);
}

/// A map's axes and padded values: what the fixed-width path reads.
#[derive(Clone, Copy)]
pub(super) struct Data<'a> {
    pub(super) x: &'a Axis,
    pub(super) y: Option<&'a Axis>,
    /// See [`pad`].
    pub(super) padded: &'a [f64],
}

/// The fixed-width path over all points (the map [`fits`]); `out` as `Map::partials2_batch` lays it out.
#[inline(always)]
fn run<V: F4>(map: Data<'_>, a: &[f64], b: &[f64], out: &mut [f64], s: &mut Scratch) {
    let n = a.len();
    let width = if map.y.is_some() { 9 } else { 3 };
    let mut start = 0;
    while start < n {
        let len = CHUNK.min(n - start);
        let ax = chunk_of(&a[start..start + len], map.x.grid[0]);
        axis_stages::<V>(map.x, &ax, &mut s.x, &mut s.e);
        match map.y {
            None => contract_1d(map.padded, s),
            Some(y) => {
                let by = chunk_of(&b[start..start + len], y.grid[0]);
                axis_stages::<V>(y, &by, &mut s.y, &mut s.e);
                contract_2d(map.padded, y.len(), s);
            }
        }
        for (k, r) in s.res.iter().enumerate().take(width) {
            out[k * n + start..][..len].copy_from_slice(&r[..len]);
        }
        start += len;
    }
}

/// [`run`] compiled for AVX2 with FMA (chosen at run time; the arithmetic has no fused operations, so the
/// numbers are those of the portable build).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2(map: Data<'_>, a: &[f64], b: &[f64], out: &mut [f64], s: &mut Scratch) {
    run::<crate::kernel::Avx2>(map, a, b, out, s)
}

/// [`run`] built for any processor (what [`dispatch`] runs without AVX2), for the tests.
#[cfg(test)]
pub(super) fn portable(map: Data<'_>, a: &[f64], b: &[f64], out: &mut [f64]) {
    with_scratch(|s| run::<[f64; 4]>(map, a, b, out, s))
}

/// [`run`] with the best instruction set this processor has.
pub(super) fn dispatch(map: Data<'_>, a: &[f64], b: &[f64], out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        // SAFETY: the processor has the features `run_avx2` is compiled for.
        return with_scratch(|s| unsafe { run_avx2(map, a, b, out, s) });
    }
    with_scratch(|s| run::<[f64; 4]>(map, a, b, out, s))
}

/// One axis of one point through stages 1–3 (`a` finite): the padded index `c` of `Φ_0 = φ_{c−1}` and
/// `phi[k][m] = Φ_{c−1+k}^(m)(a)`, each entry by the operations [`locate`], [`plain`] and [`add_corners`]
/// apply to a lane of a chunk.
#[inline(always)]
fn axis_one(axis: &Axis, a: f64) -> (usize, [[f64; 3]; 3]) {
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
        let e = kernel.corner_excess(a - if near { x0 } else { x1 });
        let w = axis.weights[c];
        for k in 0..3 {
            for m in 0..3 {
                phi[k][m] += w[k] * e[m];
            }
        }
    }
    (c, phi)
}

/// [`Map::partials2`](super::Map::partials2) of a 2-D map that [`fits`] at one point with finite
/// arguments: the fixed-width path of one lane ([`axis_one`] per axis, then [`contract_2d`]'s sums in its
/// order), so the same numbers as the batch and as the point-by-point path of `small.rs`, with fixed-size
/// loops and no basis of variable length.
pub(super) fn partials2_one(x: &Axis, y: &Axis, padded: &[f64], a: f64, b: f64) -> [f64; 9] {
    let (cx, phi) = axis_one(x, a);
    let (cy, psi) = axis_one(y, b);
    let w = y.len() + 2;
    let mut sum = [[0.0; 3]; 3];
    for k in 0..3 {
        let v = &padded[(cx + k) * w + cy..][..3];
        let mut t = [0.0; 3];
        for l in 0..3 {
            for q in 0..3 {
                t[q] += v[l] * psi[l][q];
            }
        }
        for p in 0..3 {
            for q in 0..3 {
                sum[p][q] += phi[k][p] * t[q];
            }
        }
    }
    let mut out = [0.0; 9];
    for p in 0..3 {
        for q in 0..3 {
            out[3 * p + q] = sum[p][q];
        }
    }
    out
}
