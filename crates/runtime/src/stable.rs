//! Stable (non-causal) inversion of unstable zero dynamics (Devasia, Chen & Paden, IEEE TAC 41(7), 1996; Hunt &
//! Meyer, Automatica 33(8), 1997), as applied to drive cycles by Fröberg & Nielsen (IEEE TVT 57(3), 2008).
//!
//! # The problem
//!
//! For r < n the internal coordinates follow η̇ = q(ξ(t), η, y_d^(r)(t)) (Isidori, *Nonlinear Control Systems*,
//! §4.3). When ∂q/∂η has eigenvalues in the right half-plane (a non-minimum-phase system) integrating forward
//! from any η(t_0) blows up. Because the whole reference is known in advance, the *bounded* solution can be
//! computed instead: with A = ∂q/∂η split into its stable and unstable invariant subspaces E^s ⊕ E^u, the
//! bounded solution of the linearisation is (Devasia, Chen & Paden 1996, the linear time-invariant case)
//!
//! ```text
//! η(t) = ∫_{−∞}^{t} e^{A(t−τ)} P_s b(τ) dτ − ∫_{t}^{∞} e^{A(t−τ)} P_u b(τ) dτ,
//! ```
//!
//! i.e. the stable part integrated forward from the start and the unstable part backward from the end, and for
//! the nonlinear zero dynamics it is the solution of the boundary-value problem (Devasia–Chen–Paden solve it
//! as a fixed point around this linear one, Hunt & Meyer as a boundary-value problem in η)
//!
//! ```text
//! η̇ = q(ξ(t), η, y_d^(r)(t)) on [t_a, t_b],   P_s(a)(η(t_a) − η_a) = 0,   P_u(b)(η(t_b) − η_b) = 0,
//! ```
//!
//! where η_a, η_b are the equilibria of the zero dynamics for the constant reference before the cycle starts and
//! after it ends and P_s(a), P_u(b) the spectral projections of ∂q/∂η there: η leaves η_a along its unstable
//! manifold and arrives at η_b along its stable manifold. The reference is constant outside
//! [first corner − a, last corner + a] (the smoother's support), so ξ is known everywhere; the time grid is
//! extended before the cycle (pre-actuation) and after it (post-actuation) until the deviation from the
//! equilibria has decayed below the tolerance: T_pre = ln(1/tol)/min Re λ_u(a), T_post = ln(1/tol)/min |Re λ_s(b)|.
//!
//! # The method
//!
//! The boundary-value problem is discretised by Hermite–Simpson collocation (the 3-stage Lobatto IIIA method,
//! order 4, A-stable and symmetric, so it treats decaying and growing modes alike; Ascher, Mattheij & Russell,
//! *Numerical Solution of Boundary Value Problems for ODEs*, 1995, on symmetric collocation and dichotomy):
//!
//! ```text
//! η_{j+1} − η_j − h/6 (q_j + 4 q_{j+½} + q_{j+1}) = 0,   η_{j+½} = (η_j + η_{j+1})/2 + h/8 (q_j − q_{j+1}),
//! ```
//!
//! and solved by Newton's method on all nodes at once (the Newton step is the linear boundary-value problem
//! whose bounded solution is the formula above: the "integrate the stable part forward and the unstable part
//! backward" of the linearisation). The Jacobian is block bidiagonal plus the boundary rows, a band matrix
//! solved by Gaussian elimination with partial pivoting — for purely unstable zero dynamics an upper bidiagonal
//! matrix, whose back substitution is exactly the backward integration. Newton starts from the quasi-static
//! equilibria; it stops when the scaled step is below 1 % of the tolerance, with a clear error if it does not
//! converge.
//! The step size is chosen from the look-ahead, the solution computed on a grid and on the grid halved, and the
//! difference (Richardson: error ≈ difference/15 for order 4) must be below the tolerance, else the grid is
//! refined. Between nodes η is the collocation polynomial, the cubic Hermite interpolant of (η_j, q_j).

use invsim_model_api::InverseModel;
use nalgebra::{DMatrix, DVector};

use crate::cycle::Cycle;
use crate::simulate::{fmt_sig, SimulateError, SimulationOptions, MAX_DERIVATIVES};
use crate::smoother::Smoother;

pub use invsim_model_api::linearize::ZeroDynamicsClass;
use invsim_model_api::linearize::{eigenvalues, jacobian};

/// Largest number of collocation nodes (memory guard: about 100 bytes per node and internal state).
const MAX_NODES: usize = 20_000_000;

/// Newton iterations on the boundary-value problem before giving up.
const MAX_NEWTON: usize = 30;

// --- small numeric helpers ---------------------------------------------------------------------------------

/// Max over the nodes of |v_i|/scale_i (NaN propagates).
fn scaled_norm(v: &[f64], scale: &[f64]) -> f64 {
    v.chunks_exact(scale.len())
        .flat_map(|node| node.iter().zip(scale).map(|(v, s)| v.abs() / s))
        .fold(0.0_f64, |a, v| {
            if v.is_nan() || a.is_nan() {
                f64::NAN
            } else {
                a.max(v)
            }
        })
}

/// Max norm that propagates NaN (f64::max would drop it).
fn max_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |a, x| {
        if x.is_nan() || a.is_nan() {
            f64::NAN
        } else {
            a.max(x.abs())
        }
    })
}

