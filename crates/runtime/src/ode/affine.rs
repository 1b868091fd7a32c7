//! One state with affine dynamics, η' = a(t) η + b(t), integrated by the variation of constants (Hairer,
//! Nørsett & Wanner, *Solving ODEs I*, §I.3), so that the stiffness of a costs nothing: a mode's zero
//! dynamics where the derivation found them affine in η (`ModelInfo::zero_dynamics_affine`; an intake
//! manifold's filling, a ≈ −25 1/s, which bounds an explicit method's step by stability).
//!
//! Over a sub-interval [τ, τ + H], with x = (s − τ)/H and A(s) = ∫_τ^s a,
//!
//! ```text
//! η(τ + H) = e^(A(τ+H)) η(τ) + H ∫_0^1 e^(A(τ+H) − A(τ+xH)) b(τ + xH) dx.
//! ```
//!
//! a and b are taken at the m Gauss–Legendre nodes x_i (a_i, b_i). With the mean ā = Σ w_i a_i (Gauss's
//! quadrature of A(τ + H)/H, exact for a of degree 2m − 1), z = āH and the remainder
//! D(x) = A(τ+H) − A(τ+xH) − z(1 − x) = H ∫_x^1 (a − ā), the exponent splits into the stiff linear part and
//! a smooth one: D_i = H Σ_j T_ij (a_j − ā), T_ij = ∫_(x_i)^1 ℓ_j (ℓ_j the Lagrange basis of the nodes), and
//! with g(x) = e^(D(x)) b(τ + xH) interpolated at the nodes in Legendre polynomials,
//! g ≈ Σ_k ĝ_k P_k(2x − 1), ĝ_k = (2k + 1) Σ_i w_i P_k(2x_i − 1) g_i (Gauss's discrete orthogonality),
//!
//! ```text
//! η(τ + H) ≈ e^z η(τ) + H Σ_k ĝ_k μ_k(z),   μ_k(z) = ∫_0^1 e^(z(1−x)) P_k(2x − 1) dx
//!          = Σ_j (−1)^(k+j) C(k, j) C(k+j, j) j! φ_(j+1)(z),   φ_j(z) = Σ_(i≥0) z^i/(i + j)!
//! ```
//!
//! (∫_0^1 e^(z(1−x)) x^j dx = j! φ_(j+1)(z), the φ-functions of exponential integrators: Hochbruck &
//! Ostermann, *Exponential integrators*, Acta Numerica 2010, §2). The only approximation is the interpolation
//! of the smooth g (and of a inside D); the error estimate bounds the last Legendre term's share,
//! H |ĝ_(m−1)| |μ_(m−1)|‾ + H |â_(m−1)| |I|/(2m + 1) (|μ|‾ a bound free of the cancellation in the highest
//! μ's sums, [`mu_bound`]; I the integral, â the coefficients of a: D_i's error is at most
//! H |â_m|/(2m + 1), since |∫_x^1 P_m(2s − 1) ds| ≤ 1/(2m + 1)), held within 10⁻⁸·|η| + 10⁻¹² like
//! DOP853's (the sub-interval shrunk or grown by 0.9·ratio^(−1/(m−1)), the estimate falling at least as
//! H^(m−1); at most [`MAX_SUB_STEPS`] a call). The bound is pessimistic: the results lie within 10⁻¹² of a
//! DOP853 run at rtol 10⁻¹³ (`modes/zd_ode.rs`). e^z is exact however stiff a is: an interval of DOP853 steps
//! bounded by e^(hλ) (about six 12-stage steps a second at λ = −25) becomes a sub-interval of m = 12 nodes,
//! each node one evaluation of a and b (or two of η', at η = 0 and η = s: b and a) at one time.

use std::sync::OnceLock;

use super::{OdeStats, StepFailure};
use crate::binomial::binomial;

/// The most nodes a sub-interval has.
pub(crate) const NODES_MAX: usize = 12;
/// Sub-intervals one call may take (accepted or rejected).
const MAX_SUB_STEPS: usize = 100_000;
/// The error the estimate is held within: RTOL·max(|η(τ)|, |η(τ + H)|) + ATOL.
const RTOL: f64 = 1e-8;
const ATOL: f64 = 1e-12;

