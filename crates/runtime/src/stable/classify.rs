//! Classification of the zero dynamics along the reference: the output held at each level the reference
//! passes, the equilibrium there and its linearisation (Isidori §4.3).

use invsim_model_api::zero_dynamics::{
    default_starts, equilibrium, Linearization, ZeroDynamicsClass,
};
use invsim_model_api::InverseModel;

use crate::grid::MAX_DERIVATIVES;

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
    // The signals at their nominal values (defaults, derivatives 0): the classification is by output level.
    let w = model.info().nominal_w();
    let eta = equilibrium(model, &xi[..r], &w, 0.0, guess, &default_starts(y)).ok()?;
    let lin = Linearization::at(model, &xi[..r], &w, &eta, 0.0);
    Some(Level {
        y,
        eta,
        unstable: lin.is_hyperbolic().then(|| lin.unstable_count()),
        has_unstable: lin.has_unstable(),
        eigenvalues: lin.eigenvalues,
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
