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
//! are tabulated once per process for the unit kernel on `[−1, 0]` (the rest follows from symmetry:
//! `K(u) = 1 − K(−u)`, `M(u) = M(−u)`, `R(u) = u + R(−u)`): 128 pieces, each a degree-11 polynomial
//! obtained by interpolating `h` at 32 Chebyshev points, integrating the Chebyshev series exactly and
//! accumulating the piece integrals in double-double arithmetic. The truncation error is below 10⁻¹⁸, so `K`
//! is correct to rounding (≈ 10⁻¹⁶ absolute) and a call costs one table look-up.

use std::f64::consts::PI;
use std::fmt;
use std::sync::OnceLock;

/// `C₀ = ∫_{−1}^{1} exp(−1/(1 − u²)) du`: the paper's normalisation constant is `C = C₀·a` (eq. 33–35).
pub const UNIT_NORMALISATION: f64 = 0.443_993_816_168_079_4;

/// Number of table pieces on `[−1, 0]`.
const PIECES: usize = 128;
/// Coefficients per piece (degree + 1).
const COEFFS: usize = 12;
/// Chebyshev points used to build each piece.
const SAMPLES: usize = 32;
/// Derivative orders whose polynomials are precomputed; higher orders are built on demand.
const TABULATED_ORDERS: usize = 33;
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
    polys: &'static [Vec<f64>],
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
            tables: unit_tables(),
            polys: derivative_polys(),
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
            unit_derivative(&self.polys[order], order, u) * scale
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
                let v = c * horner(&polys[n], q);
                *o += if n % 2 == 1 { v * u } else { v };
                c *= w2 * self.inv_a;
            }
        } else {
            let ln_w = w.ln();
            for (n, o) in out.iter_mut().enumerate() {
                let e = (-w + 2.0 * n as f64 * ln_w).exp();
                let v = c * e * horner(&polys[n], q);
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

fn horner(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci)
}

fn derivative_polys() -> &'static [Vec<f64>] {
    static POLYS: OnceLock<Vec<Vec<f64>>> = OnceLock::new();
    POLYS.get_or_init(|| build_derivative_polys(TABULATED_ORDERS))
}

/// `S̃_n(q) = q^(2n) S_n(1/q)` for `n = 0..count`, from the recurrence for `S_n(w)` in the module docs.
fn build_derivative_polys(count: usize) -> Vec<Vec<f64>> {
    let mut out = Vec::with_capacity(count);
    // s[j] = coefficient of w^j in S_n.
    let mut s = vec![1.0_f64];
    for n in 0..count {
        // S̃_n: coefficient of q^i is s[2n − i].
        let mut rev = vec![0.0; 2 * n + 1];
        for (j, &c) in s.iter().enumerate() {
            rev[2 * n - j] = c;
        }
        out.push(rev);
        // d = S_n' − S_n
        let mut d = vec![0.0; s.len()];
        for (j, dj) in d.iter_mut().enumerate() {
            let deriv = s.get(j + 1).map_or(0.0, |&c| c * (j + 1) as f64);
            *dj = deriv - s[j];
        }
        let mut next = vec![0.0; 2 * (n + 1) + 1];
        if n % 2 == 0 {
            // S_{n+1} = 2 w² d
            for (j, &dj) in d.iter().enumerate() {
                next[j + 2] += 2.0 * dj;
            }
        } else {
            // S_{n+1} = S_n + 2 (w² − w) d
            for (j, &c) in s.iter().enumerate() {
                next[j] += c;
            }
            for (j, &dj) in d.iter().enumerate() {
                next[j + 2] += 2.0 * dj;
                next[j + 1] -= 2.0 * dj;
            }
        }
        s = next;
    }
    out
}

/// Piecewise polynomials for the unit kernel on `[−1, 0]`: `K₁(u)` and `R₁(u)`, each as `COEFFS` monomial
/// coefficients in the local variable `s ∈ [−1, 1]` of piece `j` (`u = −1 + (j + ½ + s/2)/PIECES`).
struct UnitTables {
    pieces: Vec<Piece>,
}

/// Coefficient `i` of a piece is the pair `[K-coefficient, R-coefficient]`, so both polynomials are
/// evaluated together, two lanes at a time.
type Piece = [[f64; 2]; COEFFS];

