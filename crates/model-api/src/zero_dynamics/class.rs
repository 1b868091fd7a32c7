//! The class of the zero dynamics from the eigenvalues of their linearisation (Isidori, *Nonlinear Control
//! Systems*, 3rd ed., §4.3: minimum phase when the zero dynamics are asymptotically stable; hyperbolicity as
//! stable inversion needs it, Devasia, Chen & Paden 1996).

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
