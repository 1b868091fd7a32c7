//! Linearisation of the zero dynamics, shared by `invsim derive` (classification at the nominal point) and
//! the runtime (stability checks along a run, the stable/unstable split of stable inversion).
//!
//! ∂q/∂η by central differences, (q(η + h e_j) − q(η − h e_j))/(2h) with h = 1e-6·max(1, |η_j|), and the
//! eigenvalues of the result by the real Schur decomposition (Golub & Van Loan, *Matrix Computations*,
//! 4th ed., §7.5); the class follows from the signs of their real parts (Isidori, *Nonlinear Control
//! Systems*, 3rd ed., §4.3: minimum phase when the zero dynamics are asymptotically stable).

use crate::InverseModel;
use nalgebra::DMatrix;

/// The class of the zero dynamics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ZeroDynamicsClass {
    /// r = n: no zero dynamics.
    None,
    /// Every eigenvalue of ∂q/∂η in the open left half-plane.
    MinimumPhase,
    /// Every eigenvalue in the open right half-plane.
    NonMinimumPhase,
    /// Eigenvalues on both sides.
    Mixed,
    /// No equilibrium found, eigenvalues on the imaginary axis, or a type that changes along the reference.
    Unknown,
}

impl ZeroDynamicsClass {
    /// `none`, `minimum_phase`, `non_minimum_phase`, `mixed` or `unknown`.
    pub fn as_str(self) -> &'static str {
        match self {
            ZeroDynamicsClass::None => "none",
            ZeroDynamicsClass::MinimumPhase => "minimum_phase",
            ZeroDynamicsClass::NonMinimumPhase => "non_minimum_phase",
            ZeroDynamicsClass::Mixed => "mixed",
            ZeroDynamicsClass::Unknown => "unknown",
        }
    }

    /// The class of a set of eigenvalues [re, im] of ∂q/∂η; real parts within `tol` of 0, or no eigenvalues
    /// (a linearisation that could not be computed), make it unknown.
    pub fn of_eigenvalues(eigenvalues: &[[f64; 2]], tol: f64) -> ZeroDynamicsClass {
        if eigenvalues.is_empty()
            || eigenvalues
                .iter()
                .any(|e| !e[0].is_finite() || e[0].abs() <= tol)
        {
            return ZeroDynamicsClass::Unknown;
        }
        match eigenvalues.iter().filter(|e| e[0] > 0.0).count() {
            0 => ZeroDynamicsClass::MinimumPhase,
            u if u == eigenvalues.len() => ZeroDynamicsClass::NonMinimumPhase,
            _ => ZeroDynamicsClass::Mixed,
        }
    }
}

/// Buffers for [`JacobianWork::jacobian`], allocated once for a run.
#[derive(Debug, Clone)]
pub struct JacobianWork {
    n: usize,
    eta: Vec<f64>,
    qp: Vec<f64>,
    qm: Vec<f64>,
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
            jac: vec![0.0; n * n],
        }
    }

    /// ∂q/∂η at (ξ, η, y^(r)) by central differences, column major; no allocation.
    pub fn jacobian<M: InverseModel + ?Sized>(
        &mut self,
        model: &M,
        xi: &[f64],
        eta: &[f64],
        yr: f64,
    ) -> &[f64] {
        let n = self.n;
        self.eta.copy_from_slice(eta);
        for (j, &eta_j) in eta.iter().enumerate() {
            let h = 1e-6 * eta_j.abs().max(1.0);
            self.eta[j] = eta_j + h;
            model.zero_dynamics(xi, &self.eta, yr, &mut self.qp);
            self.eta[j] = eta_j - h;
            model.zero_dynamics(xi, &self.eta, yr, &mut self.qm);
            self.eta[j] = eta_j;
            let column = &mut self.jac[j * n..(j + 1) * n];
            for ((d, p), m) in column.iter_mut().zip(&self.qp).zip(&self.qm) {
                *d = (p - m) / (2.0 * h);
            }
        }
        &self.jac
    }
}

/// ∂q/∂η at (ξ, η, y^(r)) as a matrix (allocating; see [`JacobianWork`] for a hot loop).
pub fn jacobian<M: InverseModel + ?Sized>(
    model: &M,
    xi: &[f64],
    eta: &[f64],
    yr: f64,
) -> DMatrix<f64> {
    let n = eta.len();
    let mut work = JacobianWork::new(n);
    DMatrix::from_column_slice(n, n, work.jacobian(model, xi, eta, yr))
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
        assert_eq!(
            ZeroDynamicsClass::of_eigenvalues(&e, 1e-9),
            ZeroDynamicsClass::MinimumPhase
        );
        assert_eq!(
            ZeroDynamicsClass::of_eigenvalues(&[[1.0, 0.0], [-1.0, 0.0]], 1e-9),
            ZeroDynamicsClass::Mixed
        );
        assert_eq!(
            ZeroDynamicsClass::of_eigenvalues(&[], 1e-9),
            ZeroDynamicsClass::Unknown
        );
    }
}
