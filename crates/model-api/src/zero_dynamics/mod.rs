//! The zero dynamics η̇ = q(ξ, η, y^(r)) in one place: their equilibrium, their linearisation ∂q/∂η, the
//! threshold below which a real part counts as zero, and the class that follows (Isidori, *Nonlinear Control
//! Systems*, 3rd ed., §4.3), shared by `invsim derive` (classification at the nominal point), the causal run
//! (initial state, stability checks along the run), the forward run (initial state) and stable inversion (the
//! stable/unstable split at the ends).
//!
//! Also here, with no feature needed (generated code uses them): the constants of ψ⁻¹'s Newton iteration, for
//! states that the derivation could only solve numerically.
//!
//! With the `linearize` feature (nalgebra): [`equilibrium`] (one damped Newton method, the starting points a
//! parameter), [`jacobian`] / [`JacobianWork`], [`eigenvalues`], [`Linearization`] and
//! [`ZeroDynamicsClass`].

#[cfg(feature = "linearize")]
mod class;
#[cfg(feature = "linearize")]
mod equilibrium;
#[cfg(feature = "linearize")]
mod linear;
mod threshold;

#[cfg(feature = "linearize")]
pub use class::ZeroDynamicsClass;
#[cfg(feature = "linearize")]
pub use equilibrium::{
    default_starts, equilibrium, newton, EquilibriumFailure, EQUILIBRIUM_MAX_ITER,
};
#[cfg(feature = "linearize")]
pub use linear::{eigenvalues, jacobian, JacobianWork, Linearization};
pub use threshold::{critical_tol, CRITICAL_ABS_TOL, CRITICAL_REL_TOL};

/// Maximum Newton iterations for a numerically solved ψ⁻¹ (interpreter and generated code alike).
pub const PSI_INV_NEWTON_MAX_ITER: usize = 50;
/// ψ⁻¹'s Newton iteration stops when every residual, relative to max(|target|, 1), is below this.
pub const PSI_INV_NEWTON_TOL: f64 = 1e-13;
/// Largest |φ(u) − yr| / (1 + |yr| + |φ(u)|) accepted for an input u isolated in closed form from
/// φ(ξ, η, w, u) = yr (interpreter and generated code alike). The closed form holds only on its branch's
/// domain (sqrt(P) = R gives P = R², a root only for R ≥ 0); rounding errs ~1e-15 relative, a u off the
/// domain by the order of φ itself, and is refused as no input reaching yr.
pub const ISOLATED_INPUT_TOL: f64 = 1e-6;
