//! Construction of the kernel's tables (see the crate root): the piecewise polynomials of `K₁`, `R₁` and
//! `h/C₀` on `[−1, 0]` and the derivative polynomials `S̃_n(q)`. Plain `std` only: `build.rs` includes this file to
//! emit the tables as constants at compile time, and the kernel's tests run it again to check them.

use std::f64::consts::PI;

/// Number of table pieces on `[−1, 0]`.
pub const PIECES: usize = 128;
/// Coefficients per piece (degree + 1).
pub const COEFFS: usize = 12;
/// Coefficients per piece of the density `h/C₀` (its Chebyshev tail falls below 10⁻¹⁶ of the peak only
/// after more terms than the integrals need).
pub const DENSITY_COEFFS: usize = 16;
/// Chebyshev points used to build each piece.
pub const SAMPLES: usize = 32;
/// Derivative orders whose polynomials are precomputed; higher orders are built on demand.
pub const TABULATED_ORDERS: usize = 33;
/// `C₀ = ∫_{−1}^{1} exp(−1/(1 − u²)) du`: the paper's normalisation constant is `C = C₀·a` (eq. 33–35).
pub const UNIT_NORMALISATION: f64 = 0.443_993_816_168_079_4;

/// Coefficient `i` of a piece is the pair `[K-coefficient, R-coefficient]`, so both polynomials are
/// evaluated together, two lanes at a time.
pub type Piece = [[f64; 2]; COEFFS];

