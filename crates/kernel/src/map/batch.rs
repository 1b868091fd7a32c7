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
//! compares) and clamp the count to the region (vectorised), gather the region's ends (scalar loads), find
//! the nearest corner and form the unsmoothed weights and slopes (vectorised across points), gather the
//! corner's kink weights (scalar loads), evaluate the corner terms (one 4-lane table evaluation per point
//! inside the kernel's support, [`F4`]; +0 outside, where the evaluation would give +0), add them
//! (vectorised), gather the values and contract (vectorised, `contract.rs`). A whole chunk reads its
//! arguments in place and writes its results into the output directly. The independent work of different
//! points overlaps instead of waiting on one point's chain of dependent loads and products, and no stage
//! branches on the data.

// The stages index several arrays by the point `i` and small fixed orders: the form the vectoriser turns into
// fixed-width loops across points.
#![allow(clippy::needless_range_loop)]

use std::cell::RefCell;

use super::axis::Axis;
use super::chunk::{AxisChunk, CHUNK};
use super::contract::{contract_1d, contract_1d_value, contract_2d, contract_2d_value};
use super::extrapolate::Extrapolate;
use crate::kernel::{CornerChunk, F4};

/// Grids up to this length are searched by counting the points below `a` (fixed-width, vectorised across
/// the chunk's points); longer ones by a branch-free binary search per point.
const COUNT_SEARCH: usize = 32;

/// Everything a chunk needs, one per thread (see [`with_scratch`]): the stages write every entry a chunk
/// reads before reading it, so nothing is cleared per chunk or per call.
struct Scratch {
    x: AxisChunk,
    y: AxisChunk,
    /// The corner terms of the axis at hand.
    corners: Corners,
    /// Values `v[k][l][i] = v_{c_x−1+k, c_y−1+l}` (1-D: `v[0][k][i] = v_{c−1+k}`).
    v: [[[f64; CHUNK]; 3]; 3],
    /// Results `res[3p + q][i]` (1-D: `res[m][i]`).
    res: [[f64; CHUNK]; 9],
}

/// Corner terms `e[m][i] = E_m(t_i)` of the axis at hand, and the working arrays that find them.
struct Corners {
    e: [[f64; CHUNK]; 3],
    work: CornerChunk<CHUNK>,
}

