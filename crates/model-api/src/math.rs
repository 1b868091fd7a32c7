//! x^y for positive x, accurate to below one ulp and fast over whole slices: the fractional powers of
//! generated batch kernels.
//!
//! # Method
//!
//! x^y = exp(y · ln x), with ln x and the product y · ln x carried as double-double values (an unevaluated
//! sum hi + lo of two `f64`, about 106 bits), so that y · ln x keeps an absolute error far below 2⁻⁵³ even
//! where it is large (up to 708); the standard structure of an accurate `pow` (Muller, *Elementary
//! Functions: Algorithms and Implementation*, 3rd ed., Birkhäuser 2016, for the error-free transformations,
//! range reduction and polynomial evaluation used below).
//!
//! * **ln x.** The exponent bits give x = 2^k · m with m ∈ [√½, √2) (no table). Then
//!   ln m = 2 atanh(s) = 2s + 2s³/3 + 2s⁵/5 + …, s = (m − 1)/(m + 1), |s| ≤ 0.1716. s is computed as
//!   s_h + s_l to about 2⁻⁷⁹ relative by one division and an exact residual: m − 1 is exact (Sterbenz),
//!   m + 1 = (1 + m_h) + m_l exactly with m_h the leading 25 bits of m, and s_h (the leading 26 bits of the
//!   quotient) times 1 + m_h is exact. The tail s³ · Q(s²) is a degree-7 minimax polynomial in s² (relative
//!   error 2⁻⁵⁸ before rounding its coefficients), evaluated in plain `f64`: it is at most 1 % of ln m, so its
//!   rounding adds only about 1.2e-18 to ln m. ln x = k · ln2_hi + 2s_h + (k · ln2_lo + 2s_l + tail),
//!   renormalised (Fast2Sum), with ln 2 split as in Cody & Waite, *Software Manual for the Elementary
//!   Functions* (1980): ln2_hi has 32 significant bits, so k · ln2_hi is exact.
//! * **y · ln x** as a double-double: the exact product of Dekker, *A floating-point technique for extending
//!   the available precision*, Numer. Math. 18 (1971) (Veltkamp's split, or one fused multiply-add where the
//!   hardware has it: both give the exact error term, so every path returns the same bits).
//! * **exp w.** Cody–Waite reduction w = n · ln 2 + r, |r| ≤ ln 2 / 2, as in Tang's exponential (Tang,
//!   *Table-driven implementation of the exponential function in IEEE floating-point arithmetic*, ACM TOMS
//!   15(2), 1989), without the table: exp r = 1 + r + r² · E(r) with E a degree-10 minimax polynomial on
//!   [−0.3466, 0.3466] (relative error 2⁻⁵⁷), 1 + r kept exact (Fast2Sum) so that only the final addition
//!   rounds, then scaled by 2^n through the exponent bits. Both polynomials are evaluated by Estrin's scheme
//!   (short dependency chains). Coefficients: Remez exchange in 200-bit arithmetic (mpmath), rounded to
//!   `f64`.
//!
//! The main path has no branches and no table lookups, so a loop over a slice vectorises. [`pow_pos_slice`]
//! runs it in two passes over chunks of 256 values (ln x, then exp(y · ln x)), which keeps the dependency
//! chains short enough to overlap many values, and on x86-64 runs a copy compiled for AVX2 + FMA when the
//! processor has them (chosen at run time: twice the vector width; the same results bit for bit, see above).
//! Lanes outside the main path's domain are marked and recomputed with [`f64::powf`] in a scalar pass.
//!
//! # Domain and accuracy
//!
//! The main path covers positive normal finite x, |y| ≤ [`POW_POS_MAX_EXPONENT`] and |y · ln x| < 708 (a
//! normal, finite result). Everything else — x ≤ 0, subnormal, infinite or NaN x, NaN or larger |y|, results
//! that overflow or are subnormal — is [`f64::powf`]'s result exactly.
//!
//! On the main path the error is below 1 ulp of the exact x^y: 0.5 ulp from the final rounding, about 0.1 ulp
//! from evaluating exp r, and up to 0.022 · |y| ulp from the absolute error of ln x (about 1.2e-18, from the
//! rounding of the atanh tail), so at most 0.35 ulp at |y| = 16. Measured against 160-bit references (mpmath,
//! 100 000 points per set): at most 0.63 ulp for x ∈ [1e-300, 1e300], |y| ≤ 4; 0.75 ulp for |y| ≤ 16; and
//! 0.83 ulp for |y| ≤ 16 with x's mantissa near √2 or √½ (largest |s|, the worst case for ln x). `f64::powf`
//! (glibc: below 0.52 ulp) and this function therefore differ by at most one representable value; the tests
//! (`tests/pow_pos.rs`) check that over millions of points, and against correctly rounded references.