/// Tolerance below which a real part counts as zero (finite-difference noise): 1e-9 + 1e-7·‖A‖_max.
fn critical_tol(a: &DMatrix<f64>) -> f64 {
    1e-9 + 1e-7 * a.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

/// Damped Newton's method for q(ξ, η, y^(r)) = 0 from `eta`; `None` if it fails.
fn newton_equilibrium<M: InverseModel + ?Sized>(
    model: &M,
    xi: &[f64],
    yr: f64,
    mut eta: Vec<f64>,
    max_iter: usize,
) -> Option<Vec<f64>> {
    let m = eta.len();
    let mut q = vec![0.0; m];
    let mut trial = vec![0.0; m];
    let mut q_trial = vec![0.0; m];
    model.zero_dynamics(xi, &eta, yr, &mut q);
    for _ in 0..max_iter {
        let res = max_norm(&q);
        if !res.is_finite() {
            return None;
        }
        if res == 0.0 {
            return Some(eta);
        }
        let step = jacobian(model, xi, &eta, yr)
            .lu()
            .solve(&DVector::from_column_slice(&q))?;
        if step.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let mut lambda = 1.0;
        let mut accepted = false;
        for _ in 0..40 {
            for i in 0..m {
                trial[i] = eta[i] - lambda * step[i];
            }
            model.zero_dynamics(xi, &trial, yr, &mut q_trial);
            let r = max_norm(&q_trial);
            if r.is_finite() && r < res {
                accepted = true;
                break;
            }
            lambda *= 0.5;
        }
        let eta_norm = max_norm(&eta);
        if !accepted {
            // No decrease possible: converged to rounding level if the full step is negligible.
            return (max_norm(step.as_slice()) <= 1e-9 * (1.0 + eta_norm)).then_some(eta);
        }
        eta.copy_from_slice(&trial);
        q.copy_from_slice(&q_trial);
        if lambda * max_norm(step.as_slice()) <= 1e-13 * (1.0 + eta_norm) {
            return Some(eta);
        }
    }
    None
}

/// An equilibrium q(ξ, η, y^(r)) = 0: Newton's method from `guess` if given, else from several starting points
/// (η = 0; η = ξ1 in every component — internal states often share the output's scale, as pressures do —;
/// ±1; ±10^k): the first that converges.
pub(crate) fn equilibrium<M: InverseModel + ?Sized>(
    model: &M,
    xi: &[f64],
    yr: f64,
    guess: Option<&[f64]>,
) -> Option<Vec<f64>> {
    let m = model.info().n_eta;
    if let Some(g) = guess {
        if let Some(e) = newton_equilibrium(model, xi, yr, g.to_vec(), 100) {
            return Some(e);
        }
    }
    let mut starts = vec![0.0, xi.first().copied().unwrap_or(0.0), 1.0, -1.0];
    for k in [-2, 1, 2, 3, 4, 5, 6] {
        starts.push(10f64.powi(k));
        starts.push(-(10f64.powi(k)));
    }
    starts
        .into_iter()
        .find_map(|s| newton_equilibrium(model, xi, yr, vec![s; m], 100))
}

// --- classification along the reference ------------------------------------------------------------------

/// The zero dynamics at one constant output value y (ξ = (y, 0, …), y^(r) = 0).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Level {
    pub y: f64,
    pub eta: Vec<f64>,
    pub eigenvalues: Vec<[f64; 2]>,
    /// Number of eigenvalues with Re > tol; `None` if one lies on the imaginary axis or none are computable.
    pub unstable: Option<usize>,
    /// Some eigenvalue has Re > tol (clearly unstable, whatever the others do).
    pub has_unstable: bool,
}

/// The zero dynamics at the equilibria the reference passes.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ReferenceClassification {
    pub class: ZeroDynamicsClass,
    /// At the reference's first value.
    pub start: Option<Level>,
    /// Two levels whose numbers of unstable eigenvalues differ, if any.
    pub change: Option<(Level, Level)>,
    /// Number of unstable eigenvalues (where the class is not unknown).
    pub unstable: usize,
    /// Some level has an eigenvalue with positive real part (beyond finite-difference noise).
    pub any_unstable: bool,
}

fn level<M: InverseModel + ?Sized>(model: &M, y: f64, guess: Option<&[f64]>) -> Option<Level> {
    let r = model.info().relative_degree;
    let mut xi = [0.0; MAX_DERIVATIVES];
    xi[0] = y;
    let eta = equilibrium(model, &xi[..r], 0.0, guess)?;
    let a = jacobian(model, &xi[..r], &eta, 0.0);
    let eigs = eigenvalues(&a);
    let tol = critical_tol(&a);
    let unstable = (!eigs.is_empty() && eigs.iter().all(|e| e[0].abs() > tol))
        .then(|| eigs.iter().filter(|e| e[0] > tol).count());
    let has_unstable = eigs.iter().any(|e| e[0] > tol);
    Some(Level {
        y,
        eta,
        eigenvalues: eigs,
        unstable,
        has_unstable,
    })
}

/// Classify the zero dynamics at the equilibria the reference passes: the output held at y for every y in
/// [y_lo, y_hi] (16 levels each way from `y_start`, by continuation), linearised there (Isidori §4.3).
pub(crate) fn classify_reference<M: InverseModel + ?Sized>(
    model: &M,
    y_start: f64,
    y_lo: f64,
    y_hi: f64,
) -> ReferenceClassification {
    let m = model.info().n_eta;
    if m == 0 {
        return ReferenceClassification {
            class: ZeroDynamicsClass::None,
            start: None,
            change: None,
            unstable: 0,
            any_unstable: false,
        };
    }
    let Some(start) = level(model, y_start, None) else {
        return ReferenceClassification {
            class: ZeroDynamicsClass::Unknown,
            start: None,
            change: None,
            unstable: 0,
            any_unstable: false,
        };
    };
    let mut levels = vec![start.clone()];
    const STEPS: usize = 16;
    for target in [y_hi, y_lo] {
        let mut previous = start.eta.clone();
        if target == y_start {
            continue;
        }
        for s in 1..=STEPS {
            let y = y_start + (target - y_start) * s as f64 / STEPS as f64;
            if let Some(l) = level(model, y, Some(&previous)) {
                previous = l.eta.clone();
                levels.push(l);
            }
        }
    }
    let change = levels
        .iter()
        .find(|l| l.unstable != start.unstable)
        .map(|l| (start.clone(), l.clone()));
    let class = match (start.unstable, &change) {
        (Some(0), None) => ZeroDynamicsClass::MinimumPhase,
        (Some(u), None) if u == m => ZeroDynamicsClass::NonMinimumPhase,
        (Some(_), None) => ZeroDynamicsClass::Mixed,
        _ => ZeroDynamicsClass::Unknown,
    };
    let unstable = start.unstable.unwrap_or(0);
    let any_unstable = levels.iter().any(|l| l.has_unstable);
    ReferenceClassification {
        class,
        start: Some(start),
        change,
        unstable,
        any_unstable,
    }
}

/// True if any of the classified levels has an unstable eigenvalue (then causal inversion cannot work).
pub(crate) fn any_unstable(c: &ReferenceClassification) -> bool {
    c.any_unstable
}

// --- spectral projections ------------------------------------------------------------------------------

