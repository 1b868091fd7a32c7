//! The C-infinity bump kernel of Fröberg & Nielsen (2004), eq. 33–35: values, closed-form derivatives of any
//! order, the normalised integral `K`, the first moment `M` and the smoothed ramp `R`.
//!
//! # Definitions
//!
//! The paper smooths the drive cycle with (eq. 33–35)
//!
//! ```text
//! g(t) = exp(−a² / (a² − t²))   for |t| < a,   g(t) = 0 otherwise,
//! C    = ∫ g dt = C₀·a,   C₀ = ∫_{−1}^{1} exp(−1/(1 − u²)) du = 0.443 993 816 168 079 437 8…
//! k(t) = g(t) / C                                            (normalised kernel, ∫ k = 1)
//! ```
//!
//! Everything is computed for the unit kernel `h(u) = exp(−1/(1 − u²))`, `u = t/a`, and scaled:
//! `k^(n)(t) = h^(n)(t/a) / (C₀ a^(n+1))`, `K(t) = K₁(t/a)`, `M(t) = a·M₁(t/a)`, `R(t) = a·R₁(t/a)`.
//!
//! # Derivatives in closed form
//!
//! The derivatives of the smoothed cycle come from the kernel, never from differencing. In the variable `t`
//! they have the form
//!
//! ```text
//! g^(n)(t) = g(t) · P_n(t) / (a² − t²)^(2n),
//! P_0 = 1,   P_{n+1}(t) = (a² − t²)² P_n'(t) + 2t (2n (a² − t²) − a²) P_n(t),
//! ```
//!
//! which follows from differentiating `g P_n (a² − t²)^(−2n)` and collecting the factor
//! `(a² − t²)^(−2n−2)`; `P_1 = −2a²t`, `P_2 = 6a²t⁴ − 2a⁶`. Evaluated in powers of
//! `u` this loses many digits near `u = ±1` (the coefficients of `P_10` reach 3.6·10¹⁰ while `P_10(±1)` is
//! small). We therefore use the equivalent exact scheme in the variable `w = 1/(1 − u²)`:
//!
//! ```text
//! h^(n)(u) = u^(n mod 2) · e^(−w) · S_n(w),          dw/du = 2u w²,   u² w² = w² − w,
//! S_0 = 1,
//! S_{n+1} = 2w² (S_n' − S_n)                for n even,
//! S_{n+1} = S_n + 2(w² − w)(S_n' − S_n)     for n odd,
//! ```
//!
//! (`S_1 = −2w²`, `S_2 = 4w⁴ − 12w³ + 6w²`; `deg S_n = 2n`). It is evaluated as
//! `e^(−w) w^(2n) · S̃_n(q)` with `q = 1 − u² = (1 − u)(1 + u)` and `S̃_n(q) = q^(2n) S_n(1/q)`, a
//! polynomial in `q` that is dominated by its constant term near the support's edge. When `e^(−w)` would
//! underflow (`w > 700`) the product is formed in log space, `exp(−w + 2n ln w)`, so every derivative tends
//! to 0 at `±a` without overflow or NaN.
//!
//! # The integral and the smoothed ramp
//!
//! `K(t) = ∫_{−a}^{t} k` and `R(t) = ∫_{−a}^{t} K = t K(t) − M(t)`, with `M(t) = ∫_{−a}^{t} σ k(σ) dσ`,
//! are tabulated for the unit kernel on `[−1, 0]` (the rest follows from symmetry:
//! `K(u) = 1 − K(−u)`, `M(u) = M(−u)`, `R(u) = u + R(−u)`): 128 pieces, each a degree-11 polynomial
//! obtained by interpolating `h` at 32 Chebyshev points, integrating the Chebyshev series exactly and
//! accumulating the piece integrals in double-double arithmetic. The truncation error is below 10⁻¹⁸, so `K`
//! is correct to rounding (≈ 10⁻¹⁶ absolute) and a call costs one table look-up. The kernel itself, `h/C₀`,
//! has a table on the same pieces (degree 15, the interpolant of the same samples, its DCT taken of the
//! samples' deviation from their mean so the sums' rounding stays below 10⁻¹⁷; error below 10⁻¹⁵ of the
//! peak): the smooth maps take their value, slope and curvature from one look-up with no exponential
//! ([`Kernel::corner_excess`]). The tables (and the polynomials `S̃_n` of the orders 0–32) are built at
//! compile time by `build.rs`, which runs the construction in `construction.rs`; nothing is built at
//! start-up.

mod lanes;