/// Largest |y| on the fast path of [`pow_pos`] and [`pow_pos_slice`]; larger exponents use
/// [`f64::powf`]. (The error contributed by ln x grows with |y|: at most 0.35 ulp up to this bound.)
pub const POW_POS_MAX_EXPONENT: f64 = 16.0;

/// Values per pass of [`pow_pos_slice`] (the low parts of ln x live on the stack in between).
const CHUNK: usize = 256;

/// ln 2 = LN2_HI + LN2_LO (Cody & Waite; fdlibm's constants): LN2_HI has 32 significant bits, so n · LN2_HI is
/// exact for |n| < 2²¹.
const LN2_HI: f64 = 6.931_471_803_691_238e-1;
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
/// 1.5 · 2⁵²: adding it rounds a value below 2⁵¹ in magnitude to an integer, kept in the low mantissa bits.
const ROUND: f64 = 6_755_399_441_055_744.0;
/// The bits of √½ (rounded to nearest): x = 2^k · m with m ∈ [√½, √2).
const SQRT_HALF_BITS: u64 = 0x3FE6_A09E_667F_3BCD;
const ONE_BITS: u64 = 0x3FF0_0000_0000_0000;
const MANTISSA: u64 = 0x000F_FFFF_FFFF_FFFF;
/// 2⁵² + 1023 as an `f64`: (bits 0x433 << 52 | e) − this = e − 1023 for a biased exponent e.
const EXPONENT_BIAS: f64 = 4_503_599_627_370_496.0 + 1023.0;
/// Masks keeping the leading 25 and 26 significant bits of an `f64`.
const LEADING_25: u64 = 0xFFFF_FFFF_F000_0000;
const LEADING_26: u64 = 0xFFFF_FFFF_F800_0000;
/// The results of x^y with |y · ln x| at or above this are not normal, or overflow: left to `powf`.
const MAX_W: f64 = 708.0;

/// (ln m − 2s)/s³ = Σ 2z^j/(2j + 3) at z = s² ∈ [0, 0.02944]: minimax, relative error 2⁻⁵⁸ (before the
/// coefficients are rounded; the rounding of the first, 2/3, dominates the rest at 2⁻⁵⁴).
const LOG_Q: [f64; 8] = [
    0.666_666_666_666_666_6,
    0.400_000_000_000_008_8,
    0.285_714_285_708_019_2,
    0.222_222_223_920_586_05,
    0.181_817_956_066_348_12,
    0.153_862_413_736_609_55,
    0.132_687_318_187_493_02,
    0.130_870_275_417_940_66,
];

/// (e^r − 1 − r)/r² on [−0.3466, 0.3466]: minimax, relative error 2⁻⁵⁷ with the coefficients rounded.
const EXP_E: [f64; 11] = [
    0.5,
    0.166_666_666_666_666_7,
    0.041_666_666_666_666_616,
    0.008_333_333_333_326_164,
    0.001_388_888_888_891_797_4,
    1.984_126_987_473_661_4e-4,
    2.480_158_724_572_123e-5,
    2.755_725_549_414_064e-6,
    2.755_734_962_452_262e-7,
    2.510_518_199_991_913_2e-8,
    2.088_937_727_257_559_2e-9,
];

