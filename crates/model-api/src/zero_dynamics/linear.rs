//! Linearisation of the zero dynamics: ∂q/∂η by central differences, (q(η + h e_j) − q(η − h e_j))/(2h) with
//! h = 1e-6·max(1, |η_j|); where a column is not finite because η lies on the boundary of q's domain (η_j = 0
//! in η_j^1.5, where q(η − h e_j) is NaN), the one-sided second-order difference into the domain,
//! ±(−3q(η) + 4q(η ± h e_j) − q(η ± 2h e_j))/(2h) (Fornberg 1988), the one-sided limit of the derivative;
//! and the eigenvalues of the result by the real Schur decomposition (Golub & Van
//! Loan, *Matrix Computations*, 4th ed., §7.5).

use super::class::ZeroDynamicsClass;
use super::threshold::critical_tol;
use crate::InverseModel;
use nalgebra::DMatrix;

/// Buffers for [`JacobianWork::jacobian`], allocated once for a run.
#[derive(Debug, Clone)]
pub struct JacobianWork {
    n: usize,
    eta: Vec<f64>,
    qp: Vec<f64>,
    qm: Vec<f64>,
    /// q(η), for one-sided differences.
    q0: Vec<f64>,
    /// ∂q/∂η, column major (n × n).
    jac: Vec<f64>,
}

impl JacobianWork {
    /// Buffers for `n` internal coordinates.
    pub fn new(n: usize) -> JacobianWork {
        JacobianWork {
            n,
            eta: vec![0.0; n],
            qp: vec![0.0; n],
            qm: vec![0.0; n],
            q0: vec![0.0; n],
            jac: vec![0.0; n * n],
        }
    }

    /// ∂q/∂η at (ξ, η, y^(r)) by central differences (one-sided at the boundary of q's domain, see the
    /// module documentation), column major; no allocation.
    pub fn jacobian<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        xi: &[f64],
        w: &[f64],
        eta: &[f64],
        yr: f64,
    ) -> &[f64] {
        let n = self.n;
        self.eta.copy_from_slice(eta);
        let mut have_q0 = false;
        for (j, &eta_j) in eta.iter().enumerate() {
            let h = 1e-6 * eta_j.abs().max(1.0);
            self.eta[j] = eta_j + h;
            model.zero_dynamics(xi, &self.eta, w, yr, &mut self.qp);
            self.eta[j] = eta_j - h;
            model.zero_dynamics(xi, &self.eta, w, yr, &mut self.qm);
            self.eta[j] = eta_j;
            let column = &mut self.jac[j * n..(j + 1) * n];
            for ((d, p), m) in column.iter_mut().zip(&self.qp).zip(&self.qm) {
                *d = (p - m) / (2.0 * h);
            }
            if column.iter().all(|d| d.is_finite()) {
                continue;
            }
            if !have_q0 {
                model.zero_dynamics(xi, eta, w, yr, &mut self.q0);
                have_q0 = true;
            }
            for side in [1.0, -1.0] {
                if self.one_sided(model, (xi, w, yr), j, eta_j, side * h) {
                    break;
                }
            }
        }
        &self.jac
    }

    /// Column j by the one-sided difference (−3q(η) + 4q(η + s e_j) − q(η + 2s e_j))/(2s) with step s
    /// (either sign); false (column left as it was) if that is not finite either. `self.q0` holds q(η) and
    /// `self.eta` holds η.
    fn one_sided<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        (xi, w, yr): (&[f64], &[f64], f64),
        j: usize,
        eta_j: f64,
        s: f64,
    ) -> bool {
        let n = self.n;
        self.eta[j] = eta_j + s;
        model.zero_dynamics(xi, &self.eta, w, yr, &mut self.qp);
        self.eta[j] = eta_j + 2.0 * s;
        model.zero_dynamics(xi, &self.eta, w, yr, &mut self.qm);
        self.eta[j] = eta_j;
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(finite(&self.q0) && finite(&self.qp) && finite(&self.qm)) {
            return false;
        }
        let column = &mut self.jac[j * n..(j + 1) * n];
        for (((d, q0), p), m) in column.iter_mut().zip(&self.q0).zip(&self.qp).zip(&self.qm) {
            *d = (-3.0 * q0 + 4.0 * p - m) / (2.0 * s);
        }
        true
    }
}