impl Scratch {
    fn new() -> Box<Scratch> {
        Box::new(Scratch {
            x: AxisChunk::new(),
            y: AxisChunk::new(),
            corners: Corners {
                e: [[0.0; CHUNK]; 3],
                work: CornerChunk::new(),
            },
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
pub(super) fn lower_bound(g: &[f64], a: f64) -> usize {
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
fn count_below(g: &[f64], a: &[f64; CHUNK]) -> [i64; CHUNK] {
    let mut count = [0_i64; CHUNK];
    if g.len() <= COUNT_SEARCH {
        // Compare and add across the chunk's points, one grid point at a time.
        for &x in g {
            for (c, &a) in count.iter_mut().zip(a) {
                *c += i64::from(x < a);
            }
        }
    } else {
        for (c, &a) in count.iter_mut().zip(a) {
            *c = lower_bound(g, a) as i64;
        }
    }
    count
}

/// All ones for true, zeros for false.
#[inline(always)]
fn mask(b: bool) -> u64 {
    u64::from(b).wrapping_neg()
}

/// `mask ? a : b` on the bits (`mask` all ones or all zeros): the same number, vectorised as and/or.
#[inline(always)]
fn select(mask: u64, a: f64, b: f64) -> f64 {
    f64::from_bits((a.to_bits() & mask) | (b.to_bits() & !mask))
}

/// Stages 1–2 of an axis. The region `r` (`x_r < a ≤ x_{r+1}`, clamped to the end intervals) from the count
/// `p` of grid points below `a` (vectorised), its ends `x_r, x_{r+1}` (scalar loads), then vectorised: the
/// nearest corner `c ∈ {r, r + 1}`, the offset `t = a − x_c`, the unsmoothed weights and slopes of the region
/// (`Axis::plain`'s numbers, under `clamp` the edge value outside the grid) at the fixed-width offsets
/// (`φ_r, φ_{r+1}` at offsets 1, 2 when `c = r`, at 0, 1 when `c = r + 1`); last the kink weights of `c`
/// (scalar loads).
#[inline(always)]
fn locate(axis: &Axis, a: &[f64; CHUNK], ch: &mut AxisChunk) {
    let g = axis.grid.as_slice();
    let n = g.len();
    // A grid has at least two points (`Map::new_*` checks); stated so that the indices below need no checks.
    assert!(n >= 2 && axis.weights.len() == n);
    let weights = &axis.weights[..n];
    let clamp = axis.extrapolate == Extrapolate::Clamp;
    let p = count_below(g, a);
    let mut r = [0_usize; CHUNK];
    for i in 0..CHUNK {
        r[i] = (p[i] - 1).clamp(0, n as i64 - 2) as usize;
    }
    let (mut x0, mut x1) = ([0.0; CHUNK], [0.0; CHUNK]);
    for i in 0..CHUNK {
        let ends = &g[r[i]..][..2];
        (x0[i], x1[i]) = (ends[0], ends[1]);
    }
    let [k0, k1, k2] = &mut ch.phi;
    for i in 0..CHUNK {
        let (a, x0, x1) = (a[i], x0[i], x1[i]);
        let near = mask(a - x0 <= x1 - a);
        ch.c[i] = r[i] + (!near & 1) as usize;
        ch.t[i] = a - select(near, x0, x1);
        let d = x1 - x0;
        // φ_r = (x_{r+1} − a)/d, φ_{r+1} = (a − x_r)/d; slopes ∓1/d.
        let (mut f0, mut f1) = ((x1 - a) / d, (a - x0) / d);
        let (mut s0, mut s1) = (-1.0 / d, 1.0 / d);
        if clamp {
            // The edge value outside the grid: φ_0 = 1 left of it, φ_{n−1} = 1 right of it, slopes 0.
            let (left, right) = (mask(p[i] == 0), mask(p[i] == n as i64));
            let edge = left | right;
            f0 = select(edge, select(left, 1.0, 0.0), f0);
            f1 = select(edge, select(left, 0.0, 1.0), f1);
            s0 = select(edge, 0.0, s0);
            s1 = select(edge, 0.0, s1);
        }
        (k0[0][i], k1[0][i], k2[0][i]) = (
            select(near, 0.0, f0),
            select(near, f0, f1),
            select(near, f1, 0.0),
        );
        (k0[1][i], k1[1][i], k2[1][i]) = (
            select(near, 0.0, s0),
            select(near, s0, s1),
            select(near, s1, 0.0),
        );
        (k0[2][i], k1[2][i], k2[2][i]) = (0.0, 0.0, 0.0);
    }
    for i in 0..CHUNK {
        [ch.w[0][i], ch.w[1][i], ch.w[2][i]] = weights[ch.c[i]];
    }
}

/// Stage 3 of a smoothed axis: `Φ_{c−1+k}^(m) += w_{c−1+k, c} E_m(a − x_c)`.
#[inline(always)]
fn add_corners<V: F4, const VALUE: bool>(axis: &Axis, ch: &mut AxisChunk, c: &mut Corners) {
    let Some(kernel) = axis.kernel else {
        return;
    };
    let e = &mut c.e;
    kernel.corner_excess_chunk::<V, CHUNK>(&ch.t, e, &mut c.work);
    let orders = if VALUE { 1 } else { 3 };
    for i in 0..CHUNK {
        for k in 0..3 {
            for m in 0..orders {
                ch.phi[k][m][i] += ch.w[k][i] * e[m][i];
            }
        }
    }
}

/// `from` (fewer than [`CHUNK`] values: the last chunk) padded with `fill`.
#[inline(always)]
fn chunk_of(from: &[f64], fill: f64) -> [f64; CHUNK] {
    let mut out = [fill; CHUNK];
    out[..from.len()].copy_from_slice(from);
    out
}

/// The chunk of `a` from `start` (`len` points): in place when whole, else padded into `buf`.
#[inline(always)]
fn chunk<'a>(
    a: &'a [f64],
    start: usize,
    len: usize,
    fill: f64,
    buf: &'a mut [f64; CHUNK],
) -> &'a [f64; CHUNK] {
    let from = &a[start..start + len];
    match <&[f64; CHUNK]>::try_from(from) {
        Ok(whole) => whole,
        Err(_) => {
            *buf = chunk_of(from, fill);
            buf
        }
    }
}

/// Rows `k < W` of `out` (`n` values each) from `start` on, one whole chunk each.
#[inline(always)]
fn rows<const W: usize>(out: &mut [f64], n: usize, start: usize) -> [&mut [f64; CHUNK]; W] {
    let mut rest = out;
    std::array::from_fn(|_| {
        let (row, tail) = std::mem::take(&mut rest).split_at_mut(n);
        rest = tail;
        // `row[start..]` holds at least a whole chunk: the caller pads the last one.
        let (chunk, _) = row[start..].split_at_mut(CHUNK);
        chunk_mut(chunk)
    })
}

/// A slice of exactly [`CHUNK`] values as an array (every call passes such a slice).
#[inline(always)]
fn chunk_mut(s: &mut [f64]) -> &mut [f64; CHUNK] {
    let len = s.len();
    match s.first_chunk_mut::<CHUNK>() {
        Some(c) => c,
        None => unreachable_chunk(len),
    }
}

#[cold]
#[inline(never)]
fn unreachable_chunk(len: usize) -> ! {
    panic!("a chunk of {len} values, not {CHUNK}")
}

/// One axis through stages 1–3.
#[inline(always)]
fn axis_stages<V: F4, const VALUE: bool>(
    axis: &Axis,
    a: &[f64; CHUNK],
    ch: &mut AxisChunk,
    c: &mut Corners,
) {
    locate(axis, a, ch);
    add_corners::<V, VALUE>(axis, ch, c);
}

/// A map's axes and padded values: what the fixed-width path reads.
#[derive(Clone, Copy)]
pub(super) struct Data<'a> {
    pub(super) x: &'a Axis,
    pub(super) y: Option<&'a Axis>,
    /// See [`pad`].
    pub(super) padded: &'a [f64],
}

/// The fixed-width path over all points (the map [`fits`]); `out` as `Map::partials2_batch` lays it out, or
/// with `VALUE` the values alone (`Map::values_batch`: stage 3 adds the corner terms of order 0 only, stage 4
/// forms the one sum `Σ_k Φ_k Σ_l v_kl Ψ_l`, the terms and order of entry 0 of the full contraction).
/// Whole chunks read their arguments in place and write their results into `out` directly; the last,
/// shorter one goes through the scratch.
#[inline(always)]
fn run<V: F4, const VALUE: bool>(
    map: Data<'_>,
    a: &[f64],
    b: &[f64],
    out: &mut [f64],
    s: &mut Scratch,
) {
    let n = a.len();
    let mut start = 0;
    let (mut buf_a, mut buf_b) = ([0.0; CHUNK], [0.0; CHUNK]);
    while start < n {
        let len = CHUNK.min(n - start);
        let whole = len == CHUNK;
        let ax = chunk(a, start, len, map.x.grid[0], &mut buf_a);
        axis_stages::<V, VALUE>(map.x, ax, &mut s.x, &mut s.corners);
        let width = match (map.y, VALUE) {
            (None, true) => {
                let [res] = if whole {
                    rows(out, n, start)
                } else {
                    [&mut s.res[0]]
                };
                contract_1d_value(map.padded, &s.x, &mut s.v[0], res);
                1
            }
            (None, false) => {
                let v = &mut s.v[0];
                if whole {
                    contract_1d(map.padded, &s.x, v, rows(out, n, start));
                } else {
                    let [r0, r1, r2, ..] = &mut s.res;
                    contract_1d(map.padded, &s.x, v, [r0, r1, r2]);
                }
                3
            }
            (Some(y), _) => {
                let by = chunk(b, start, len, y.grid[0], &mut buf_b);
                axis_stages::<V, VALUE>(y, by, &mut s.y, &mut s.corners);
                let axes = (&s.x, &s.y);
                if VALUE {
                    let [res] = if whole {
                        rows(out, n, start)
                    } else {
                        [&mut s.res[0]]
                    };
                    contract_2d_value(map.padded, y.len(), axes, &mut s.v, res);
                    1
                } else {
                    if whole {
                        contract_2d(map.padded, y.len(), axes, &mut s.v, rows(out, n, start));
                    } else {
                        contract_2d(map.padded, y.len(), axes, &mut s.v, s.res.each_mut());
                    }
                    9
                }
            }
        };
        if !whole {
            for (k, r) in s.res.iter().enumerate().take(width) {
                out[k * n + start..][..len].copy_from_slice(&r[..len]);
            }
        }
        start += len;
    }
}

/// [`run`] compiled for AVX2 with FMA (chosen at run time; the arithmetic has no fused operations, so the
/// numbers are those of the portable build).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2<const VALUE: bool>(
    map: Data<'_>,
    a: &[f64],
    b: &[f64],
    out: &mut [f64],
    s: &mut Scratch,
) {
    run::<crate::kernel::Avx2, VALUE>(map, a, b, out, s)
}

/// [`run`] built for any processor (what [`dispatch`] runs without AVX2), for the tests.
#[cfg(test)]
pub(super) fn portable(map: Data<'_>, a: &[f64], b: &[f64], out: &mut [f64], value: bool) {
    with_scratch(|s| match value {
        true => run::<[f64; 4], true>(map, a, b, out, s),
        false => run::<[f64; 4], false>(map, a, b, out, s),
    })
}

/// [`run`] with the best instruction set this processor has (`value`: the values alone).
pub(super) fn dispatch(map: Data<'_>, a: &[f64], b: &[f64], out: &mut [f64], value: bool) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        // SAFETY: the processor has the features `run_avx2` is compiled for.
        return with_scratch(|s| unsafe {
            match value {
                true => run_avx2::<true>(map, a, b, out, s),
                false => run_avx2::<false>(map, a, b, out, s),
            }
        });
    }
    with_scratch(|s| match value {
        true => run::<[f64; 4], true>(map, a, b, out, s),
        false => run::<[f64; 4], false>(map, a, b, out, s),
    })
}