/// x^y for positive x, with an error below 1 ulp (see the [module documentation](self)); any other argument
/// gives exactly `x.powf(y)`.
///
/// The same value, bit for bit, as one element of [`pow_pos_slice`]; for many values with one exponent the
/// slice form is much faster (it vectorises).
///
/// ```
/// use invsim_model_api::math::pow_pos;
/// let v = pow_pos(2.0, 0.5);
/// assert!((v - std::f64::consts::SQRT_2).abs() <= f64::EPSILON);
/// assert_eq!(pow_pos(-8.0, 3.0), -512.0); // outside the fast path: f64::powf
/// ```
#[inline]
pub fn pow_pos(x: f64, y: f64) -> f64 {
    if y.abs() <= POW_POS_MAX_EXPONENT {
        let (l_hi, l_lo) = ln_dd(x);
        let v = exp_y_ln::<FMA_PORTABLE>(y, l_hi, l_lo);
        if !v.is_nan() {
            return v;
        }
    }
    x.powf(y)
}

/// `out[i] = x[i]^y` for every i, as [`pow_pos`] computes it (the same bits), for many values at once.
///
/// # Panics
///
/// If `out` and `x` differ in length.
///
/// ```
/// use invsim_model_api::math::{pow_pos, pow_pos_slice};
/// let x = [1e-3, 0.5, 2.0, 1e10, 0.0, -1.0];
/// let mut out = [0.0; 6];
/// pow_pos_slice(&x, 0.9, &mut out);
/// for (o, &v) in out.iter().zip(&x) {
///     assert_eq!(o.to_bits(), pow_pos(v, 0.9).to_bits());
/// }
/// assert_eq!(out[4], 0.0);
/// assert!(out[5].is_nan());
/// ```
pub fn pow_pos_slice(x: &[f64], y: f64, out: &mut [f64]) {
    assert_eq!(
        x.len(),
        out.len(),
        "pow_pos_slice: input and output lengths differ"
    );
    if y.abs() <= POW_POS_MAX_EXPONENT {
        if fast_pass(x, y, out) {
            // The lanes the main path does not cover are NaN there (and only those: a covered lane is finite).
            for (o, &v) in out.iter_mut().zip(x) {
                if o.is_nan() {
                    *o = v.powf(y);
                }
            }
        }
    } else {
        for (o, &v) in out.iter_mut().zip(x) {
            *o = v.powf(y);
        }
    }
}

/// The main path over `x`, with the best kernel this processor runs; true if any lane is left NaN.
#[inline]
fn fast_pass(x: &[f64], y: f64, out: &mut [f64]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        // SAFETY: the processor has the features `kernel_avx2` is compiled for.
        return unsafe { x86::kernel_avx2(x, y, out) };
    }
    kernel::<FMA_PORTABLE>(x, y, out)
}

/// A copy of [`kernel`] compiled for a wider vector unit (chosen at run time by [`fast_pass`]).
#[cfg(target_arch = "x86_64")]
mod x86 {
    /// [`super::kernel`] for AVX2 (4 lanes) with FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn kernel_avx2(x: &[f64], y: f64, out: &mut [f64]) -> bool {
        super::kernel::<true>(x, y, out)
    }
}

/// Whether the portable kernel may use `f64::mul_add` (a single instruction, not a library call).
const FMA_PORTABLE: bool = cfg!(any(target_feature = "fma", target_arch = "aarch64"));

/// The main path over chunks of [`CHUNK`] values: ln x for the chunk, then exp(y · ln x). Lanes outside the
/// domain are NaN; returns whether there are any.
#[inline(always)]
fn kernel<const FMA: bool>(x: &[f64], y: f64, out: &mut [f64]) -> bool {
    let mut low = [0.0; CHUNK];
    let mut any_nan = false;
    for (xs, os) in x.chunks(CHUNK).zip(out.chunks_mut(CHUNK)) {
        let low = &mut low[..xs.len()];
        for ((o, l), &v) in os.iter_mut().zip(low.iter_mut()).zip(xs) {
            (*o, *l) = ln_dd(v);
        }
        for (o, &l) in os.iter_mut().zip(low.iter()) {
            *o = exp_y_ln::<FMA>(y, *o, l);
            any_nan |= o.is_nan();
        }
    }
    any_nan
}