/// The integrator of η' = a(t) η + b(t) (module docs): its node tables and the sub-interval it proposes.
pub(crate) struct AffineScalar {
    nodes: &'static Nodes,
    /// The sub-interval the next call starts with (∞: the whole interval).
    h: f64,
    pub(crate) stats: OdeStats,
}

/// The tables of m Gauss–Legendre nodes (made once per m for the process: [`Nodes::of`]).
struct Nodes {
    m: usize,
    /// Nodes and weights on [0, 1].
    x: [f64; NODES_MAX],
    w: [f64; NODES_MAX],
    /// `legendre[k][i]` = (2k + 1) w_i P_k(2x_i − 1): ĝ_k = Σ_i legendre[k][i] g_i.
    legendre: [[f64; NODES_MAX]; NODES_MAX],
    /// `tail[i][j]` = ∫_(x_i)^1 ℓ_j.
    tail: [[f64; NODES_MAX]; NODES_MAX],
    /// `moments[k][j]` = (−1)^(k+j) C(k, j) C(k+j, j) j!: μ_k = Σ_j moments[k][j] φ_(j+1).
    moments: [[f64; NODES_MAX]; NODES_MAX],
    /// 1/k! for k = 0 … NODES_MAX (the φ-functions' recurrences).
    inv_factorial: [f64; NODES_MAX + 1],
    /// Half the largest ratio of estimate to tolerance at which a sub-interval grows by the most (×4:
    /// 0.9·ratio^(−1/(m−1)) ≥ 4), the half a margin for powf's rounding.
    grow_most_below: f64,
}

impl AffineScalar {
    /// With `m` Gauss–Legendre nodes a sub-interval (2 … [`NODES_MAX`]).
    pub(crate) fn new(m: usize) -> AffineScalar {
        AffineScalar {
            nodes: Nodes::of(m),
            h: f64::INFINITY,
            stats: OdeStats::default(),
        }
    }

    /// The sub-interval the next call starts with.
    pub(crate) fn step_size(&self) -> f64 {
        self.h
    }

    /// Start the next call with sub-interval `h` (≤ 0 or not finite: the whole interval).
    pub(crate) fn reset(&mut self, h: f64) {
        self.h = if h > 0.0 && h.is_finite() {
            h
        } else {
            f64::INFINITY
        };
    }

    /// η from t0 to t1 in place, `ab(t)` giving (a(t), b(t)).
    pub(crate) fn advance<F>(
        &mut self,
        (t0, t1): (f64, f64),
        eta: &mut f64,
        ab: &mut F,
    ) -> Result<(), StepFailure>
    where
        F: FnMut(f64) -> Result<(f64, f64), StepFailure>,
    {
        let mut t = t0;
        let mut h = self.h.min(t1 - t0);
        for _ in 0..MAX_SUB_STEPS {
            if t >= t1 {
                return Ok(());
            }
            // The last sub-interval ends at t1 exactly (and one barely short of it is stretched to it).
            let last = t + 1.01 * h >= t1;
            let hs = if last { t1 - t } else { h };
            let (next, ratio) = self.sub_step((t, hs), *eta, ab)?;
            let factor = if ratio <= self.nodes.grow_most_below {
                4.0
            } else {
                (0.9 * ratio.powf(-1.0 / (self.nodes.m - 1) as f64)).clamp(0.2, 4.0)
            };
            if ratio <= 1.0 {
                self.stats.accepted += 1;
                *eta = next;
                t = if last { t1 } else { t + hs };
                h = hs * factor;
                // The proposal for the next call: the step that served (not the remainder of this interval).
                self.h = if last { h.max(hs) } else { h };
            } else {
                self.stats.rejected += 1;
                h = hs * factor.min(0.9);
                if h <= super::h_min(t) {
                    return Err(StepFailure {
                        t,
                        reason: format!(
                            "step size too small ({h:e} s) for the affine zero dynamics"
                        ),
                    });
                }
            }
        }
        Err(StepFailure {
            t,
            reason: format!("more than {MAX_SUB_STEPS} sub-intervals for the affine zero dynamics"),
        })
    }