impl UnitTables {
    /// `(K₁(u), R₁(u))` for `u ∈ (−1, 0]`.
    #[inline]
    fn eval(&self, u: f64) -> (f64, f64) {
        let n = PIECES as f64;
        let x = (u + 1.0) * n;
        // x ∈ (0, PIECES]; truncation is the intended floor, clamped to the last piece.
        let j = (x as usize).min(PIECES - 1);
        let centre = -1.0 + (j as f64 + 0.5) / n;
        let s = (u - centre) * (2.0 * n);
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

fn unit_tables() -> &'static UnitTables {
    static TABLES: OnceLock<UnitTables> = OnceLock::new();
    TABLES.get_or_init(build_unit_tables)
}

/// Double-double accumulator (Knuth's two-sum) for the running integrals between pieces.
#[derive(Clone, Copy, Default)]
struct DoubleDouble {
    hi: f64,
    lo: f64,
}

impl DoubleDouble {
    fn add(&mut self, x: f64) {
        let s = self.hi + x;
        let bb = s - self.hi;
        let err = (self.hi - (s - bb)) + (x - bb);
        self.hi = s;
        self.lo += err;
    }
    fn value(self) -> f64 {
        self.hi + self.lo
    }
}

fn build_unit_tables() -> UnitTables {
    let n = PIECES as f64;
    let half = 0.5 / n;
    let theta: Vec<f64> = (0..SAMPLES)
        .map(|i| PI * (i as f64 + 0.5) / SAMPLES as f64)
        .collect();
    let mut k_left = DoubleDouble::default();
    let mut r_left = DoubleDouble::default();
    let mut pieces = Vec::with_capacity(PIECES);
    for j in 0..PIECES {
        let centre = -1.0 + (j as f64 + 0.5) / n;
        // Chebyshev interpolant of h/C₀ on the piece, in the local variable s.
        let f: Vec<f64> = theta
            .iter()
            .map(|&th| {
                let u = centre + half * th.cos();
                let q = (1.0 - u) * (1.0 + u);
                (-1.0 / q).exp() / UNIT_NORMALISATION
            })
            .collect();
        let mut a = vec![0.0; SAMPLES];
        for (k, ak) in a.iter_mut().enumerate() {
            let sum: f64 = f
                .iter()
                .zip(&theta)
                .map(|(&fi, &th)| fi * (k as f64 * th).cos())
                .sum();
            *ak = sum * if k == 0 { 1.0 } else { 2.0 } / SAMPLES as f64;
        }
        // F(s) = ∫_{left}^{u} k: antiderivative with F(−1) = 0, du = half·ds.
        let f_series = cheb_integrate(&a, half);
        // K on the piece = K(left) + F;  R = R(left) + half·K(left)(s + 1) + ∫ F.
        let k0 = k_left.value();
        let mut k_series = f_series.clone();
        k_series[0] += k0;
        let g_series = cheb_integrate(&f_series, half);
        let mut r_series = g_series.clone();
        r_series[0] += r_left.value() + half * k0;
        r_series[1] += half * k0;
        let (k, r) = (cheb_to_monomial(&k_series), cheb_to_monomial(&r_series));
        pieces.push(std::array::from_fn(|i| [k[i], r[i]]));
        // Advance the running integrals to the right end (s = 1, where T_k = 1).
        k_left.add(f_series.iter().sum());
        r_left.add(2.0 * half * k0);
        r_left.add(g_series.iter().sum());
    }
    UnitTables { pieces }
}

/// `scale · ∫_{−1}^{s} Σ a_k T_k`, as Chebyshev coefficients (one degree higher), zero at `s = −1`.
fn cheb_integrate(a: &[f64], scale: f64) -> Vec<f64> {
    let mut b = vec![0.0; a.len() + 1];
    for (k, &ak) in a.iter().enumerate() {
        match k {
            0 => b[1] += ak,
            1 => b[2] += ak / 4.0,
            _ => {
                b[k + 1] += ak / (2.0 * (k + 1) as f64);
                b[k - 1] -= ak / (2.0 * (k - 1) as f64);
            }
        }
    }
    let at_minus_one: f64 = b
        .iter()
        .enumerate()
        .skip(1)
        .map(|(k, &bk)| if k % 2 == 0 { bk } else { -bk })
        .sum();
    b[0] -= at_minus_one;
    b.iter().map(|&x| x * scale).collect()
}

/// Truncates a Chebyshev series to `COEFFS` terms (the tail is below 10⁻¹⁸) and converts it to monomials.
fn cheb_to_monomial(c: &[f64]) -> [f64; COEFFS] {
    let mut out = [0.0; COEFFS];
    let mut t_prev = [0.0; COEFFS];
    let mut t_cur = [0.0; COEFFS];
    t_prev[0] = 1.0; // T_0
    t_cur[1] = 1.0; // T_1
    for (k, &ck) in c.iter().enumerate().take(COEFFS) {
        let tk = match k {
            0 => t_prev,
            1 => t_cur,
            _ => {
                let mut next = [0.0; COEFFS];
                for i in 0..COEFFS {
                    let shifted = if i > 0 { 2.0 * t_cur[i - 1] } else { 0.0 };
                    next[i] = shifted - t_prev[i];
                }
                t_prev = t_cur;
                t_cur = next;
                next
            }
        };
        for i in 0..COEFFS {
            out[i] += ck * tk[i];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn pieces_join_continuously() {
        let tables = unit_tables();
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
