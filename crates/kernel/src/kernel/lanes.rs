//! [`Kernel::corner_excess`] with its three polynomials side by side in the lanes of one 4-wide vector, for
//! the batched map evaluation: the same table, the same Estrin scheme, the same operations per lane, so the
//! same numbers.
//!
//! Piece `j` of the unit kernel holds `K₁, R₁` (degree 11, `Piece`) and `h/C₀` (degree 15) in the local
//! variable `s`. Interleaved per power of `s` as rows `[R₁, K₁, h/C₀, h/C₀ of the power + 12]` (the fourth lane
//! of rows 0–3 holds the density's coefficients 12–15, the other rows 0), one 4-lane Estrin pass over the 12
//! rows gives: in lanes 0–2 the groups `q₀, q₄, q₈` of both schemes, and in lane 3 of `q₀` the density's top
//! group `q₁₂ = (c₁₂ + c₁₃ s) + (c₁₄ + c₁₅ s) s²`, operation for operation as `estrin16` forms it. Moved to
//! lane 2 (0 in the others) it completes `(q₀ + q₄ s⁴) + (q₈ + q₁₂ s⁴) s⁸`; for `K₁, R₁` the top group is 0 and
//! `q₈ + 0·s⁴ = q₈`, so the sum is `estrin12`'s `lo + mid·s⁴ + hi·s⁸`. Without fused multiply-adds (Rust
//! never contracts `a + b·c`) every lane rounds as the scalar path does. A piece is 384 bytes, six cache
//! lines.

use super::{tables, Kernel, UnitTables};
use crate::construction::{COEFFS, DENSITY_COEFFS, PIECES};

/// Four lanes of `f64` with the few operations the batched map evaluation needs: a plain array, or an AVX2
/// register ([`Avx2`], only where the processor has AVX2). Every operation is the lane-wise IEEE operation, so
/// both give the same numbers.
pub(crate) trait F4: Copy {
    fn splat(x: f64) -> Self;
    fn load(lanes: &[f64; 4]) -> Self;
    fn add(self, other: Self) -> Self;
    fn mul(self, other: Self) -> Self;
    /// Lane-wise `max(self, 0)` for finite lanes (`f64::max`'s result).
    fn max0(self) -> Self;
    /// `[0, 0, self[3], 0]`.
    fn lane3_to_2(self) -> Self;
    fn to_array(self) -> [f64; 4];

    /// `self + c·x` per lane.
    #[inline(always)]
    fn add_mul(self, c: Self, x: Self) -> Self {
        self.add(c.mul(x))
    }
}

impl F4 for [f64; 4] {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        [x; 4]
    }
    #[inline(always)]
    fn load(lanes: &[f64; 4]) -> Self {
        *lanes
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        std::array::from_fn(|i| self[i] + o[i])
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        std::array::from_fn(|i| self[i] * o[i])
    }
    #[inline(always)]
    fn max0(self) -> Self {
        self.map(|v| v.max(0.0))
    }
    #[inline(always)]
    fn lane3_to_2(self) -> Self {
        [0.0, 0.0, self[3], 0.0]
    }
    #[inline(always)]
    fn to_array(self) -> [f64; 4] {
        self
    }
}

/// An AVX2 register of four `f64`. Its operations are reached only from code compiled with
/// `#[target_feature(enable = "avx2,fma")]` that runs after `is_x86_feature_detected!("avx2")` (the batched
/// map's dispatch).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(crate) struct Avx2(std::arch::x86_64::__m256d);

#[cfg(target_arch = "x86_64")]
impl F4 for Avx2 {
    // SAFETY (every method): AVX is available, see the type's documentation; loads read a `[f64; 4]`.
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Avx2(unsafe { std::arch::x86_64::_mm256_set1_pd(x) })
    }
    #[inline(always)]
    fn load(lanes: &[f64; 4]) -> Self {
        Avx2(unsafe { std::arch::x86_64::_mm256_loadu_pd(lanes.as_ptr()) })
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Avx2(unsafe { std::arch::x86_64::_mm256_add_pd(self.0, o.0) })
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Avx2(unsafe { std::arch::x86_64::_mm256_mul_pd(self.0, o.0) })
    }
    #[inline(always)]
    fn max0(self) -> Self {
        // maxpd(x, 0) is x for x > 0 and 0 for x ≤ 0 (also −0): `f64::max(x, 0.0)` for finite x ≠ −0.
        Avx2(unsafe {
            std::arch::x86_64::_mm256_max_pd(self.0, std::arch::x86_64::_mm256_setzero_pd())
        })
    }
    #[inline(always)]
    fn lane3_to_2(self) -> Self {
        use std::arch::x86_64::{_mm256_blend_pd, _mm256_permute4x64_pd, _mm256_setzero_pd};
        // Every lane = lane 3, then lane 2 of that over zeros (AVX2 is available: the type's documentation).
        Avx2(unsafe {
            _mm256_blend_pd::<0b0100>(_mm256_setzero_pd(), _mm256_permute4x64_pd::<0xFF>(self.0))
        })
    }
    #[inline(always)]
    fn to_array(self) -> [f64; 4] {
        let mut out = [0.0; 4];
        unsafe { std::arch::x86_64::_mm256_storeu_pd(out.as_mut_ptr(), self.0) };
        out
    }
}