    /// η(τ + H) from η(τ) (module docs) and the ratio of the error estimate to the tolerance: the sums
    /// over M = m nodes where m is one of the sizes served (a loop the compiler unrolls), else over
    /// [`NODES_MAX`] (the tables are zero beyond m, as are a and b: the same sums).
    fn sub_step<F>(
        &mut self,
        span: (f64, f64),
        eta: f64,
        ab: &mut F,
    ) -> Result<(f64, f64), StepFailure>
    where
        F: FnMut(f64) -> Result<(f64, f64), StepFailure>,
    {
        // One evaluation of a and b a node (two of η' for a model without them: `modes/zd_ode.rs`).
        self.stats.evaluations += self.nodes.m;
        match self.nodes.m {
            5 => sub_step_of::<5, F>(self.nodes, span, eta, ab),
            _ => sub_step_of::<NODES_MAX, F>(self.nodes, span, eta, ab),
        }
    }
}

/// [`AffineScalar::sub_step`] with its sums over the first M nodes (M ≥ m).
#[inline(always)]
fn sub_step_of<const M: usize, F>(
    n: &Nodes,
    (tau, h): (f64, f64),
    eta: f64,
    ab: &mut F,
) -> Result<(f64, f64), StepFailure>
where
    F: FnMut(f64) -> Result<(f64, f64), StepFailure>,
{
    let m = n.m;
    let (mut a, mut b) = ([0.0; M], [0.0; M]);
    for i in 0..m {
        (a[i], b[i]) = ab(tau + n.x[i] * h)?;
    }
    let dot = |row: &[f64; NODES_MAX], v: &[f64; M]| -> f64 {
        row[..M].iter().zip(v).map(|(r, v)| r * v).sum()
    };
    let abar = dot(&n.w, &a);
    let z = abar * h;
    let deviation: [f64; M] = std::array::from_fn(|j| a[j] - abar);
    let g: [f64; M] = std::array::from_fn(|i| (h * dot(&n.tail[i], &deviation)).exp() * b[i]);
    let phi = phi_functions(z, M, &n.inv_factorial);
    let phi_next: [f64; M] = std::array::from_fn(|j| phi[j + 1]);
    let terms: [f64; M] = std::array::from_fn(|k| {
        let moments: &[f64; NODES_MAX] = &n.moments[k];
        dot(&n.legendre[k], &g)
            * moments[..M]
                .iter()
                .zip(&phi_next)
                .map(|(r, v)| r * v)
                .sum::<f64>()
    });
    let integral = h * terms.iter().sum::<f64>();
    let next = phi[0] * eta + integral;
    if !next.is_finite() {
        return Err(StepFailure {
            t: tau,
            reason: format!(
                "the affine zero dynamics are not finite (a = {abar:e} 1/s over {h:e} s)"
            ),
        });
    }
    let a_tail = dot(&n.legendre[m - 1], &a).abs();
    let g_tail = dot(&n.legendre[m - 1], &g).abs();
    let tolerance = ATOL + RTOL * eta.abs().max(next.abs());
    let rest = h * a_tail * integral.abs() / (2 * m + 1) as f64;
    // The bound of |μ_(m−1)| without its series first: where the estimate with it is so small that the next
    // sub-interval grows by the most anyway, the series (which can only lower it) would change nothing.
    let cheap = mu_bound_cheap(m - 1, (&n.moments[m - 1], &phi));
    let ratio = (h * g_tail * cheap + rest) / tolerance;
    if ratio <= n.grow_most_below {
        return Ok((next, ratio));
    }
    let mu_bound = mu_series_bound(z, m - 1, cheap);
    let estimate = h * g_tail * mu_bound + rest;
    Ok((next, estimate / tolerance))
}

