//! Classification of the zero dynamics at the model's nominal point: minimum phase, non-minimum phase or mixed.
//!
//! For r < n the internal coordinates follow η̇ = q(ξ, η, y^(r)) (Isidori, *Nonlinear Control Systems*, 3rd ed.,
//! §4.3). With the output held at its nominal value y0 — ξ = (y0, 0, …, 0), y^(r) = 0 — the zero dynamics are
//! autonomous; at an equilibrium η* (q(ξ, η*, 0) = 0, found here by Newton's method) their linearisation
//! A = ∂q/∂η decides the class (Isidori §4.3, local asymptotic stability of the zero dynamics; hyperbolicity
//! as stable inversion needs it, Devasia, Chen & Paden 1996):
//!
//! * every eigenvalue of A in the open left half-plane: **minimum phase** (causal inversion is stable);
//! * every eigenvalue in the open right half-plane: **non-minimum phase** (η must be integrated backward);
//! * some on each side: **mixed** (the stable part forward, the unstable part backward: stable inversion);
//! * an eigenvalue on the imaginary axis, or no equilibrium found: **unknown** (the linearisation does not
//!   decide); r = n: **none** (there are no zero dynamics).
//!
//! y0 is the `[output]`'s `nominal` value, else its `reference_offset` (the reference at a standstill), else 0.

use crate::derive::Derivation;
use crate::interpreter::Interpreter;
pub use invsim_model_api::linearize::ZeroDynamicsClass;
use invsim_model_api::linearize::{eigenvalues, jacobian};
use invsim_model_api::InverseModel;
use nalgebra::DVector;

/// The zero dynamics linearised at the nominal point.
#[derive(Debug, Clone, PartialEq)]
pub struct Classification {
    pub class: ZeroDynamicsClass,
    /// The nominal output value y0 (ξ = (y0, 0, …, 0), y^(r) = 0).
    pub output: f64,
    /// The equilibrium η* (empty if r = n or none was found).
    pub eta: Vec<f64>,
    /// Eigenvalues [re, im] of ∂q/∂η at (ξ, η*, 0), sorted by decreasing real part.
    pub eigenvalues: Vec<[f64; 2]>,
    /// Why the class is unknown, if it is.
    pub note: Option<String>,
}

impl Derivation {
    /// Classify the zero dynamics at the nominal point (see the module documentation).
    pub fn classify(&self) -> Classification {
        let y0 = self.model.output.nominal_value();
        let m = self.eta.len();
        let unknown = |note: String| Classification {
            class: ZeroDynamicsClass::Unknown,
            output: y0,
            eta: Vec::new(),
            eigenvalues: Vec::new(),
            note: Some(note),
        };
        if m == 0 {
            return Classification {
                class: ZeroDynamicsClass::None,
                output: y0,
                eta: Vec::new(),
                eigenvalues: Vec::new(),
                note: None,
            };
        }
        let model = match Interpreter::new(self) {
            Ok(i) => i,
            Err(e) => return unknown(format!("the zero dynamics cannot be evaluated: {e}")),
        };
        let mut xi = vec![0.0; self.relative_degree];
        xi[0] = y0;
        let Some(eta) = equilibrium(&model, &xi, 0.0, y0) else {
            return unknown(format!(
                "no equilibrium of the zero dynamics found at y = {y0} (Newton's method from several starting \
                 points); set the output's `nominal` value in the model file"
            ));
        };
        let jac = jacobian(&model, &xi, &eta, 0.0);
        let eigenvalues = eigenvalues(&jac);
        let scale = jac.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let class = ZeroDynamicsClass::of_eigenvalues(&eigenvalues, 1e-9 + 1e-7 * scale);
        let note = match class {
            ZeroDynamicsClass::Unknown if eigenvalues.is_empty() => {
                Some("the linearisation ∂q/∂η is not finite at the equilibrium".to_string())
            }
            ZeroDynamicsClass::Unknown => Some(
                "an eigenvalue lies on the imaginary axis: the linearisation does not decide (critical case)"
                    .to_string(),
            ),
            _ => None,
        };
        Classification {
            class,
            output: y0,
            eta,
            eigenvalues,
            note,
        }
    }
}

/// An equilibrium q(ξ, η, y^(r)) = 0 by damped Newton's method, tried from several starting points (η = 0,
/// η = y0 in every component — internal states often share the output's scale, as pressures do —, then ±10^k):
/// the first that converges to a finite point.
pub(crate) fn equilibrium(
    model: &dyn InverseModel,
    xi: &[f64],
    yr: f64,
    y0: f64,
) -> Option<Vec<f64>> {
    let m = model.info().n_eta;
    let mut starts = vec![0.0, y0, 1.0, -1.0];
    for k in [-2, 1, 2, 3, 4, 5, 6] {
        starts.push(10f64.powi(k));
        starts.push(-(10f64.powi(k)));
    }
    starts.dedup();
    starts
        .into_iter()
        .find_map(|s| newton(model, xi, yr, vec![s; m]))
}

/// Damped Newton's method for q(ξ, η, y^(r)) = 0 from `eta`; `None` if it fails.
fn newton(model: &dyn InverseModel, xi: &[f64], yr: f64, mut eta: Vec<f64>) -> Option<Vec<f64>> {
    const MAX_ITER: usize = 100;
    let m = eta.len();
    // Max norm that propagates NaN (f64::max would drop it).
    let norm = |v: &[f64]| {
        v.iter().fold(0.0_f64, |a, x| {
            if x.is_nan() || a.is_nan() {
                f64::NAN
            } else {
                a.max(x.abs())
            }
        })
    };
    let mut q = vec![0.0; m];
    let mut trial = vec![0.0; m];
    let mut q_trial = vec![0.0; m];
    model.zero_dynamics(xi, &eta, yr, &mut q);
    for _ in 0..MAX_ITER {
        let res = norm(&q);
        if !res.is_finite() {
            return None;
        }
        if res == 0.0 {
            return Some(eta);
        }
        let jac = jacobian(model, xi, &eta, yr);
        let step = jac.lu().solve(&DVector::from_column_slice(&q))?;
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
            let r = norm(&q_trial);
            if r.is_finite() && r < res {
                accepted = true;
                break;
            }
            lambda *= 0.5;
        }
        let step_norm = lambda * norm(step.as_slice());
        let eta_norm = norm(&eta);
        if !accepted {
            // No decrease possible: converged to rounding level if the full step is negligible.
            return (norm(step.as_slice()) <= 1e-9 * (1.0 + eta_norm)).then_some(eta);
        }
        eta.copy_from_slice(&trial);
        q.copy_from_slice(&q_trial);
        if step_norm <= 1e-13 * (1.0 + eta_norm) {
            return Some(eta);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_of_eigenvalues() {
        let c = |e: &[[f64; 2]]| ZeroDynamicsClass::of_eigenvalues(e, 1e-9).as_str();
        assert_eq!(c(&[]), "unknown");
        assert_eq!(
            c(&[[-1.0, 0.0], [-2.0, 3.0], [-2.0, -3.0]]),
            "minimum_phase"
        );
        assert_eq!(c(&[[0.5, 0.0]]), "non_minimum_phase");
        assert_eq!(c(&[[0.5, 0.0], [-3.0, 0.0]]), "mixed");
        assert_eq!(c(&[[0.0, 1.0], [0.0, -1.0]]), "unknown");
    }
}