/// Four lanes in the table: `[R₁, K₁, h/C₀, h/C₀ of the power + 12]`.
type Lanes = [f64; 4];

// The density's top group (coefficients 12–15) is the fourth lane of rows 0–3: the degrees are 11 and 15.
const _: () = assert!(COEFFS == 12 && DENSITY_COEFFS == COEFFS + 4);

/// One piece: `COEFFS` rows, aligned to whole cache lines.
#[repr(align(64))]
struct LanePiece([Lanes; COEFFS]);

/// The unit kernel's tables per piece and power of `s`, interleaved (built at compile time).
static CORNER_LANES: [LanePiece; PIECES] = interleave();

const fn interleave() -> [LanePiece; PIECES] {
    let mut out = [const { LanePiece([[0.0; 4]; COEFFS]) }; PIECES];
    let mut j = 0;
    while j < PIECES {
        let mut i = 0;
        while i < COEFFS {
            let [k, r] = tables::UNIT_PIECES[j][i];
            let top = if i + COEFFS < DENSITY_COEFFS {
                tables::UNIT_DENSITY[j][i + COEFFS]
            } else {
                0.0
            };
            out[j].0[i] = [r, k, tables::UNIT_DENSITY[j][i], top];
            i += 1;
        }
        j += 1;
    }
    out
}

/// `estrin12` of `K₁, R₁` and `estrin16` of `h/C₀` of one piece in lanes 0–2 (see the module documentation).
#[inline(always)]
fn estrin_lanes<V: F4>(c: &LanePiece, s: f64) -> V {
    let c = &c.0;
    let s2 = s * s;
    let s4 = s2 * s2;
    let s8 = s4 * s4;
    let (s, s2, s4, s8) = (V::splat(s), V::splat(s2), V::splat(s4), V::splat(s8));
    let p = |i: usize| V::load(&c[i]).add_mul(V::load(&c[i + 1]), s);
    let q = |i: usize| p(i).add_mul(p(i + 2), s2);
    let q0 = q(0);
    q0.add_mul(q(4), s4)
        .add_mul(q(8).add_mul(q0.lane3_to_2(), s4), s8)
}

/// The working arrays of [`Kernel::corner_excess_chunk`] for `N` points, kept by the caller from chunk to
/// chunk: every entry a call reads it has written before.
pub(crate) struct CornerChunk<const N: usize> {
    /// The piece and the local variable of each point's `−|u|`.
    j: [usize; N],
    s: [f64; N],
    /// The factors `[a, ±1, 1/a]` (0 outside the support).
    scale: [[f64; N]; 3],
    /// Whether the point lies inside the support, and the first `count` of `listed`: those that do.
    inside: [bool; N],
    listed: [usize; N],
}

impl<const N: usize> CornerChunk<N> {
    pub(crate) fn new() -> CornerChunk<N> {
        CornerChunk {
            j: [0; N],
            s: [0.0; N],
            scale: [[0.0; N]; 3],
            inside: [false; N],
            listed: [0; N],
        }
    }
}

impl Kernel {
    /// [`Kernel::corner_excess`] at one `t` from the 4-lane table: the same numbers (one lane of
    /// [`Kernel::corner_excess_chunk`]).
    #[inline(always)]
    pub(crate) fn corner_excess_lanes<V: F4>(&self, t: f64) -> [f64; 3] {
        let u = t * self.inv_a;
        if u.is_nan() {
            return [f64::NAN; 3];
        }
        let v = -u.abs();
        if v <= -1.0 {
            return [0.0; 3];
        }
        let (j, s) = UnitTables::locate(v);
        let [r, k, d, _] = estrin_lanes::<V>(&CORNER_LANES[j], s).max0().to_array();
        [self.a * r, if u > 0.0 { -k } else { k }, d * self.inv_a]
    }