/// The matrix sign function by the scaled Newton iteration X ← (μX + (μX)⁻¹)/2, μ = |det X|^(−1/m)
/// (Higham, *Functions of Matrices*, 2008, ch. 5); `None` if X becomes singular or it does not converge.
fn matrix_sign(a: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let m = a.nrows();
    let mut x = a.clone();
    for _ in 0..100 {
        let inv = x.clone().try_inverse()?;
        let det = x.determinant().abs();
        let mu = if det > 0.0 && det.is_finite() {
            det.powf(-1.0 / m as f64)
        } else {
            1.0
        };
        let next = (&x * mu + inv / mu) * 0.5;
        let diff = (&next - &x).norm();
        let size = next.norm();
        x = next;
        if !size.is_finite() {
            return None;
        }
        if diff <= 1e-14 * size {
            return Some(x);
        }
    }
    None
}

/// Rows W (k × m, orthonormal) with W x = 0 ⇔ P x = 0, for a projector P of rank k.
fn projector_rows(p: &DMatrix<f64>, k: usize) -> Option<DMatrix<f64>> {
    let m = p.nrows();
    if k == 0 {
        return Some(DMatrix::zeros(0, m));
    }
    let svd = p.clone().svd(false, true);
    let v_t = svd.v_t?;
    // Singular values come sorted in decreasing order for nalgebra's SVD only after sorting; sort explicitly.
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&i, &j| svd.singular_values[j].total_cmp(&svd.singular_values[i]));
    Some(DMatrix::from_fn(k, m, |r, c| v_t[(order[r], c)]))
}

// --- the band solver ---------------------------------------------------------------------------------------

/// A band matrix with kl sub- and ku super-diagonals in LAPACK's layout (room for the ku + kl super-diagonals
/// that partial pivoting fills in), factorised in place (Golub & Van Loan, *Matrix Computations*, §4.3;
/// LAPACK dgbtf2/dgbtrs).
struct Band {
    n: usize,
    kl: usize,
    ku: usize,
    ld: usize,
    ab: Vec<f64>,
    piv: Vec<usize>,
}

impl Band {
    fn new(n: usize, kl: usize, ku: usize) -> Band {
        let ld = 2 * kl + ku + 1;
        Band {
            n,
            kl,
            ku,
            ld,
            ab: vec![0.0; ld * n],
            piv: vec![0; n],
        }
    }
    fn clear(&mut self) {
        self.ab.fill(0.0);
    }
    #[inline]
    fn at(&self, i: usize, j: usize) -> usize {
        debug_assert!(i + self.kl + self.ku >= j && i <= j + self.kl);
        (self.kl + self.ku + i - j) + j * self.ld
    }
    #[inline]
    fn set(&mut self, i: usize, j: usize, v: f64) {
        let k = self.at(i, j);
        self.ab[k] = v;
    }
    /// LU with partial pivoting; `Err(column)` if singular.
    fn factor(&mut self) -> Result<(), usize> {
        let (n, kl) = (self.n, self.kl);
        let kv = self.kl + self.ku;
        let mut ju = 0;
        for j in 0..n {
            let km = kl.min(n - 1 - j);
            let mut p = 0;
            let mut best = self.ab[self.at(j, j)].abs();
            for i in 1..=km {
                let v = self.ab[self.at(j + i, j)].abs();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            self.piv[j] = j + p;
            if best == 0.0 || !best.is_finite() {
                return Err(j);
            }
            ju = ju.max((j + self.ku + p).min(n - 1));
            if p != 0 {
                for c in j..=ju {
                    let (a, b) = (self.at(j, c), self.at(j + p, c));
                    self.ab.swap(a, b);
                }
            }
            if km > 0 {
                let pivot = self.ab[self.at(j, j)];
                for i in 1..=km {
                    let k = self.at(j + i, j);
                    self.ab[k] /= pivot;
                }
                for c in j + 1..=ju {
                    let u = self.ab[self.at(j, c)];
                    if u != 0.0 {
                        for i in 1..=km {
                            // Row j+i, column c: within the stored band since c − (j+i) ≤ kv.
                            debug_assert!(c <= j + i + kv);
                            let l = self.ab[self.at(j + i, j)];
                            let k = self.at(j + i, c);
                            self.ab[k] -= l * u;
                        }
                    }
                }
            }
        }
        Ok(())
    }
    /// Solve A x = b in place with the factors.
    fn solve(&self, b: &mut [f64]) {
        let (n, kl) = (self.n, self.kl);
        let kv = self.kl + self.ku;
        for j in 0..n {
            let p = self.piv[j];
            if p != j {
                b.swap(j, p);
            }
            let bj = b[j];
            if bj != 0.0 {
                for i in 1..=kl.min(n - 1 - j) {
                    b[j + i] -= self.ab[self.at(j + i, j)] * bj;
                }
            }
        }
        for j in (0..n).rev() {
            b[j] /= self.ab[self.at(j, j)];
            let bj = b[j];
            if bj != 0.0 {
                let first = j.saturating_sub(kv);
                for (i, bi) in b[first..j].iter_mut().enumerate() {
                    *bi -= self.ab[self.at(first + i, j)] * bj;
                }
            }
        }
    }
}

// --- the boundary-value problem -----------------------------------------------------------------------------

/// Settings of the stable inversion.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Settings {
    /// Tolerance: Newton stops when the scaled step is below it; the estimated discretisation error must be below
    /// it; the pre- and post-actuation run until the deviation from the equilibria has decayed to it.
    pub tol: f64,
    /// Initial node spacing in seconds (refined until the error estimate meets `tol`).
    pub h0: f64,
    /// Smallest node spacing tried, s.
    pub h_min: f64,
}

/// The plan: where the boundary conditions sit and how η is split there.
#[derive(Debug, Clone)]
pub(crate) struct Plan {
    pub t_a: f64,
    pub t_b: f64,
    /// Equilibria of the zero dynamics for the constant reference at t_a and t_b.
    pub eta_a: Vec<f64>,
    pub eta_b: Vec<f64>,
    /// W_a (m_s × m): W_a (η(t_a) − η_a) = 0 (no component in the stable subspace at the start).
    w_a: DMatrix<f64>,
    /// W_b (m_u × m): W_b (η(t_b) − η_b) = 0 (no component in the unstable subspace at the end).
    w_b: DMatrix<f64>,
    pub unstable: usize,
    /// Eigenvalues at the start and end equilibria.
    pub eig_a: Vec<[f64; 2]>,
    pub eig_b: Vec<[f64; 2]>,
}