/// The leading bits of `a` (`mask`: [`LEADING_25`] or [`LEADING_26`]), the rest zero.
#[inline(always)]
fn leading(a: f64, mask: u64) -> f64 {
    f64::from_bits(a.to_bits() & mask)
}

/// ln x as hi + lo (|lo| ≤ ulp(hi)/2, absolute error about 1.2e-18 + 2⁻¹⁰⁶ |ln x|); hi is NaN unless x is
/// positive, normal and finite.
#[inline(always)]
fn ln_dd(x: f64) -> (f64, f64) {
    // x = 2^k · m, m ∈ [√½, √2): adding (bits(1) − bits(√½)) carries into the exponent field exactly when the
    // mantissa is at or above √2's, so the field holds k + 1023 and the mantissa bits give m − √½'s bits.
    let t = x
        .to_bits()
        .wrapping_add(ONE_BITS.wrapping_sub(SQRT_HALF_BITS));
    let k = f64::from_bits((t >> 52) | 0x4330_0000_0000_0000) - EXPONENT_BIAS;
    let m = f64::from_bits((t & MANTISSA) + SQRT_HALF_BITS);
    // s = (m − 1)/(m + 1) = s_h + s_l: m + 1 = d_h + m_l exactly, s_h · d_h exact (26 + 27 bits).
    let f = m - 1.0;
    let m_h = leading(m, LEADING_25);
    let m_l = m - m_h;
    let d_h = 1.0 + m_h;
    let inv = 1.0 / (d_h + m_l);
    let s = f * inv;
    let s_h = leading(s, LEADING_26);
    let s_l = ((f - s_h * d_h) - s_h * m_l) * inv;
    // ln m = 2s + s³ Q(s²).
    let z = s * s;
    let z2 = z * z;
    let q = &LOG_Q;
    let poly = (q[0] + q[1] * z)
        + z2 * (q[2] + q[3] * z)
        + (z2 * z2) * ((q[4] + q[5] * z) + z2 * (q[6] + q[7] * z));
    let tail = s * z * poly;
    // ln x = k·ln2_hi + 2s_h (Fast2Sum: |k·ln2_hi| ≥ |2s_h| unless k = 0) + the small terms.
    let a = k * LN2_HI;
    let b = 2.0 * s_h;
    let sum = a + b;
    let small = (b - (sum - a)) + (k * LN2_LO + (2.0 * s_l + tail));
    let hi = sum + small;
    let lo = small - (hi - sum);
    let positive_normal = (f64::MIN_POSITIVE..=f64::MAX).contains(&x);
    (if positive_normal { hi } else { f64::NAN }, lo)
}

/// exp(y · (l_hi + l_lo)); NaN unless |y · l_hi| < [`MAX_W`] (NaN l_hi stays NaN).
#[inline(always)]
fn exp_y_ln<const FMA: bool>(y: f64, l_hi: f64, l_lo: f64) -> f64 {
    let (w_hi, w_err) = two_product::<FMA>(y, l_hi);
    let w_lo = w_err + y * l_lo;
    // w = n ln2 + r: w_hi − n·ln2_hi is exact (n·ln2_hi is, and the two agree to within a factor 2).
    let shifted = w_hi * std::f64::consts::LOG2_E + ROUND;
    let n = shifted - ROUND;
    let r_hi = w_hi - n * LN2_HI;
    let r_lo = w_lo - n * LN2_LO;
    let r = r_hi + r_lo;
    let r_lo = r_lo - (r - r_hi);
    // exp(r + r_lo) = 1 + r + r²E(r) + r_lo(1 + r) + O(r_lo²), with 1 + r exact as h + h_lo.
    let r2 = r * r;
    let r4 = r2 * r2;
    let e = &EXP_E;
    let poly = ((e[0] + e[1] * r) + r2 * (e[2] + e[3] * r))
        + r4 * (((e[4] + e[5] * r) + r2 * (e[6] + e[7] * r))
            + r4 * ((e[8] + e[9] * r) + r2 * e[10]));
    let h = 1.0 + r;
    let h_lo = r - (h - 1.0);
    let v = h + (h_lo + (r2 * poly + r_lo * (1.0 + r)));
    // 2^n from the integer in the low bits of `shifted` (|n| ≤ 1022 here, so the exponent field is normal).
    let scale = f64::from_bits(shifted.to_bits().wrapping_add(1023) << 52);
    if w_hi.abs() < MAX_W {
        v * scale
    } else {
        f64::NAN
    }
}