/// `S̃_n(q) = q^(2n) S_n(1/q)` for `n = 0..count` (coefficients in increasing powers of `q`), from the
/// recurrence `S_{n+1} = 2w² (S_n' − S_n)` (n even), `S_{n+1} = S_n + 2(w² − w)(S_n' − S_n)` (n odd).
pub fn build_derivative_polys(count: usize) -> Vec<Vec<f64>> {
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

/// `h/C₀` at the `SAMPLES` Chebyshev points `u = −1 + (j + ½ + cos θ_i / 2)/PIECES` of piece `j` of
/// `[−1, 0]`, with the angles `θ_i`.
fn density_samples(j: usize) -> (Vec<f64>, Vec<f64>) {
    let n = PIECES as f64;
    let half = 0.5 / n;
    let centre = -1.0 + (j as f64 + 0.5) / n;
    let theta: Vec<f64> = (0..SAMPLES)
        .map(|i| PI * (i as f64 + 0.5) / SAMPLES as f64)
        .collect();
    let f = theta
        .iter()
        .map(|&th| {
            let u = centre + half * th.cos();
            let q = (1.0 - u) * (1.0 + u);
            (-1.0 / q).exp() / UNIT_NORMALISATION
        })
        .collect();
    (theta, f)
}

/// The Chebyshev coefficients of the interpolant through `f` at the angles `theta` (a DCT), the samples
/// first shifted by `offset` (added back to the constant term): shifting by their mean makes the terms of
/// the sums small, and with them the sums' rounding.
fn chebyshev_coefficients(theta: &[f64], f: &[f64], offset: f64) -> Vec<f64> {
    (0..SAMPLES)
        .map(|k| {
            let sum: f64 = f
                .iter()
                .zip(theta)
                .map(|(&fi, &th)| (fi - offset) * (k as f64 * th).cos())
                .sum();
            let ak = sum * if k == 0 { 1.0 } else { 2.0 } / SAMPLES as f64;
            if k == 0 {
                ak + offset
            } else {
                ak
            }
        })
        .collect()
}

/// The `PIECES` pieces of `K₁(u)` and `R₁(u)` on `[−1, 0]`, piece `j` in the local variable `s ∈ [−1, 1]`
/// (`u = −1 + (j + ½ + s/2)/PIECES`): `h/C₀` interpolated at `SAMPLES` Chebyshev points, its Chebyshev
/// series integrated exactly (once for `K`, twice for `R`), the running integrals between the pieces
/// accumulated in double-double arithmetic.
pub fn build_unit_pieces() -> Vec<Piece> {
    let half = 0.5 / PIECES as f64;
    let mut k_left = DoubleDouble::default();
    let mut r_left = DoubleDouble::default();
    let mut pieces = Vec::with_capacity(PIECES);
    for j in 0..PIECES {
        let (theta, f) = density_samples(j);
        let a = chebyshev_coefficients(&theta, &f, 0.0);
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
        let (k, r): ([f64; COEFFS], [f64; COEFFS]) =
            (cheb_to_monomial(&k_series), cheb_to_monomial(&r_series));
        pieces.push(std::array::from_fn(|i| [k[i], r[i]]));
        // Advance the running integrals to the right end (s = 1, where T_k = 1).
        k_left.add(f_series.iter().sum());
        r_left.add(2.0 * half * k0);
        r_left.add(g_series.iter().sum());
    }
    pieces
}

/// The `PIECES` pieces of the unit density `h(u)/C₀` on `[−1, 0]` on the same pieces and in the same local
/// variable as [`build_unit_pieces`]: its Chebyshev interpolant truncated to `DENSITY_COEFFS` terms. The smooth
/// maps take `k(t)` (their second derivatives) from it with the same look-up as `K` and `R`, no exponential.
pub fn build_density_pieces() -> Vec<[f64; DENSITY_COEFFS]> {
    (0..PIECES)
        .map(|j| {
            let (theta, f) = density_samples(j);
            let mean = f.iter().sum::<f64>() / SAMPLES as f64;
            // Unshifted, the sums' rounding puts ≈ 3·10⁻¹⁶ of noise into every coefficient.
            cheb_to_monomial(&chebyshev_coefficients(&theta, &f, mean))
        })
        .collect()
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

/// Truncates a Chebyshev series to `N` terms (`COEFFS` for `K` and `R`, whose tails are below 10⁻¹⁸;
/// `DENSITY_COEFFS` for `h/C₀`) and converts it to monomials.
fn cheb_to_monomial<const N: usize>(c: &[f64]) -> [f64; N] {
    let mut out = [0.0; N];
    let mut t_prev = [0.0; N];
    let mut t_cur = [0.0; N];
    t_prev[0] = 1.0; // T_0
    t_cur[1] = 1.0; // T_1
    for (k, &ck) in c.iter().enumerate().take(N) {
        let tk = match k {
            0 => t_prev,
            1 => t_cur,
            _ => {
                let mut next = [0.0; N];
                for i in 0..N {
                    let shifted = if i > 0 { 2.0 * t_cur[i - 1] } else { 0.0 };
                    next[i] = shifted - t_prev[i];
                }
                t_prev = t_cur;
                t_cur = next;
                next
            }
        };
        for i in 0..N {
            out[i] += ck * tk[i];
        }
    }
    out
}

/// Rust source of the tables as constants: `UNIT_PIECES: [Piece; PIECES]`, `UNIT_DENSITY` and
/// `DERIVATIVE_POLYS: [&[f64]; TABULATED_ORDERS]` (each `f64` printed in its shortest round-trip form, so
/// the constants are bit for bit the values built here).
pub fn tables_source() -> String {
    use std::fmt::Write;
    let mut src =
        String::from("// Generated by build.rs from src/kernel/construction.rs; do not edit.\n");
    let _ = writeln!(src, "pub(super) static UNIT_PIECES: [Piece; {PIECES}] = [");
    for piece in build_unit_pieces() {
        src.push_str("    [");
        for [k, r] in piece {
            let _ = write!(src, "[{k:?}, {r:?}], ");
        }
        src.push_str("],\n");
    }
    src.push_str("];\n");
    let _ = writeln!(
        src,
        "pub(super) static UNIT_DENSITY: [[f64; {DENSITY_COEFFS}]; {PIECES}] = ["
    );
    for piece in build_density_pieces() {
        src.push_str("    [");
        for c in piece {
            let _ = write!(src, "{c:?}, ");
        }
        src.push_str("],\n");
    }
    src.push_str("];\n");
    let _ = writeln!(
        src,
        "pub(super) static DERIVATIVE_POLYS: [&[f64]; {TABULATED_ORDERS}] = ["
    );
    for poly in build_derivative_polys(TABULATED_ORDERS) {
        src.push_str("    &[");
        for c in poly {
            let _ = write!(src, "{c:?}, ");
        }
        src.push_str("],\n");
    }
    src.push_str("];\n");
    src
}