/// The stable inverse: η at the nodes t_a + j h and q = η̇ there, interpolated by cubic Hermite polynomials.
#[derive(Debug, Clone)]
pub(crate) struct Solution {
    pub t_a: f64,
    pub h: f64,
    pub m: usize,
    /// Number of intervals K (K + 1 nodes).
    pub k: usize,
    eta: Vec<f64>,
    q: Vec<f64>,
    /// Newton iterations on the finest grid.
    pub iterations: usize,
    /// Estimated discretisation error, scaled by each component's magnitude.
    pub estimated_error: f64,
    /// First node time where the frozen-time linearisation has a different number of unstable eigenvalues.
    pub dichotomy_change: Option<(f64, Vec<[f64; 2]>)>,
}

impl Solution {
    /// η(t) into `out`: the cubic Hermite interpolant of (η_j, η̇_j) (the collocation polynomial).
    pub fn eval(&self, t: f64, out: &mut [f64]) {
        let m = self.m;
        let s = (t - self.t_a) / self.h;
        let j = if s.is_nan() {
            0
        } else {
            (s.floor().max(0.0) as usize).min(self.k - 1)
        };
        let th = (s - j as f64).clamp(0.0, 1.0);
        let (t2, t3) = (th * th, th * th * th);
        let h00 = 2.0 * t3 - 3.0 * t2 + 1.0;
        let h10 = (t3 - 2.0 * t2 + th) * self.h;
        let h01 = -2.0 * t3 + 3.0 * t2;
        let h11 = (t3 - t2) * self.h;
        let (a, b) = (j * m, (j + 1) * m);
        for (i, o) in out.iter_mut().enumerate().take(m) {
            *o = h00 * self.eta[a + i]
                + h10 * self.q[a + i]
                + h01 * self.eta[b + i]
                + h11 * self.q[b + i];
        }
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.k + 1
    }
}

/// Build the plan: the equilibria at t_a and t_b, the split of η there and the boundary rows.
pub(crate) fn plan<M: InverseModel + ?Sized>(
    model: &M,
    smoother: &Smoother,
    t_a: f64,
    t_b: f64,
    unstable: usize,
    guess: Option<&[f64]>,
) -> Result<Plan, SimulateError> {
    let info = model.info();
    let (r, m) = (info.relative_degree, info.n_eta);
    let fail = |reason: String| SimulateError::StableInversion { reason };
    let mut yd = [0.0; MAX_DERIVATIVES];
    let mut end = |t: f64,
                   guess: Option<&[f64]>|
     -> Result<(Vec<f64>, DMatrix<f64>), SimulateError> {
        smoother.eval(t, &mut yd[..=r]);
        let e = equilibrium(model, &yd[..r], yd[r], guess).ok_or_else(|| {
            fail(format!(
                "no equilibrium of the zero dynamics for the constant reference y = {} at t = {t} s",
                fmt_sig(yd[0], 8)
            ))
        })?;
        let a = jacobian(model, &yd[..r], &e, yd[r]);
        Ok((e, a))
    };
    let (eta_a, a_a) = end(t_a, guess)?;
    let (eta_b, a_b) = end(t_b, Some(&eta_a))?;
    let (eig_a, eig_b) = (eigenvalues(&a_a), eigenvalues(&a_b));
    for (eigs, a, t) in [(&eig_a, &a_a, t_a), (&eig_b, &a_b, t_b)] {
        let tol = critical_tol(a);
        let u = eigs.iter().filter(|e| e[0] > tol).count();
        if eigs.is_empty() || eigs.iter().any(|e| e[0].abs() <= tol) || u != unstable {
            return Err(fail(format!(
                "the zero dynamics at the equilibrium for t = {t} s are not hyperbolic with {unstable} unstable \
                 eigenvalue(s) (eigenvalues of ∂q/∂η: {})",
                crate::simulate::format_eigenvalues(eigs)
            )));
        }
    }
    let identity = DMatrix::<f64>::identity(m, m);
    let sign = |a: &DMatrix<f64>, t: f64| {
        matrix_sign(a).ok_or_else(|| {
            fail(format!(
                "cannot split ∂q/∂η at t = {t} s into stable and unstable parts"
            ))
        })
    };
    let (s_a, s_b) = (sign(&a_a, t_a)?, sign(&a_b, t_b)?);
    let p_s = (&identity - &s_a) * 0.5;
    let p_u = (&identity + &s_b) * 0.5;
    let w_a = projector_rows(&p_s, m - unstable)
        .ok_or_else(|| fail("SVD of the stable projection failed".into()))?;
    let w_b = projector_rows(&p_u, unstable)
        .ok_or_else(|| fail("SVD of the unstable projection failed".into()))?;
    Ok(Plan {
        t_a,
        t_b,
        eta_a,
        eta_b,
        w_a,
        w_b,
        unstable,
        eig_a,
        eig_b,
    })
}

/// One discretisation of the boundary-value problem: K intervals of length h from t_a.
struct Bvp<'a, M: ?Sized> {
    model: &'a M,
    plan: &'a Plan,
    r: usize,
    m: usize,
    k: usize,
    h: f64,
    /// y_d … y_d^(r) at the nodes and the midpoints: half-node i at t_a + i h/2, row-wise (r + 1 per point).
    yd: Vec<f64>,
    /// Scale of each component of η (for norms).
    scale: Vec<f64>,
}

