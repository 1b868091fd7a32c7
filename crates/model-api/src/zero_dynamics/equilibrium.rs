//! The equilibrium of the zero dynamics, q(ξ, η, y^(r)) = 0 for fixed ξ and y^(r), by one damped Newton
//! method (Dennis & Schnabel, *Numerical Methods for Unconstrained Optimization and Nonlinear Equations*,
//! 1983, §6.3: Newton's step with backtracking on the max norm of the residual), tried from a list of
//! starting points.
//!
//! η_{k+1} = η_k − λ J(η_k)⁻¹ q(η_k), J = ∂q/∂η by central differences ([`super::jacobian`]), λ halved
//! (at most 40 times) until |q|_∞ decreases. It converges when the accepted step λ|Δη|_∞ is at most
//! 1e-13·(1 + |η|_∞); where no λ decreases the residual it has reached rounding level if the full step is at
//! most 1e-9·(1 + |η|_∞), and has stalled otherwise.

use std::fmt;

use nalgebra::DVector;

use super::linear::jacobian;
use crate::InverseModel;

/// Newton iterations per starting point.
pub const EQUILIBRIUM_MAX_ITER: usize = 100;
/// Step halvings of the line search per iteration.
const LINE_SEARCH_HALVINGS: usize = 40;
/// Converged: accepted step λ|Δη|_∞ ≤ STEP_TOL·(1 + |η|_∞).
const STEP_TOL: f64 = 1e-13;
/// No decrease possible but the full step |Δη|_∞ ≤ STALL_TOL·(1 + |η|_∞): at rounding level, converged.
const STALL_TOL: f64 = 1e-9;

/// Why Newton's method found no equilibrium from a starting point (a phrase: "… at t0 = 0 s {failure}").
#[derive(Debug, Clone, PartialEq)]
pub enum EquilibriumFailure {
    /// q is not finite at the iterate.
    NonFinite { eta: Vec<f64> },
    /// ∂q/∂η is singular (or the step not finite) at the iterate.
    Singular { eta: Vec<f64> },
    /// The line search found no decrease and the step is not negligible.
    Stalled { eta: Vec<f64>, residual: f64 },
    /// No convergence within the iteration limit.
    NoConvergence { iterations: usize, residual: f64 },
}

impl fmt::Display for EquilibriumFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EquilibriumFailure::NonFinite { eta } => {
                write!(f, "met a non-finite q at η = {}", short_list(eta))
            }
            EquilibriumFailure::Singular { eta } => {
                write!(
                    f,
                    "met a singular Jacobian ∂q/∂η at η = {}",
                    short_list(eta)
                )
            }
            EquilibriumFailure::Stalled { eta, residual } => write!(
                f,
                "stalled at η = {} with residual {}",
                short_list(eta),
                short(*residual)
            ),
            EquilibriumFailure::NoConvergence {
                iterations,
                residual,
            } => write!(
                f,
                "did not converge in {iterations} iterations (residual {})",
                short(*residual)
            ),
        }
    }
}

impl std::error::Error for EquilibriumFailure {}

/// `v` for a message with at most six significant digits (the rule of every number in a message): `0`,
/// `1.04517e15`, `-2.5e-3`, `NaN`.
fn short(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let s = format!("{v:.5e}");
    match s.split_once('e') {
        Some((m, e)) => format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.')),
        None => s,
    }
}

/// `[a, b, …]` of [`short`] numbers.
fn short_list(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|&x| short(x)).collect();
    format!("[{}]", items.join(", "))
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

/// The starting points tried when no guess is known, as values for every component of η: 0; `y` (internal
/// states often share the output's scale, as pressures do); ±1; ±10^k for k = −2, 1 … 6.
pub fn default_starts(y: f64) -> Vec<f64> {
    let mut starts = vec![0.0, y, 1.0, -1.0];
    for k in [-2, 1, 2, 3, 4, 5, 6] {
        starts.push(10f64.powi(k));
        starts.push(-(10f64.powi(k)));
    }
    // Newton is deterministic: a start equal to the one before it would fail the same way.
    starts.dedup();
    starts
}

/// Damped Newton's method for q(ξ, η, w, y^(r)) = 0 (signal values `w`) from `eta`, at most `max_iter` iterations.
pub fn newton<M: InverseModel + ?Sized>(
    model: &M,
    xi: &[f64],
    w: &[f64],
    yr: f64,
    mut eta: Vec<f64>,
    max_iter: usize,
) -> Result<Vec<f64>, EquilibriumFailure> {
    let m = eta.len();
    let mut q = vec![0.0; m];
    let mut trial = vec![0.0; m];
    let mut q_trial = vec![0.0; m];
    model.zero_dynamics(xi, &eta, w, yr, &mut q);
    for _ in 0..max_iter {
        let res = max_norm(&q);
        if !res.is_finite() {
            return Err(EquilibriumFailure::NonFinite { eta });
        }
        if res == 0.0 {
            return Ok(eta);
        }
        let step = jacobian(model, xi, w, &eta, yr)
            .lu()
            .solve(&DVector::from_column_slice(&q))
            .filter(|s| s.iter().all(|v| v.is_finite()));
        let Some(step) = step else {
            return Err(EquilibriumFailure::Singular { eta });
        };
        let mut lambda = 1.0;
        let mut accepted = false;
        for _ in 0..LINE_SEARCH_HALVINGS {
            for i in 0..m {
                trial[i] = eta[i] - lambda * step[i];
            }
            model.zero_dynamics(xi, &trial, w, yr, &mut q_trial);
            let r = max_norm(&q_trial);
            if r.is_finite() && r < res {
                accepted = true;
                break;
            }
            lambda *= 0.5;
        }
        let step_norm = max_norm(step.as_slice());
        let eta_norm = max_norm(&eta);
        if !accepted {
            if step_norm <= STALL_TOL * (1.0 + eta_norm) {
                return Ok(eta);
            }
            return Err(EquilibriumFailure::Stalled { eta, residual: res });
        }
        eta.copy_from_slice(&trial);
        q.copy_from_slice(&q_trial);
        if lambda * step_norm <= STEP_TOL * (1.0 + eta_norm) {
            return Ok(eta);
        }
    }
    Err(EquilibriumFailure::NoConvergence {
        iterations: max_iter,
        residual: max_norm(&q),
    })
}

/// An equilibrium q(ξ, η, y^(r)) = 0: Newton's method from `guess` if given, then from each of `starts` (a
/// value for every component, see [`default_starts`]): the first that converges. The failure reported is that
/// of the first attempt.
pub fn equilibrium<M: InverseModel + ?Sized>(
    model: &M,
    xi: &[f64],
    w: &[f64],
    yr: f64,
    guess: Option<&[f64]>,
    starts: &[f64],
) -> Result<Vec<f64>, EquilibriumFailure> {
    let m = model.info().n_eta;
    let attempts = guess
        .map(<[f64]>::to_vec)
        .into_iter()
        .chain(starts.iter().map(|&s| vec![s; m]));
    let mut first = None;
    for eta in attempts {
        match newton(model, xi, w, yr, eta, EQUILIBRIUM_MAX_ITER) {
            Ok(e) => return Ok(e),
            Err(f) => {
                first.get_or_insert(f);
            }
        }
    }
    Err(first.unwrap_or(EquilibriumFailure::NoConvergence {
        iterations: 0,
        residual: f64::NAN,
    }))
}