#[cfg(target_arch = "x86_64")]
pub(crate) use lanes::Avx2;
pub(crate) use lanes::{CornerChunk, F4};

use std::fmt;

use crate::construction::{
    build_derivative_polys, Piece, DENSITY_COEFFS, PIECES, TABULATED_ORDERS, UNIT_NORMALISATION,
};

/// The tables as constants, emitted by `build.rs` from [`construction`] (bit for bit what it builds at run
/// time; a test checks that).
#[allow(clippy::unreadable_literal, clippy::excessive_precision)]
mod tables {
    use crate::construction::Piece;
    include!(concat!(env!("OUT_DIR"), "/kernel_tables.rs"));
}

/// Above this `w = 1/(1 − u²)` the factor `e^(−w) w^(2n)` is formed in log space.
const W_LOG_SPACE: f64 = 700.0;

/// The normalised bump kernel `k(t) = g(t)/C` of half-width (look-ahead time) `a`.
///
/// Cheap to construct and `Copy`: the tables it uses are shared by all kernels.
#[derive(Clone, Copy)]
pub struct Kernel {
    a: f64,
    inv_a: f64,
    tables: &'static UnitTables,
    polys: &'static [&'static [f64]; TABULATED_ORDERS],
}

impl fmt::Debug for Kernel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Kernel").field("a", &self.a).finish()
    }
}

impl PartialEq for Kernel {
    fn eq(&self, other: &Self) -> bool {
        self.a == other.a
    }
}

impl Kernel {
    /// Kernel of half-width `a` seconds. `a` must be finite and positive; callers validate it (the smoother
    /// returns an error for other values), this constructor only checks it in debug builds.
    pub fn new(a: f64) -> Kernel {
        debug_assert!(
            a > 0.0 && a.is_finite(),
            "kernel half-width must be finite and positive, got {a}"
        );
        Kernel {
            a,
            inv_a: 1.0 / a,
            tables: &UNIT_TABLES,
            polys: &tables::DERIVATIVE_POLYS,
        }
    }

    /// The half-width `a`: the kernel vanishes outside `(−a, a)`.
    pub fn half_width(&self) -> f64 {
        self.a
    }

    /// The normalisation constant `C = ∫ g = C₀·a` (eq. 33–35).
    pub fn normalisation(&self) -> f64 {
        UNIT_NORMALISATION * self.a
    }

    /// The normalised kernel `k(t) = g(t)/C` (eq. 33–35).
    pub fn value(&self, t: f64) -> f64 {
        self.derivative(0, t)
    }

    /// `k^(order)(t)` in closed form (see the module documentation). Returns 0 for `|t| ≥ a`, NaN for NaN.
    ///
    /// Any order is accepted; orders up to 32 use precomputed polynomials, higher ones build theirs on each
    /// call. Rounding of `t/a` is amplified by the growth of the derivatives, so the error relative to the
    /// order's peak value is about 10⁻¹⁵ up to order 3, 6·10⁻¹⁴ at order 8, 4·10⁻¹² at 12, 3·10⁻¹⁰ at 16
    /// and 2·10⁻⁸ at 20 (measured against 80-digit arithmetic).
    pub fn derivative(&self, order: usize, t: f64) -> f64 {
        if t.is_nan() {
            return f64::NAN;
        }
        let u = t * self.inv_a;
        let scale = self.inv_a.powi(order as i32 + 1) / UNIT_NORMALISATION;
        if order < TABULATED_ORDERS {
            unit_derivative(self.polys[order], order, u) * scale
        } else {
            let poly = build_derivative_polys(order + 1).pop().unwrap_or_default();
            unit_derivative(&poly, order, u) * scale
        }
    }

    /// Writes `out[n] = k^(n)(t)` for `n = 0..out.len()`, sharing the exponential between the orders.
    pub fn derivatives(&self, t: f64, out: &mut [f64]) {
        out.fill(0.0);
        self.add_derivatives(t, 1.0, out);
    }