impl<'a, M: InverseModel + ?Sized> Bvp<'a, M> {
    fn new(model: &'a M, smoother: &Smoother, plan: &'a Plan, k: usize) -> Bvp<'a, M> {
        let info = model.info();
        let (r, m) = (info.relative_degree, info.n_eta);
        let h = (plan.t_b - plan.t_a) / k as f64;
        let points = 2 * k + 1;
        let times: Vec<f64> = (0..points)
            .map(|i| plan.t_a + i as f64 * (h / 2.0))
            .collect();
        let mut cols = vec![vec![0.0; points]; r + 1];
        {
            let mut views: Vec<&mut [f64]> = cols.iter_mut().map(|c| c.as_mut_slice()).collect();
            smoother.eval_grid(&times, Some(h / 2.0), &mut views);
        }
        let mut yd = vec![0.0; points * (r + 1)];
        for (i, row) in yd.chunks_exact_mut(r + 1).enumerate() {
            for (o, c) in row.iter_mut().zip(&cols) {
                *o = c[i];
            }
        }
        Bvp {
            model,
            plan,
            r,
            m,
            k,
            h,
            yd,
            scale: vec![1.0; m],
        }
    }

    /// q at half-node i (even: node i/2, odd: a midpoint).
    #[inline]
    fn q(&self, i: usize, eta: &[f64], out: &mut [f64]) {
        let p = &self.yd[i * (self.r + 1)..(i + 1) * (self.r + 1)];
        self.model.zero_dynamics(&p[..self.r], eta, p[self.r], out);
    }

    /// ∂q/∂η at half-node i by forward differences from the value `q0` there, into `jac` (row-major m × m).
    fn jac(
        &self,
        i: usize,
        eta: &[f64],
        q0: &[f64],
        jac: &mut [f64],
        work: &mut [f64],
        qp: &mut [f64],
    ) {
        let m = self.m;
        work.copy_from_slice(eta);
        for c in 0..m {
            let d = 1e-7 * eta[c].abs().max(self.scale[c]);
            work[c] = eta[c] + d;
            self.q(i, work, qp);
            work[c] = eta[c];
            for row in 0..m {
                jac[row * m + c] = (qp[row] - q0[row]) / d;
            }
        }
    }

    /// Component scales from a trajectory: max |η_i| over the nodes, at least 1e-3 of the largest.
    fn set_scale(&mut self, eta: &[f64]) {
        let m = self.m;
        let mut s = vec![0.0_f64; m];
        for node in eta.chunks_exact(m) {
            for (a, v) in s.iter_mut().zip(node) {
                *a = a.max(v.abs());
            }
        }
        let big = s.iter().fold(0.0_f64, |a, v| a.max(*v));
        for v in &mut s {
            *v = if big > 0.0 && big.is_finite() {
                v.max(1e-3 * big)
            } else {
                1.0
            };
        }
        self.scale = s;
    }

    /// The quasi-static guess: the equilibrium of the frozen zero dynamics at every node, by continuation.
    fn quasi_static(&self) -> Vec<f64> {
        let (m, r) = (self.m, self.r);
        let mut eta = vec![0.0; (self.k + 1) * m];
        let mut previous = self.plan.eta_a.clone();
        for j in 0..=self.k {
            let p = &self.yd[2 * j * (r + 1)..(2 * j + 1) * (r + 1)];
            if let Some(e) = newton_equilibrium(self.model, &p[..r], p[r], previous.clone(), 8) {
                previous = e;
            }
            eta[j * m..(j + 1) * m].copy_from_slice(&previous);
        }
        eta
    }

    /// Residual F(η) (scaled max norm returned) with q at the nodes and midpoints; `eta_mid` and the q's are
    /// filled for the Jacobian.
    fn residual(
        &self,
        eta: &[f64],
        q_nodes: &mut [f64],
        eta_mid: &mut [f64],
        q_mid: &mut [f64],
        f: &mut [f64],
    ) -> f64 {
        let (m, k, h) = (self.m, self.k, self.h);
        for j in 0..=k {
            self.q(
                2 * j,
                &eta[j * m..(j + 1) * m],
                &mut q_nodes[j * m..(j + 1) * m],
            );
        }
        for j in 0..k {
            for i in 0..m {
                let (a, b) = (j * m + i, (j + 1) * m + i);
                eta_mid[j * m + i] = 0.5 * (eta[a] + eta[b]) + h / 8.0 * (q_nodes[a] - q_nodes[b]);
            }
            self.q(
                2 * j + 1,
                &eta_mid[j * m..(j + 1) * m],
                &mut q_mid[j * m..(j + 1) * m],
            );
        }
        let ms = m - self.plan.unstable;
        let big = self.scale.iter().fold(0.0_f64, |a, v| a.max(*v));
        let mut norm = 0.0_f64;
        let mut put = |f: &mut [f64], row: usize, v: f64, s: f64| {
            f[row] = v;
            let x = v.abs() / s;
            norm = if x.is_nan() || norm.is_nan() {
                f64::NAN
            } else {
                norm.max(x)
            };
        };
        for a in 0..ms {
            let v: f64 = (0..m)
                .map(|i| self.plan.w_a[(a, i)] * (eta[i] - self.plan.eta_a[i]))
                .sum();
            put(f, a, v, big);
        }
        for j in 0..k {
            for c in 0..m {
                let (a, b) = (j * m + c, (j + 1) * m + c);
                let v =
                    eta[b] - eta[a] - h / 6.0 * (q_nodes[a] + 4.0 * q_mid[j * m + c] + q_nodes[b]);
                put(f, ms + j * m + c, v, self.scale[c]);
            }
        }
        for b in 0..self.plan.unstable {
            let v: f64 = (0..m)
                .map(|i| self.plan.w_b[(b, i)] * (eta[k * m + i] - self.plan.eta_b[i]))
                .sum();
            put(f, ms + k * m + b, v, big);
        }
        norm
    }

    /// Newton's method on the collocation equations from `eta` (in place); returns the iterations and the final
    /// q at the nodes.
    fn newton(&mut self, eta: &mut Vec<f64>, tol: f64) -> Result<(usize, Vec<f64>), String> {
        let (m, k, h) = (self.m, self.k, self.h);
        let ms = m - self.plan.unstable;
        let n = (k + 1) * m;
        self.set_scale(eta);
        let (kl, ku) = (ms + m - 1, 2 * m - 1 - ms);
        let mut band = Band::new(n, kl, ku);
        let mut q_nodes = vec![0.0; n];
        let mut eta_mid = vec![0.0; k * m];
        let mut q_mid = vec![0.0; k * m];
        let mut f = vec![0.0; n];
        let mut trial = vec![0.0; n];
        let (mut tq, mut tem, mut tqm, mut tf) = (
            vec![0.0; n],
            vec![0.0; k * m],
            vec![0.0; k * m],
            vec![0.0; n],
        );
        let mut jn = vec![0.0; (k + 1) * m * m];
        let mut jm = vec![0.0; m * m];
        let (mut work, mut qp) = (vec![0.0; m], vec![0.0; m]);
        let mut d = vec![0.0; m * m];
        let mut e = vec![0.0; m * m];
        let mut norm = self.residual(eta, &mut q_nodes, &mut eta_mid, &mut q_mid, &mut f);
        if !norm.is_finite() {
            return Err("the zero dynamics are not finite along the starting guess (the quasi-static equilibria)".into());
        }
        // Newton stops two orders of magnitude below the tolerance, so that its error does not pollute the
        // discretisation error estimate; near convergence (scaled step below 1e-3) the factorised Jacobian is
        // kept (the chord method: linear convergence at a rate of the order of the step).
        let newton_tol = 0.01 * tol;
        let mut last_step = f64::INFINITY;
        for iteration in 1..=MAX_NEWTON {
            if last_step <= 1e-3 {
                let mut step: Vec<f64> = f.iter().map(|v| -v).collect();
                band.solve(&mut step);
                let step_norm = scaled_norm(&step, &self.scale);
                if !step_norm.is_finite() {
                    return Err("the Newton step is not finite".into());
                }
                for ((t, x), s) in trial.iter_mut().zip(eta.iter()).zip(&step) {
                    *t = x + s;
                }
                let tn = self.residual(&trial, &mut tq, &mut tem, &mut tqm, &mut tf);
                if tn.is_finite()
                    && (tn < norm || step_norm <= newton_tol)
                    && step_norm < 0.5 * last_step
                {
                    norm = tn;
                    std::mem::swap(eta, &mut trial);
                    std::mem::swap(&mut q_nodes, &mut tq);
                    std::mem::swap(&mut eta_mid, &mut tem);
                    std::mem::swap(&mut q_mid, &mut tqm);
                    std::mem::swap(&mut f, &mut tf);
                    last_step = step_norm;
                    if step_norm <= newton_tol {
                        return Ok((iteration, q_nodes));
                    }
                    continue;
                }
                // The old Jacobian no longer contracts: fall through to a fresh one.
            }
            // Jacobian: nodes, then per interval the midpoint, assembled into the band matrix.
            for j in 0..=k {
                let (lo, hi) = (j * m, (j + 1) * m);
                self.jac(
                    2 * j,
                    &eta[lo..hi],
                    &q_nodes[lo..hi],
                    &mut jn[j * m * m..(j + 1) * m * m],
                    &mut work,
                    &mut qp,
                );
            }
            band.clear();
            for a in 0..ms {
                for i in 0..m {
                    band.set(a, i, self.plan.w_a[(a, i)]);
                }
            }
            for j in 0..k {
                let (lo, hi) = (j * m, (j + 1) * m);
                self.jac(
                    2 * j + 1,
                    &eta_mid[lo..hi],
                    &q_mid[lo..hi],
                    &mut jm,
                    &mut work,
                    &mut qp,
                );
                let ja = &jn[j * m * m..(j + 1) * m * m];
                let jb = &jn[(j + 1) * m * m..(j + 2) * m * m];
                // ∂R_j/∂η_j = −I − h/6 (J_j + 4 J_mid (I/2 + h/8 J_j)),
                // ∂R_j/∂η_{j+1} = I − h/6 (J_{j+1} + 4 J_mid (I/2 − h/8 J_{j+1})).
                for c in 0..m {
                    for i in 0..m {
                        let (mut sa, mut sb) = (0.0, 0.0);
                        for l in 0..m {
                            let delta = if l == i { 0.5 } else { 0.0 };
                            sa += jm[c * m + l] * (delta + h / 8.0 * ja[l * m + i]);
                            sb += jm[c * m + l] * (delta - h / 8.0 * jb[l * m + i]);
                        }
                        let id = if c == i { 1.0 } else { 0.0 };
                        d[c * m + i] = -id - h / 6.0 * (ja[c * m + i] + 4.0 * sa);
                        e[c * m + i] = id - h / 6.0 * (jb[c * m + i] + 4.0 * sb);
                    }
                }
                let row0 = ms + j * m;
                for c in 0..m {
                    for i in 0..m {
                        band.set(row0 + c, j * m + i, d[c * m + i]);
                        band.set(row0 + c, (j + 1) * m + i, e[c * m + i]);
                    }
                }
            }
            for b in 0..self.plan.unstable {
                for i in 0..m {
                    band.set(ms + k * m + b, k * m + i, self.plan.w_b[(b, i)]);
                }
            }
            band.factor().map_err(|col| {
                format!(
                    "the Newton matrix of the collocation equations is singular (column {col} of {n}): the split \
                     into stable and unstable parts does not fit the zero dynamics along the trajectory"
                )
            })?;
            let mut step: Vec<f64> = f.iter().map(|v| -v).collect();
            band.solve(&mut step);
            let step_norm = scaled_norm(&step, &self.scale);
            if !step_norm.is_finite() {
                return Err("the Newton step is not finite".into());
            }
            // Backtracking: halve the step until the residual decreases (or the step is negligible).
            let mut lambda = 1.0;
            let mut accepted = false;
            for _ in 0..30 {
                for ((t, x), s) in trial.iter_mut().zip(eta.iter()).zip(&step) {
                    *t = x + lambda * s;
                }
                let tn = self.residual(&trial, &mut tq, &mut tem, &mut tqm, &mut tf);
                if tn.is_finite() && (tn < norm || lambda * step_norm <= newton_tol) {
                    norm = tn;
                    accepted = true;
                    break;
                }
                lambda *= 0.5;
            }
            if !accepted {
                return Err(format!(
                    "Newton's method stalled in iteration {iteration} (scaled residual {}): the line search found \
                     no decrease",
                    fmt_sig(norm, 3)
                ));
            }
            std::mem::swap(eta, &mut trial);
            std::mem::swap(&mut q_nodes, &mut tq);
            std::mem::swap(&mut eta_mid, &mut tem);
            std::mem::swap(&mut q_mid, &mut tqm);
            std::mem::swap(&mut f, &mut tf);
            last_step = lambda * step_norm;
            if last_step <= newton_tol {
                return Ok((iteration, q_nodes));
            }
        }
        Err(format!(
            "Newton's method did not converge in {MAX_NEWTON} iterations (scaled residual {})",
            fmt_sig(norm, 3)
        ))
    }
}

