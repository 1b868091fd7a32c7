//! The plan of a stable inversion: the equilibria of the zero dynamics for the constant reference before the
//! cycle and after it, the split of η into stable and unstable parts there (spectral projections by the
//! matrix sign function), the boundary rows, and the pre- and post-actuation the decay rates require.

use invsim_model_api::zero_dynamics::{default_starts, equilibrium, Linearization};
use invsim_model_api::InverseModel;
use nalgebra::DMatrix;

use super::error::StableError;
use crate::grid::MAX_DERIVATIVES;
use crate::report::{fmt_sig, format_eigenvalues};
use crate::smoother::Smoother;

/// The plan: where the boundary conditions sit and how η is split there.
#[derive(Debug, Clone)]
pub(crate) struct Plan {
    pub t_a: f64,
    pub t_b: f64,
    /// Equilibria of the zero dynamics for the constant reference at t_a and t_b.
    pub eta_a: Vec<f64>,
    pub eta_b: Vec<f64>,
    /// The times whose reference the equilibria are solved for (where it is constant: before the smoother's
    /// support and after it; t_a and t_b themselves may move further out for the pre- and post-actuation).
    pub t_eq: (f64, f64),
    /// W_a (m_s × m): W_a (η(t_a) − η_a) = 0 (no component in the stable subspace at the start).
    pub(crate) w_a: DMatrix<f64>,
    /// W_b (m_u × m): W_b (η(t_b) − η_b) = 0 (no component in the unstable subspace at the end).
    pub(crate) w_b: DMatrix<f64>,
    pub unstable: usize,
    /// Eigenvalues at the start and end equilibria.
    pub eig_a: Vec<[f64; 2]>,
    pub eig_b: Vec<[f64; 2]>,
}

/// Build the plan: the equilibria at t_a and t_b, the split of η there and the boundary rows.
pub(crate) fn plan<M: InverseModel + ?Sized>(
    model: &M,
    smoother: &Smoother,
    t_a: f64,
    t_b: f64,
    unstable: usize,
    guess: Option<&[f64]>,
) -> Result<Plan, StableError> {
    let info = model.info();
    let (r, m) = (info.relative_degree, info.n_eta);
    let fail = |reason: String| StableError::StableInversion { reason };
    let mut yd = [0.0; MAX_DERIVATIVES];
    let mut w = vec![0.0; info.n_w()];
    let mut end = |t: f64,
                   guess: Option<&[f64]>|
     -> Result<(Vec<f64>, Linearization), StableError> {
        smoother.eval(t, &mut yd[..=r]);
        smoother.eval_signals(t, &mut w);
        let e = equilibrium(model, &yd[..r], &w, yd[r], guess, &default_starts(yd[0])).map_err(|_| {
            fail(format!(
                "no equilibrium of the zero dynamics for the constant reference y = {} at t = {t} s",
                fmt_sig(yd[0], 8)
            ))
        })?;
        let lin = Linearization::at(model, &yd[..r], &w, &e, yd[r]);
        Ok((e, lin))
    };
    let (eta_a, a_a) = end(t_a, guess)?;
    let (eta_b, a_b) = end(t_b, Some(&eta_a))?;
    for (lin, t) in [(&a_a, t_a), (&a_b, t_b)] {
        if !lin.is_hyperbolic() || lin.unstable_count() != unstable {
            return Err(fail(format!(
                "the zero dynamics at the equilibrium for t = {t} s are not hyperbolic with {unstable} unstable \
                 eigenvalue(s) (eigenvalues of ∂q/∂η: {})",
                format_eigenvalues(&lin.eigenvalues)
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
    let (s_a, s_b) = (sign(&a_a.jacobian, t_a)?, sign(&a_b.jacobian, t_b)?);
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
        t_eq: (t_a, t_b),
        w_a,
        w_b,
        unstable,
        eig_a: a_a.eigenvalues,
        eig_b: a_b.eigenvalues,
    })
}

/// The matrix sign function by the scaled Newton iteration X ← (μX + (μX)⁻¹)/2, μ = |det X|^(−1/m)
/// (Higham, *Functions of Matrices*, 2008, ch. 5); `None` if X becomes singular or it does not converge.
pub(crate) fn matrix_sign(a: &DMatrix<f64>) -> Option<DMatrix<f64>> {
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
pub(crate) fn projector_rows(p: &DMatrix<f64>, k: usize) -> Option<DMatrix<f64>> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;

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