    /// Adds `weight · k^(n)(t)` to `out[n]` for `n = 0..out.len()`. Used by the smoother (eq. 33–35).
    pub fn add_derivatives(&self, t: f64, weight: f64, out: &mut [f64]) {
        if out.is_empty() {
            return;
        }
        if t.is_nan() {
            out.fill(f64::NAN);
            return;
        }
        let u = t * self.inv_a;
        let q = (1.0 - u) * (1.0 + u);
        if q <= 0.0 {
            return;
        }
        if out.len() > TABULATED_ORDERS {
            for (n, o) in out.iter_mut().enumerate() {
                *o += weight * self.derivative(n, t);
            }
            return;
        }
        let w = 1.0 / q;
        let polys = self.polys;
        // c = weight · e^(−w) w^(2n) / (C₀ a^(n+1)), updated from order to order.
        let mut c = weight * self.inv_a / UNIT_NORMALISATION;
        if w <= W_LOG_SPACE {
            c *= (-w).exp();
            if let [only] = out {
                // k(t) alone (the smoother's y_d'' term): S̃_0 = 1.
                *only += c;
                return;
            }
            let w2 = w * w;
            for (n, o) in out.iter_mut().enumerate() {
                let v = c * horner(polys[n], q);
                *o += if n % 2 == 1 { v * u } else { v };
                c *= w2 * self.inv_a;
            }
        } else {
            let ln_w = w.ln();
            for (n, o) in out.iter_mut().enumerate() {
                let e = (-w + 2.0 * n as f64 * ln_w).exp();
                let v = c * e * horner(polys[n], q);
                *o += if n % 2 == 1 { v * u } else { v };
                c *= self.inv_a;
            }
        }
    }

    /// `K(t) = ∫_{−a}^{t} k(σ) dσ`: 0 for `t ≤ −a`, 1 for `t ≥ a`, accurate to about 10⁻¹⁶ absolute.
    pub fn integral(&self, t: f64) -> f64 {
        let u = t * self.inv_a;
        if u.is_nan() {
            f64::NAN
        } else if u <= -1.0 {
            0.0
        } else if u >= 1.0 {
            1.0
        } else if u <= 0.0 {
            self.tables.eval(u).0
        } else {
            1.0 - self.tables.eval(-u).0
        }
    }

    /// The first moment `M(t) = ∫_{−a}^{t} σ k(σ) dσ` (≤ 0, even in `t`, zero for `|t| ≥ a`).
    pub fn moment(&self, t: f64) -> f64 {
        let u = -(t * self.inv_a).abs();
        if u.is_nan() {
            return f64::NAN;
        }
        if u <= -1.0 {
            return 0.0;
        }
        let (k, r) = self.tables.eval(u);
        self.a * (u * k - r)
    }

    /// The smoothed unit ramp `R(t) = ∫ k(σ) (t − σ)₊ dσ = t K(t) − M(t)`: 0 for `t ≤ −a`, `t` for
    /// `t ≥ a`. Convolving a corner `(τ − t_j)₊` with the kernel gives `R(t − t_j)`.
    pub fn ramp(&self, t: f64) -> f64 {
        self.ramp_offset(t) + t.max(0.0)
    }

    /// `R(t) − max(t, 0) = R(−|t|)`: how far the smoothed ramp lies above the corner. Even in `t`,
    /// non-negative, `a·R₁(0) ≈ 0.1204·a` at `t = 0` and 0 for `|t| ≥ a`. Computed without cancellation.
    pub fn ramp_offset(&self, t: f64) -> f64 {
        let u = -(t * self.inv_a).abs();
        if u.is_nan() {
            f64::NAN
        } else if u <= -1.0 {
            0.0
        } else {
            self.a * self.tables.eval(u).1
        }
    }

    /// `(K(t), R(t) − max(t, 0))` from one table look-up (the smoother needs both).
    pub fn integral_and_ramp_offset(&self, t: f64) -> (f64, f64) {
        let u = t * self.inv_a;
        if u.is_nan() {
            return (f64::NAN, f64::NAN);
        }
        let v = -u.abs();
        if v <= -1.0 {
            return (if u > 0.0 { 1.0 } else { 0.0 }, 0.0);
        }
        let (k, r) = self.tables.eval(v);
        (if u > 0.0 { 1.0 - k } else { k }, self.a * r)
    }

    /// How a smoothed corner exceeds the sharp one, with two derivatives, from one table look-up and no
    /// exponential: `[R(t) − t₊, K(t) − H(t), k(t)]` (`H` the unit step, `H(0) = 0`). All three vanish for
    /// `|t| ≥ a`. The smooth lookup maps build their basis from it (value, slope and curvature).
    ///
    /// `R(t) − t₊ = R(−|t|)` and `k` are even, `K(t) − H(t) = K(−|t|)·sign` (`K(t) + K(−t) = 1`), so all
    /// three come from the pieces on `[−1, 0]`; `k` from the density table (its error against the closed
    /// form is below 10⁻¹⁵ of its peak, a test checks it).
    #[inline(always)]
    pub fn corner_excess(&self, t: f64) -> [f64; 3] {
        let u = t * self.inv_a;
        if u.is_nan() {
            return [f64::NAN; 3];
        }
        let v = -u.abs();
        if v <= -1.0 {
            return [0.0; 3];
        }
        let (j, s) = UnitTables::locate(v);
        let [k, r] = estrin12(&self.tables.pieces[j], s);
        let d = estrin16(&self.tables.density[j], s);
        let (k, r, d) = (k.max(0.0), r.max(0.0), d.max(0.0));
        [self.a * r, if u > 0.0 { -k } else { k }, d * self.inv_a]
    }
}