/// Solve the boundary-value problem of [`Plan`] to the tolerance (see the module documentation).
pub(crate) fn solve<M: InverseModel + ?Sized>(
    model: &M,
    smoother: &Smoother,
    plan: &Plan,
    settings: Settings,
) -> Result<Solution, SimulateError> {
    let m = model.info().n_eta;
    let span = plan.t_b - plan.t_a;
    let fail = |reason: String| SimulateError::StableInversion { reason };
    if !(span > 0.0 && span.is_finite()) {
        return Err(fail(format!(
            "the extended horizon [{}, {}] s is empty",
            plan.t_a, plan.t_b
        )));
    }
    let mut k = ((span / (2.0 * settings.h0)).ceil() as usize).max(2);
    if k > MAX_NODES {
        return Err(fail(format!(
            "{k} collocation nodes exceed the limit of {MAX_NODES}"
        )));
    }
    // Coarse grid from the quasi-static guess.
    let (mut eta, mut q) = {
        let mut bvp = Bvp::new(model, smoother, plan, k);
        let mut eta = bvp.quasi_static();
        let (_, q) = bvp
            .newton(&mut eta, settings.tol)
            .map_err(|r| fail(format!("on {} nodes: {r}", k + 1)))?;
        (eta, q)
    };
    loop {
        // Halve the spacing, start from the coarse solution (its Hermite interpolant at the new nodes).
        let coarse = Solution {
            t_a: plan.t_a,
            h: span / k as f64,
            m,
            k,
            eta,
            q,
            iterations: 0,
            estimated_error: f64::NAN,
            dichotomy_change: None,
        };
        let fine_k = 2 * k;
        if fine_k > MAX_NODES {
            return Err(fail(format!(
                "the discretisation error did not fall below {} before reaching {MAX_NODES} nodes",
                settings.tol
            )));
        }
        let mut fine = Bvp::new(model, smoother, plan, fine_k);
        let mut eta_f = vec![0.0; (fine_k + 1) * m];
        for (j, node) in eta_f.chunks_exact_mut(m).enumerate() {
            coarse.eval(plan.t_a + j as f64 * fine.h, node);
        }
        let (iterations, q_f) = fine
            .newton(&mut eta_f, settings.tol)
            .map_err(|r| fail(format!("on {} nodes: {r}", fine_k + 1)))?;
        // Richardson estimate for an order-4 method: error(fine) ≈ |fine − coarse|/15 at the common nodes.
        let mut diff = 0.0_f64;
        for j in 0..=k {
            for i in 0..m {
                let d = (eta_f[2 * j * m + i] - coarse.eta[j * m + i]).abs() / fine.scale[i];
                diff = if d.is_nan() || diff.is_nan() {
                    f64::NAN
                } else {
                    diff.max(d)
                };
            }
        }
        let estimated_error = diff / 15.0;
        if !estimated_error.is_finite() {
            return Err(fail("the solution is not finite".to_string()));
        }
        if estimated_error <= settings.tol || fine.h / 2.0 < settings.h_min {
            let dichotomy_change = dichotomy_check(&fine, &eta_f, plan.unstable);
            return Ok(Solution {
                t_a: plan.t_a,
                h: fine.h,
                m,
                k: fine_k,
                eta: eta_f,
                q: q_f,
                iterations,
                estimated_error,
                dichotomy_change,
            });
        }
        k = fine_k;
        eta = eta_f;
        q = q_f;
    }
}