/// ∂q/∂η at (ξ, η, y^(r)) as a matrix (allocating; see [`JacobianWork`] for a hot loop).
pub fn jacobian<M: InverseModel + ?Sized>(
    model: &M,
    xi: &[f64],
    w: &[f64],
    eta: &[f64],
    yr: f64,
) -> DMatrix<f64> {
    let n = eta.len();
    let mut work = JacobianWork::new(n);
    DMatrix::from_column_slice(n, n, work.jacobian(model, xi, w, eta, yr))
}

/// Eigenvalues [re, im] of a square matrix, sorted by decreasing real part (then imaginary part); empty if
/// the matrix is not finite or the Schur iteration fails.
pub fn eigenvalues(a: &DMatrix<f64>) -> Vec<[f64; 2]> {
    if a.iter().any(|v| !v.is_finite()) {
        return Vec::new();
    }
    if a.nrows() == 1 {
        return vec![[a[(0, 0)], 0.0]];
    }
    let Some(schur) = nalgebra::Schur::try_new(a.clone(), f64::EPSILON, 10_000) else {
        return Vec::new();
    };
    let mut eigs: Vec<[f64; 2]> = schur
        .complex_eigenvalues()
        .iter()
        .map(|c| [c.re, c.im])
        .collect();
    eigs.sort_by(|a, b| b[0].total_cmp(&a[0]).then(b[1].total_cmp(&a[1])));
    eigs
}

/// ∂q/∂η at one point with its eigenvalues and the threshold of [`critical_tol`].
#[derive(Debug, Clone)]
pub struct Linearization {
    /// ∂q/∂η (m × m).
    pub jacobian: DMatrix<f64>,
    /// Its eigenvalues [re, im], sorted by decreasing real part; empty if not computable.
    pub eigenvalues: Vec<[f64; 2]>,
    /// Real parts within ± this of 0 count as zero.
    pub tol: f64,
}

impl Linearization {
    /// Linearise the zero dynamics at (ξ, η, y^(r)).
    pub fn at<M: InverseModel + ?Sized>(
        model: &M,
        xi: &[f64],
        w: &[f64],
        eta: &[f64],
        yr: f64,
    ) -> Self {
        Linearization::of(jacobian(model, xi, w, eta, yr))
    }

    /// The eigenvalues and threshold of a given ∂q/∂η.
    pub fn of(jacobian: DMatrix<f64>) -> Self {
        let eigenvalues = eigenvalues(&jacobian);
        let tol = critical_tol(jacobian.as_slice());
        Linearization {
            jacobian,
            eigenvalues,
            tol,
        }
    }

    /// Number of eigenvalues with real part above the threshold.
    pub fn unstable_count(&self) -> usize {
        self.eigenvalues.iter().filter(|e| e[0] > self.tol).count()
    }

    /// Some eigenvalue has a real part above the threshold.
    pub fn has_unstable(&self) -> bool {
        self.eigenvalues.iter().any(|e| e[0] > self.tol)
    }

    /// Every eigenvalue off the imaginary axis (by more than the threshold), and there are some.
    pub fn is_hyperbolic(&self) -> bool {
        !self.eigenvalues.is_empty() && self.eigenvalues.iter().all(|e| e[0].abs() > self.tol)
    }

    /// The class of these eigenvalues ([`ZeroDynamicsClass::of_eigenvalues`] with the threshold).
    pub fn class(&self) -> ZeroDynamicsClass {
        ZeroDynamicsClass::of_eigenvalues(&self.eigenvalues, self.tol)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigenvalues_of_a_damped_oscillator() {
        // [[0, 1], [−4, −0.4]]: λ = −0.2 ± i·√3.96.
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -4.0, -0.4]);
        let e = eigenvalues(&a);
        assert!(
            (e[0][0] + 0.2).abs() < 1e-12 && (e[0][1].abs() - 3.96f64.sqrt()).abs() < 1e-12,
            "{e:?}"
        );
        let lin = Linearization::of(a);
        assert_eq!(lin.class(), ZeroDynamicsClass::MinimumPhase);
        assert!(lin.is_hyperbolic() && !lin.has_unstable());
        assert_eq!(lin.tol, 1e-9 + 1e-7 * 4.0);
    }
}