/// `h^(n)(u)` for the unit kernel from the polynomial `S̃_n(q)` (coefficients in increasing powers of `q`).
fn unit_derivative(poly: &[f64], n: usize, u: f64) -> f64 {
    let q = (1.0 - u) * (1.0 + u);
    if q <= 0.0 || u.is_nan() {
        return if u.is_nan() { f64::NAN } else { 0.0 };
    }
    let w = 1.0 / q;
    let two_n = 2.0 * n as f64;
    let factor = if w <= W_LOG_SPACE && n < TABULATED_ORDERS {
        (-w).exp() * w.powi(2 * n as i32)
    } else {
        (-w + two_n * w.ln()).exp()
    };
    let v = factor * horner(poly, q);
    if n % 2 == 1 {
        v * u
    } else {
        v
    }
}

#[inline]
fn horner(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci)
}

/// Piecewise polynomials for the unit kernel on `[−1, 0]`: `K₁(u)` and `R₁(u)`, each as `COEFFS` monomial
/// coefficients in the local variable `s ∈ [−1, 1]` of piece `j` (`u = −1 + (j + ½ + s/2)/PIECES`).
struct UnitTables {
    pieces: &'static [Piece; PIECES],
    /// `h(u)/C₀` on the same pieces.
    density: &'static [[f64; DENSITY_COEFFS]; PIECES],
}

/// The unit kernel's tables, compiled in.
static UNIT_TABLES: UnitTables = UnitTables {
    pieces: &tables::UNIT_PIECES,
    density: &tables::UNIT_DENSITY,
};

impl UnitTables {
    /// The piece `j` of `u ∈ (−1, 0]` and the local variable `s ∈ [−1, 1]` in it.
    #[inline]
    fn locate(u: f64) -> (usize, f64) {
        let n = PIECES as f64;
        let x = (u + 1.0) * n;
        // x ∈ (0, PIECES]; truncation is the intended floor, clamped to the last piece (through i32: cheaper
        // than the saturating conversion to usize and, unlike i64, one vector instruction across the batched
        // map's points; the same piece).
        let j = (x as i32).clamp(0, PIECES as i32 - 1) as usize;
        let centre = -1.0 + (j as f64 + 0.5) / n;
        (j, (u - centre) * (2.0 * n))
    }

    /// `(K₁(u), R₁(u))` for `u ∈ (−1, 0]`.
    #[inline]
    fn eval(&self, u: f64) -> (f64, f64) {
        let (j, s) = Self::locate(u);
        let [k, r] = estrin12(&self.pieces[j], s);
        // Near u = −1 both are below 10⁻²⁰; the clamp keeps rounding there from giving tiny negatives.
        (k.max(0.0), r.max(0.0))
    }
}

/// `[a₀ + a₁x, b₀ + b₁x]`: one step of the two-lane polynomial evaluation.
#[inline(always)]
fn lin2(c0: [f64; 2], c1: [f64; 2], x: f64) -> [f64; 2] {
    [c0[0] + c1[0] * x, c0[1] + c1[1] * x]
}

/// The two degree-11 polynomials of a piece by Estrin's scheme (shorter dependency chains than Horner).
#[inline]
fn estrin12(c: &Piece, s: f64) -> [f64; 2] {
    let s2 = s * s;
    let s4 = s2 * s2;
    let s8 = s4 * s4;
    let p01 = lin2(c[0], c[1], s);
    let p23 = lin2(c[2], c[3], s);
    let p45 = lin2(c[4], c[5], s);
    let p67 = lin2(c[6], c[7], s);
    let p89 = lin2(c[8], c[9], s);
    let pab = lin2(c[10], c[11], s);
    let lo = lin2(p01, p23, s2);
    let mid = lin2(p45, p67, s2);
    let hi = lin2(p89, pab, s2);
    lin2(lin2(lo, mid, s4), hi, s8)
}