    /// [`Kernel::corner_excess`] (`[R(t) − t₊, K(t) − H(t), k(t)]`) at a chunk of offsets, structure of
    /// arrays: `e[m][i]` is entry `m` at `t[i]`; the same numbers for every `t` but NaN, where it gives 0 (the
    /// batched map fills NaN for NaN arguments itself). The piece and the factors `[a, ±1, 1/a]` are found
    /// across the chunk first (vectorised; outside the support the piece at `u = −1` and the factors 0), then
    /// the piece of each point inside the support is evaluated in the lanes, then scaled (vectorised):
    /// `R − t₊ = a·R₁`, `K − H = ±K₁`, `k = (h/C₀)/a` from the non-negative parts (`k.max(0.0)` etc. as the
    /// scalar path). Outside the support the table's value (finite, ≥ 0) times the factor 0 would be +0:
    /// the entry is set to +0 there instead of evaluated.
    #[inline(always)]
    pub(crate) fn corner_excess_chunk<V: F4, const N: usize>(
        &self,
        t: &[f64; N],
        e: &mut [[f64; N]; 3],
        w: &mut CornerChunk<N>,
    ) {
        for i in 0..N {
            let u = t[i] * self.inv_a;
            let v = -u.abs();
            let inside = v > -1.0;
            w.inside[i] = inside;
            (w.j[i], w.s[i]) = UnitTables::locate(if inside { v } else { -1.0 });
            let sign = if u > 0.0 { -1.0 } else { 1.0 };
            w.scale[0][i] = if inside { self.a } else { 0.0 };
            w.scale[1][i] = if inside { sign } else { 0.0 };
            w.scale[2][i] = if inside { self.inv_a } else { 0.0 };
            (e[0][i], e[1][i], e[2][i]) = (0.0, 0.0, 0.0);
        }
        // The points inside the support, listed without a branch.
        let mut count = 0;
        for i in 0..N {
            w.listed[count] = i;
            count += usize::from(w.inside[i]);
        }
        for &i in &w.listed[..count] {
            let raw = estrin_lanes::<V>(&CORNER_LANES[w.j[i]], w.s[i])
                .max0()
                .to_array();
            [e[0][i], e[1][i], e[2][i]] = [raw[0], raw[1], raw[2]];
        }
        for (e_m, scale_m) in e.iter_mut().zip(&w.scale) {
            for (e, &f) in e_m.iter_mut().zip(scale_m) {
                *e *= f;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`Kernel::corner_excess_lanes`] in AVX2 registers.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn one_lane_avx2(kernel: &Kernel, t: f64) -> [f64; 3] {
        kernel.corner_excess_lanes::<Avx2>(t)
    }

    /// Bit for bit the scalar corner excess, inside the support, at its ends and outside, portable and AVX2,
    /// a chunk at a time and one point at a time.
    #[test]
    fn lanes_equal_the_scalar_corner_excess() {
        const N: usize = 64;
        for h in [0.7, 25.0, 1.0e4] {
            let kernel = Kernel::new(h);
            let mut ts: Vec<f64> = (0..=100_003)
                .map(|i| h * (-1.2 + 2.4 * i as f64 / 100_003.0))
                .collect();
            ts.extend([-h, h, 0.0, -0.0, f64::INFINITY, f64::NEG_INFINITY]);
            for chunk in ts.chunks(N) {
                let t: [f64; N] = std::array::from_fn(|i| chunk.get(i).copied().unwrap_or(0.0));
                let mut e = [[0.0; N]; 3];
                kernel.corner_excess_chunk::<[f64; 4], N>(&t, &mut e, &mut CornerChunk::new());
                for (i, &t) in chunk.iter().enumerate() {
                    let scalar = kernel.corner_excess(t);
                    let one = kernel.corner_excess_lanes::<[f64; 4]>(t);
                    assert_eq!(
                        one.map(f64::to_bits),
                        scalar.map(f64::to_bits),
                        "one lane, t {t}"
                    );
                    for n in 0..3 {
                        assert_eq!(
                            e[n][i].to_bits(),
                            scalar[n].to_bits(),
                            "h {h}, t {t}, entry {n}"
                        );
                    }
                }
                #[cfg(target_arch = "x86_64")]
                if std::is_x86_feature_detected!("avx2") {
                    let mut avx2 = [[0.0; N]; 3];
                    kernel.corner_excess_chunk::<Avx2, N>(&t, &mut avx2, &mut CornerChunk::new());
                    assert_eq!(
                        avx2.map(|r| r.map(f64::to_bits)),
                        e.map(|r| r.map(f64::to_bits)),
                        "AVX2, h {h}"
                    );
                    for (i, &t) in chunk.iter().enumerate() {
                        // SAFETY: the processor has AVX2 (checked above); `Avx2`'s operations need it.
                        let one = unsafe { one_lane_avx2(&kernel, t) };
                        let want = [e[0][i], e[1][i], e[2][i]];
                        assert_eq!(
                            one.map(f64::to_bits),
                            want.map(f64::to_bits),
                            "AVX2 one lane, t {t}"
                        );
                    }
                }
            }
        }
    }
}