/// a · b = p + e exactly (Dekker 1971): with one fused multiply-add, or with Veltkamp's split into 26-bit
/// halves. Both give the same e (it is exact), hence the same results on every path.
#[inline(always)]
fn two_product<const FMA: bool>(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    if FMA {
        return (p, a.mul_add(b, -p));
    }
    let (a_h, a_l) = veltkamp(a);
    let (b_h, b_l) = veltkamp(b);
    (p, ((a_h * b_h - p) + a_h * b_l + a_l * b_h) + a_l * b_l)
}

/// a = hi + lo with hi and lo of at most 26 significant bits each.
#[inline(always)]
fn veltkamp(a: f64) -> (f64, f64) {
    let c = 134_217_729.0 * a; // 2^27 + 1
    let hi = c - (c - a);
    (hi, a - hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic values spread over the whole range (log-uniform x, uniform y).
    fn sample(n: usize, seed: u64, y_max: f64) -> (Vec<f64>, Vec<f64>) {
        let mut s = seed;
        let mut next = || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let xs = (0..n)
            .map(|_| 10f64.powf(-300.0 + 600.0 * next()))
            .collect();
        let ys = (0..n).map(|_| y_max * (2.0 * next() - 1.0)).collect();
        (xs, ys)
    }

    /// Every kernel this processor runs gives the portable kernel's bits (the fused multiply-add appears only
    /// in the exact product).
    #[test]
    fn kernels_agree_bit_for_bit() {
        let (xs, ys) = sample(1 << 14, 7, POW_POS_MAX_EXPONENT);
        let mut xs = xs;
        xs.extend([0.0, -1.0, f64::NAN, f64::INFINITY, 1e-310, 1.0]);
        for &y in ys.iter().take(40).chain(&[0.1, 0.9, -0.1, 1.8, 0.0]) {
            let mut portable = vec![0.0; xs.len()];
            let mut dekker = vec![0.0; xs.len()];
            let mut best = vec![0.0; xs.len()];
            kernel::<FMA_PORTABLE>(&xs, y, &mut portable);
            kernel::<false>(&xs, y, &mut dekker);
            fast_pass(&xs, y, &mut best);
            #[cfg(target_arch = "x86_64")]
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                let mut avx2 = vec![0.0; xs.len()];
                // SAFETY: checked just above.
                unsafe { x86::kernel_avx2(&xs, y, &mut avx2) };
                assert_eq!(bits(&avx2), bits(&dekker), "y = {y}");
            }
            assert_eq!(bits(&portable), bits(&dekker), "y = {y}");
            assert_eq!(bits(&best), bits(&dekker), "y = {y}");
        }
    }

    #[test]
    fn constants_are_exact() {
        assert_eq!(LN2_HI.to_bits(), 0x3FE6_2E42_FEE0_0000);
        assert_eq!(LN2_LO.to_bits(), 0x3DEA_39EF_3579_3C76);
        assert_eq!(
            LN2_HI.to_bits() & 0x1F_FFFF,
            0,
            "n·ln2_hi exact for |n| < 2^21"
        );
        assert!((LN2_HI + LN2_LO - std::f64::consts::LN_2).abs() <= f64::EPSILON / 4.0);
        assert_eq!(
            f64::from_bits(SQRT_HALF_BITS),
            std::f64::consts::FRAC_1_SQRT_2
        );
        assert_eq!(ROUND, 1.5 * (1u64 << 52) as f64);
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }
}