impl Nodes {
    /// The tables of `m` nodes (2 … [`NODES_MAX`]), made the first time they are asked for.
    fn of(m: usize) -> &'static Nodes {
        static TABLES: [OnceLock<Nodes>; NODES_MAX + 1] =
            [const { OnceLock::new() }; NODES_MAX + 1];
        let m = m.clamp(2, NODES_MAX);
        TABLES[m].get_or_init(|| Nodes::new(m))
    }

    fn new(m: usize) -> Nodes {
        let (x, w) = gauss_legendre(m);
        let mut s = Nodes {
            m,
            x,
            w,
            legendre: [[0.0; NODES_MAX]; NODES_MAX],
            tail: [[0.0; NODES_MAX]; NODES_MAX],
            moments: [[0.0; NODES_MAX]; NODES_MAX],
            inv_factorial: std::array::from_fn(|k| 1.0 / factorial(k)),
            grow_most_below: 0.5 * (0.9f64 / 4.0).powi(m as i32 - 1),
        };
        for (i, (&xi, &wi)) in x.iter().zip(&w).take(m).enumerate() {
            let p = legendre_values(2.0 * xi - 1.0, m + 1);
            for (k, (row, pk)) in s.legendre.iter_mut().zip(p).take(m).enumerate() {
                row[i] = (2 * k + 1) as f64 * wi * pk;
            }
        }
        // ∫_(x_i)^1 P_k(2x − 1) dx: (1 − x_i) for k = 0, else −(P_(k+1) − P_(k−1))(2x_i − 1)/(2(2k + 1)).
        for (i, &xi) in x.iter().take(m).enumerate() {
            let p = legendre_values(2.0 * xi - 1.0, m + 1);
            let integral = |k: usize| match k {
                0 => 1.0 - xi,
                _ => -(p[k + 1] - p[k - 1]) / (2 * (2 * k + 1)) as f64,
            };
            let row: [f64; NODES_MAX] =
                std::array::from_fn(|j| (0..m).map(|k| s.legendre[k][j] * integral(k)).sum());
            s.tail[i] = row;
        }
        for k in 0..m {
            for j in 0..=k {
                let sign = if (k + j) % 2 == 0 { 1.0 } else { -1.0 };
                s.moments[k][j] = sign * binomial(k, j) * binomial(k + j, j) * factorial(j);
            }
        }
        s
    }
}

/// An upper bound of |μ_k(z)| free of the cancellation in its sum of φ-terms (`row` its coefficients): the
/// least of φ_1(z) (|P_k| ≤ 1), the computed sum plus 10⁻¹³ of its terms' size (rounding), and, where |z| < 12
/// (the sum's terms there far above μ_k), Σ_(i≥k) |z|^i i!/((i−k)!(i+k+1)!), the absolute series of
/// μ_k(z) = (−1)^k Σ_(i≥k) z^i i!/((i−k)!(i+k+1)!) (∫_0^1 y^i P_k(2y − 1) dy = i!²/((i−k)!(i+k+1)!)).
#[cfg(test)]
fn mu_bound(z: f64, k: usize, (row, phi): (&[f64; NODES_MAX], &[f64; NODES_MAX + 1])) -> f64 {
    mu_series_bound(z, k, mu_bound_cheap(k, (row, phi)))
}

/// The first two of [`mu_bound`]'s bounds: the least of φ_1(z) and the computed sum plus 10⁻¹³ of its terms'
/// size.
fn mu_bound_cheap(k: usize, (row, phi): (&[f64; NODES_MAX], &[f64; NODES_MAX + 1])) -> f64 {
    let (sum, size) = (0..=k)
        .map(|j| row[j] * phi[j + 1])
        .fold((0.0, 0.0), |(s, a), t| (s + t, a + t.abs()));
    phi[1].min(sum.abs() + 1e-13 * size)
}

/// `bound` lowered to [`mu_bound`]'s absolute series where that converges below it (|z| < 12).
fn mu_series_bound(z: f64, k: usize, mut bound: f64) -> f64 {
    if z.abs() < 12.0 {
        let mut term = z.abs().powi(k as i32) * factorial(k) / factorial(2 * k + 1);
        let mut series = 0.0;
        for i in k..k + 120 {
            series += term;
            if series >= bound {
                break;
            }
            if term <= 1e-17 * series {
                bound = series;
                break;
            }
            term *= z.abs() * (i + 1) as f64 / ((i + 1 - k) * (i + k + 2)) as f64;
        }
    }
    bound
}

