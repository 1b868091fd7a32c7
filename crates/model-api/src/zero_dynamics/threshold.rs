//! The one stability threshold of the zero dynamics: below it a real part of an eigenvalue of ∂q/∂η is
//! finite-difference noise, not a decision (Isidori §4.3's critical case).

/// Absolute part of the threshold below which a real part of an eigenvalue of ∂q/∂η counts as zero
/// (finite-difference noise of the central-difference Jacobian).
pub const CRITICAL_ABS_TOL: f64 = 1e-9;
/// Relative part of that threshold, times the largest |entry| of ∂q/∂η.
pub const CRITICAL_REL_TOL: f64 = 1e-7;

/// The threshold below which a real part counts as zero for the Jacobian `jac` (any layout):
/// 1e-9 + 1e-7·max |∂q_i/∂η_j|. A real part above it is unstable, below its negative stable, in between
/// critical (the linearisation does not decide).
pub fn critical_tol(jac: &[f64]) -> f64 {
    CRITICAL_ABS_TOL + CRITICAL_REL_TOL * jac.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}