/// The first node (checked about once a second) where the frozen-time linearisation ∂q/∂η has a number of
/// unstable eigenvalues other than `unstable` (a hint that the split may not fit; the bounded solution is
/// defined by the linear time-varying dichotomy, not by frozen eigenvalues, so this is only reported).
fn dichotomy_check<M: InverseModel + ?Sized>(
    bvp: &Bvp<'_, M>,
    eta: &[f64],
    unstable: usize,
) -> Option<(f64, Vec<[f64; 2]>)> {
    let (m, r) = (bvp.m, bvp.r);
    let every = ((1.0 / bvp.h).round() as usize).max(1);
    (0..=bvp.k).step_by(every).find_map(|j| {
        let p = &bvp.yd[2 * j * (r + 1)..(2 * j + 1) * (r + 1)];
        let a = jacobian(bvp.model, &p[..r], &eta[j * m..(j + 1) * m], p[r]);
        let eigs = eigenvalues(&a);
        let tol = critical_tol(&a);
        let u = eigs.iter().filter(|e| e[0] > tol).count();
        (eigs.is_empty() || u != unstable).then_some((bvp.plan.t_a + j as f64 * bvp.h, eigs))
    })
}

// --- horizon ------------------------------------------------------------------------------------------------

/// Pre- and post-actuation lengths (s) the decay rates require: T_pre = ln(1/tol)/min Re λ_u at the start,
/// T_post = ln(1/tol)/min |Re λ_s| at the end (0 where there is no such part).
pub(crate) fn decay_horizons(eig_a: &[[f64; 2]], eig_b: &[[f64; 2]], tol: f64) -> (f64, f64) {
    let decades = (1.0 / tol).ln();
    let slowest = |eigs: &[[f64; 2]], unstable: bool| {
        eigs.iter()
            .map(|e| e[0])
            .filter(|&re| if unstable { re > 0.0 } else { re < 0.0 })
            .map(f64::abs)
            .fold(f64::INFINITY, f64::min)
    };
    let (u, s) = (slowest(eig_a, true), slowest(eig_b, false));
    let t_pre = if u.is_finite() { decades / u } else { 0.0 };
    let t_post = if s.is_finite() { decades / s } else { 0.0 };
    (t_pre, t_post)
}

// --- planning a run ----------------------------------------------------------------------------------------

/// A stable inversion ready for the driver: the solution on [t_a, t_b] and how many output samples it adds
/// before t_0 and after the cycle's end.
#[derive(Debug, Clone)]
pub(crate) struct StableRun {
    pub solution: Solution,
    pub plan: Plan,
    pub k_pre: usize,
    pub k_post: usize,
}

/// What the driver does with the zero dynamics.
#[derive(Debug, Clone)]
pub(crate) struct ZeroDynamicsPlan {
    pub class: ZeroDynamicsClass,
    /// Eigenvalues at the equilibrium for the reference's first value.
    pub eigenvalues: Vec<[f64; 2]>,
    /// `Some` when η is computed by stable inversion, `None` for causal integration (or r = n).
    pub stable: Option<StableRun>,
}