/// One degree-15 polynomial by Estrin's scheme.
#[inline]
fn estrin16(c: &[f64; DENSITY_COEFFS], s: f64) -> f64 {
    let s2 = s * s;
    let s4 = s2 * s2;
    let s8 = s4 * s4;
    let p = |i: usize| c[i] + c[i + 1] * s;
    let q = |i: usize| p(i) + p(i + 2) * s2;
    (q(0) + q(4) * s4) + (q(8) + q(12) * s4) * s8
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::construction;

    #[test]
    fn table_is_consistent_at_the_centre() {
        let k = Kernel::new(1.0);
        assert!(
            (k.integral(0.0) - 0.5).abs() < 2e-16,
            "{}",
            k.integral(0.0) - 0.5
        );
        assert!((k.integral(-1e-300) - 0.5).abs() < 2e-16);
    }

    /// The compiled tables are bit for bit those of the double-double construction run now.
    #[test]
    fn compiled_tables_equal_the_runtime_construction() {
        let pieces = construction::build_unit_pieces();
        assert_eq!(pieces.len(), PIECES);
        for (j, (built, compiled)) in pieces.iter().zip(UNIT_TABLES.pieces.iter()).enumerate() {
            for (i, (b, c)) in built.iter().zip(compiled).enumerate() {
                for lane in 0..2 {
                    assert_eq!(
                        b[lane].to_bits(),
                        c[lane].to_bits(),
                        "piece {j}, coefficient {i}, lane {lane}: {} vs {}",
                        b[lane],
                        c[lane]
                    );
                }
            }
        }
        let density = construction::build_density_pieces();
        for (j, (built, compiled)) in density.iter().zip(UNIT_TABLES.density.iter()).enumerate() {
            let bits = |p: &[f64]| p.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(built), bits(compiled), "density piece {j}");
        }
        let polys = build_derivative_polys(TABULATED_ORDERS);
        for (n, (built, compiled)) in polys.iter().zip(tables::DERIVATIVE_POLYS).enumerate() {
            let bits = |p: &[f64]| p.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(built), bits(compiled), "derivative polynomial {n}");
        }
        // and the compiled source is what the construction prints now
        let compiled = include_str!(concat!(env!("OUT_DIR"), "/kernel_tables.rs"));
        assert!(construction::tables_source() == compiled);
    }

    /// The density table against the closed form `k(t) = e^(−w)/(C₀ a)`, and the other two entries of
    /// [`Kernel::corner_excess`] against [`Kernel::ramp_offset`] and [`Kernel::integral`].
    #[test]
    fn corner_excess_matches_the_closed_forms() {
        let k = Kernel::new(0.7);
        let peak = k.value(0.0);
        let mut worst = 0.0_f64;
        for i in 0..=200_000 {
            let t = -0.7 + 1.4 * i as f64 / 200_000.0;
            let [r, kh, d] = k.corner_excess(t);
            worst = worst.max((d - k.value(t)).abs() / peak);
            assert_eq!(r, k.ramp_offset(t), "R − t₊ at {t}");
            let step = if t > 0.0 { 1.0 } else { 0.0 };
            assert!((kh - (k.integral(t) - step)).abs() < 2e-16, "K − H at {t}");
        }
        assert!(worst < 1e-15, "density table error {worst:e} of the peak");
        assert_eq!(k.corner_excess(0.7), [0.0; 3]);
        assert_eq!(k.corner_excess(-0.8), [0.0; 3]);
        assert!(k.corner_excess(f64::NAN)[2].is_nan());
    }

    #[test]
    fn pieces_join_continuously() {
        let tables = &UNIT_TABLES;
        for j in 1..PIECES {
            // left piece at s = 1, right piece at s = −1
            let left = estrin12(&tables.pieces[j - 1], 1.0);
            let right = estrin12(&tables.pieces[j], -1.0);
            assert!((left[0] - right[0]).abs() < 3e-16, "K jump at piece {j}");
            assert!((left[1] - right[1]).abs() < 3e-16, "R jump at piece {j}");
        }
    }

    #[test]
    fn low_order_polynomials() {
        let p = build_derivative_polys(4);
        assert_eq!(p[0], vec![1.0]);
        assert_eq!(p[1], vec![-2.0, 0.0, 0.0]);
        // S_2 = 4w⁴ − 12w³ + 6w²  →  S̃_2 = 4 − 12q + 6q²
        assert_eq!(p[2], vec![4.0, -12.0, 6.0, 0.0, 0.0]);
    }
}