/// Gauss–Legendre nodes and weights of `m` points on [0, 1] (Newton's method on P_m from Tricomi's
/// estimate cos(π(i + 3/4)/(m + 1/2)); the weights 2/((1 − ξ²) P_m'(ξ)²), halved).
fn gauss_legendre(m: usize) -> ([f64; NODES_MAX], [f64; NODES_MAX]) {
    let (mut x, mut w) = ([0.0; NODES_MAX], [0.0; NODES_MAX]);
    for i in 0..m {
        let mut xi = (std::f64::consts::PI * (i as f64 + 0.75) / (m as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let p = legendre_values(xi, m);
            // P_m' = m (ξ P_m − P_(m−1))/(ξ² − 1)
            dp = m as f64 * (xi * p[m] - p[m - 1]) / (xi * xi - 1.0);
            let dx = p[m] / dp;
            xi -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        // Increasing on [0, 1]: the estimate runs from the largest root down.
        x[m - 1 - i] = 0.5 * (1.0 + xi);
        w[m - 1 - i] = 1.0 / ((1.0 - xi * xi) * dp * dp);
    }
    (x, w)
}

/// P_0(ξ) … P_n(ξ) by Bonnet's recurrence (k + 1) P_(k+1) = (2k + 1) ξ P_k − k P_(k−1).
fn legendre_values(xi: f64, n: usize) -> [f64; NODES_MAX + 2] {
    let mut p = [0.0; NODES_MAX + 2];
    p[0] = 1.0;
    if n >= 1 {
        p[1] = xi;
    }
    for k in 1..n {
        p[k + 1] = ((2 * k + 1) as f64 * xi * p[k] - k as f64 * p[k - 1]) / (k + 1) as f64;
    }
    p
}

/// φ_0(z) … φ_m(z): for |z| ≤ 2 φ_m by its series and φ_(k) = z φ_(k+1) + 1/k! downwards (stable there);
/// else φ_1 = (e^z − 1)/z and φ_(k+1) = (φ_k − 1/k!)/z upwards (each step divides the rounding by |z| > 2).
fn phi_functions(z: f64, m: usize, inv_factorial: &[f64; NODES_MAX + 1]) -> [f64; NODES_MAX + 1] {
    let mut phi = [0.0; NODES_MAX + 1];
    phi[0] = z.exp();
    if z.abs() <= 2.0 {
        // Σ_(i≥0) z^i/(i + m)!: 2^i/(i + m)! < 10⁻¹⁸ by i = 25.
        let (mut term, mut sum) = (inv_factorial[m], 0.0);
        for i in 0..26 {
            sum += term;
            term *= z / (i + m + 1) as f64;
        }
        phi[m] = sum;
        for k in (1..m).rev() {
            phi[k] = z * phi[k + 1] + inv_factorial[k];
        }
    } else {
        phi[1] = z.exp_m1() / z;
        for k in 1..m {
            phi[k + 1] = (phi[k] - inv_factorial[k]) / z;
        }
    }
    phi
}

fn factorial(k: usize) -> f64 {
    (1..=k).map(|i| i as f64).product()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫_0^1 of x^p by the nodes is exact up to p = 2m − 1, and the tail matrix integrates x^p (p < m)
    /// from each node to 1 exactly.
    #[test]
    fn the_node_tables_integrate_polynomials() {
        for m in 2..=NODES_MAX {
            let s = Nodes::of(m);
            for p in 0..2 * m {
                let q: f64 = (0..m).map(|i| s.w[i] * s.x[i].powi(p as i32)).sum();
                assert!((q - 1.0 / (p + 1) as f64).abs() < 1e-14, "m {m} p {p}: {q}");
            }
            for p in 0..m {
                for i in 0..m {
                    let q: f64 = (0..m).map(|j| s.tail[i][j] * s.x[j].powi(p as i32)).sum();
                    let exact = (1.0 - s.x[i].powi(p as i32 + 1)) / (p + 1) as f64;
                    assert!(
                        (q - exact).abs() < 1e-13,
                        "m {m} p {p} node {i}: {q} against {exact}"
                    );
                }
            }
        }
    }

    /// μ_k(z) = ∫_0^1 e^(z(1−x)) P_k(2x − 1) dx from the φ-functions against composite Gauss quadrature
    /// (400 panels of the nodes), from a stiff decay to a growth: within 10⁻¹³ of the size of the sum's terms
    /// Σ_j |C_kj φ_(j+1)| (rounding's bound for a sum; the highest μ_k cancel digits, at z = −3 μ_11 ≈ 6·10⁻¹¹
    /// from terms up to 10⁶, harmless where they serve: μ_k multiplies ĝ_k, the smooth g's small Legendre
    /// coefficient) and of 10⁻¹² of μ_0's; [`mu_bound`] above |μ_k| and within a factor of 30 of it.
    #[test]
    fn the_moments_equal_their_integrals() {
        let s = Nodes::of(NODES_MAX);
        for z in [
            -400.0, -60.0, -25.0, -3.0, -2.0, -1.0, -1e-3, 0.0, 0.5, 2.5, 8.0,
        ] {
            let phi = phi_functions(z, NODES_MAX, &s.inv_factorial);
            for k in 0..NODES_MAX {
                let terms = (0..=k).map(|j| s.moments[k][j] * phi[j + 1]);
                let (mu, size): (f64, f64) =
                    terms.fold((0.0, 0.0), |(m, a), t| (m + t, a + t.abs()));
                let panels = 400;
                let mut q = 0.0;
                for p in 0..panels {
                    for i in 0..NODES_MAX {
                        let x = (p as f64 + s.x[i]) / panels as f64;
                        let pk = legendre_values(2.0 * x - 1.0, k)[k];
                        q += s.w[i] / panels as f64 * (z * (1.0 - x)).exp() * pk;
                    }
                }
                let scale = 1.0f64.max(z.exp()) / (1.0 + z.abs());
                assert!(
                    (mu - q).abs() < 1e-13 * size + 1e-12 * scale,
                    "z {z} k {k}: {mu:e} against {q:e} (terms {size:e})"
                );
                // The error estimate's bound holds, and is within a factor of 30 where μ_k is not tiny.
                let bound = mu_bound(z, k, (&s.moments[k], &phi));
                // (the quadrature's own rounding is about 10⁻¹⁶ of μ_0's size)
                let floor = q.abs() * (1.0 - 1e-9) - 1e-14 * scale;
                assert!(bound >= floor, "z {z} k {k}: {bound:e} below {q:e}");
                assert!(
                    bound <= 30.0 * q.abs() + 1e-12 * scale,
                    "z {z} k {k}: {bound:e} for {q:e}"
                );
            }
        }
    }

    /// η' = a(t) η + b(t) with a = −λ − 3 sin(0.7 t), b = g' − a g has η = g + (η₀ − g(0)) e^(A(t)),
    /// A = ∫_0^t a; started off g, over 20 s in intervals of 1, 0.1 and 0.01 s, at the manifold's stiffness
    /// (λ = 25) and without it (λ = 0.2), and for a = 0 (η' = b): within 10⁻⁹ of η's largest value.
    #[test]
    fn stiff_affine_dynamics_follow_their_exact_solution() {
        let g = |t: f64| 2e4 + 3e3 * (0.7 * t).sin() + 1e3 * (2.1 * t).cos();
        let dg = |t: f64| 2.1e3 * (0.7 * t).cos() - 2.1e3 * (2.1 * t).sin();
        for (lambda, wobble) in [(25.0, 3.0), (0.2, 0.1), (0.0, 0.0)] {
            let a = |t: f64| -lambda - wobble * (0.7 * t).sin();
            let big_a = |t: f64| -lambda * t + wobble / 0.7 * ((0.7 * t).cos() - 1.0);
            let eta0 = g(0.0) + 5e3;
            let exact = |t: f64| g(t) + (eta0 - g(0.0)) * big_a(t).exp();
            let mut ab = |t: f64| Ok((a(t), dg(t) - a(t) * g(t)));
            for (dt, m) in [(1.0f64, 8), (0.1, 4), (0.01, 4)] {
                let mut s = AffineScalar::new(m);
                let mut eta = eta0;
                let mut worst = 0.0f64;
                for k in 0..(20.0 / dt).round() as usize {
                    let (t0, t1) = (k as f64 * dt, (k + 1) as f64 * dt);
                    s.advance((t0, t1), &mut eta, &mut ab).expect("integrates");
                    worst = worst.max((eta - exact(t1)).abs());
                }
                let rel = worst / 2.6e4;
                assert!(rel < 1e-9, "λ {lambda} dt {dt}: {rel:e}");
            }
        }
    }
}