/// Classify the zero dynamics over the reference and, when they have unstable eigenvalues and causal
/// integration was not asked for, compute the stable inverse on the grid t_0 − k_pre·dt … t_end + k_post·dt
/// (`t_end` the grid's last time).
#[allow(clippy::too_many_arguments)]
pub(crate) fn plan_run<M: InverseModel + ?Sized>(
    model: &M,
    cycle: &Cycle,
    smoother: &Smoother,
    t0: f64,
    t_end: f64,
    dt: f64,
    opts: &SimulationOptions,
    eta0_given: bool,
) -> Result<ZeroDynamicsPlan, SimulateError> {
    let m = model.info().n_eta;
    if m == 0 {
        return Ok(ZeroDynamicsPlan {
            class: ZeroDynamicsClass::None,
            eigenvalues: Vec::new(),
            stable: None,
        });
    }
    let fail = |reason: String| SimulateError::StableInversion { reason };
    if !(opts.stable_tol > 0.0 && opts.stable_tol < 1.0) {
        return Err(fail(format!(
            "the tolerance {} must lie strictly between 0 and 1",
            opts.stable_tol
        )));
    }
    if !(opts.max_pre_actuation >= 0.0 && opts.max_pre_actuation.is_finite()) {
        return Err(fail(format!(
            "the pre-actuation limit {} s must be a finite, non-negative number of seconds",
            opts.max_pre_actuation
        )));
    }
    // The levels the reference passes: y_d lies between the mapped extremes of the cycle (the kernel is
    // positive), and starts at the mapped first speed.
    let map = smoother.reference();
    let (v_min, v_max) = cycle
        .speed
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let (y_a, y_b) = (
        map.offset + map.scale * v_min,
        map.offset + map.scale * v_max,
    );
    let y_start = map.offset + map.scale * cycle.speed.first().copied().unwrap_or(0.0);
    let c = classify_reference(model, y_start, y_a.min(y_b), y_a.max(y_b));
    let eigenvalues = c
        .start
        .as_ref()
        .map(|l| l.eigenvalues.clone())
        .unwrap_or_default();
    if opts.causal || eta0_given || !any_unstable(&c) {
        return Ok(ZeroDynamicsPlan {
            class: c.class,
            eigenvalues,
            stable: None,
        });
    }
    if let Some((a, b)) = &c.change {
        let count = |l: &Level| {
            l.unstable.map(|u| u.to_string()).unwrap_or_else(|| {
                "an undetermined number of (an eigenvalue on the imaginary axis)".to_string()
            })
        };
        return Err(SimulateError::ZeroDynamicsTypeChange {
            y_from: a.y,
            y_to: b.y,
            from: count(a),
            to: count(b),
            eigenvalues_from: a.eigenvalues.clone(),
            eigenvalues_to: b.eigenvalues.clone(),
        });
    }
    let start = c.start.as_ref().map(|l| l.eta.clone());
    // Boundary conditions where the reference is constant: before the smoother's support and after it.
    let (s_start, s_end) = smoother.support().unwrap_or((t0, t_end));
    let mut p = plan(
        model,
        smoother,
        s_start.min(t0),
        s_end.max(t_end),
        c.unstable,
        start.as_deref(),
    )?;
    let tol = opts.stable_tol;
    let (t_pre, t_post) = decay_horizons(&p.eig_a, &p.eig_b, tol);
    // A constant reference needs none: η rests at the equilibrium throughout.
    let moving = smoother.support().is_some();
    let need_pre = if moving {
        (t0 - (s_start - t_pre)).max(0.0)
    } else {
        0.0
    };
    let need_post = if moving {
        (s_end + t_post - t_end).max(0.0)
    } else {
        0.0
    };
    let rate = |eigs: &[[f64; 2]], unstable: bool| {
        eigs.iter()
            .map(|e| e[0])
            .filter(|&re| (re > 0.0) == unstable)
            .map(f64::abs)
            .fold(f64::INFINITY, f64::min)
    };
    if need_pre > opts.max_pre_actuation {
        return Err(SimulateError::PreActuationTooLong {
            which: "pre",
            needed: need_pre,
            rate: rate(&p.eig_a, true),
            max: opts.max_pre_actuation,
        });
    }
    if need_post > opts.max_pre_actuation {
        return Err(SimulateError::PreActuationTooLong {
            which: "post",
            needed: need_post,
            rate: rate(&p.eig_b, false),
            max: opts.max_pre_actuation,
        });
    }
    let samples = |t: f64| (t / dt - 1e-9).ceil().max(0.0) as usize;
    let (k_pre, k_post) = (samples(need_pre), samples(need_post));
    p.t_a = t0 - k_pre as f64 * dt;
    // A grid of one sample (a cycle of zero duration) still needs an interval for the collocation: beyond the
    // grid's end the reference is held, so the boundary condition may sit a second later.
    p.t_b = (t_end + k_post as f64 * dt).max(p.t_a + 1.0);
    let settings = Settings {
        tol,
        h0: opts.lookahead / 25.0,
        h_min: opts.lookahead * 1e-3,
    };
    let solution = solve(model, smoother, &p, settings)?;
    Ok(ZeroDynamicsPlan {
        class: c.class,
        eigenvalues,
        stable: Some(StableRun {
            solution,
            plan: p,
            k_pre,
            k_post,
        }),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_solver_matches_dense() {
        // A random-ish band matrix with kl = 2, ku = 1 and a small diagonal (pivoting needed).
        let (n, kl, ku) = (9, 2, 1);
        let mut band = Band::new(n, kl, ku);
        let mut dense = DMatrix::<f64>::zeros(n, n);
        for i in 0..n {
            for j in i.saturating_sub(kl)..=(i + ku).min(n - 1) {
                let v = ((i * 7 + j * 13) % 11) as f64 - 5.0 + if i == j { 0.01 } else { 0.0 };
                band.set(i, j, v);
                dense[(i, j)] = v;
            }
        }
        let b: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut x = b.clone();
        band.factor().unwrap();
        band.solve(&mut x);
        let expect = dense.lu().solve(&DVector::from_vec(b)).unwrap();
        for i in 0..n {
            assert!(
                (x[i] - expect[i]).abs() < 1e-10,
                "{i}: {} vs {}",
                x[i],
                expect[i]
            );
        }
    }

    #[test]
    fn sign_function_splits_a_saddle() {
        let a = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 0.0, -3.0]);
        let s = matrix_sign(&a).unwrap();
        // P_u = (I + S)/2 projects onto the eigenvector of 1, (1, 0), along the one of −3, (−1, 2).
        let p_u = (DMatrix::identity(2, 2) + &s) * 0.5;
        let v_s = DVector::from_vec(vec![-1.0, 2.0]);
        assert!((&p_u * v_s).norm() < 1e-12);
        let w = projector_rows(&p_u, 1).unwrap();
        assert!((w[(0, 0)] * 1.0 + w[(0, 1)] * 0.0).abs() > 0.5);
    }

    #[test]
    fn horizons_from_decay_rates() {
        let (pre, post) = decay_horizons(
            &[[0.5, 0.0], [-2.0, 0.0]],
            &[[0.5, 0.0], [-2.0, 0.0]],
            1e-10,
        );
        assert!((pre - 10f64.ln() * 10.0 / 0.5).abs() < 1e-9);
        assert!((post - 10f64.ln() * 10.0 / 2.0).abs() < 1e-9);
        assert_eq!(decay_horizons(&[[-1.0, 0.0]], &[[-1.0, 0.0]], 1e-10).0, 0.0);
    }
}
