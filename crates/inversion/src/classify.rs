//! Classification of the zero dynamics at the model's nominal point: minimum phase, non-minimum phase or mixed.
//!
//! For r < n the internal coordinates follow η̇ = q(ξ, η, y^(r)) (Isidori, *Nonlinear Control Systems*, 3rd ed.,
//! §4.3). With the output held at its nominal value y0 — ξ = (y0, 0, …, 0), y^(r) = 0 — the zero dynamics are
//! autonomous; at an equilibrium η* (q(ξ, η*, 0) = 0, found by `invsim_model_api::zero_dynamics::equilibrium`) their linearisation
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
pub use invsim_model_api::zero_dynamics::ZeroDynamicsClass;
use invsim_model_api::zero_dynamics::{default_starts, equilibrium, Linearization};

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
    /// Why no equilibrium was found at y0, and what to do. An internal state that no equation of the zero
    /// dynamics depends on (a charge state, a fuel mass, a distance: dη/dt = q(ξ, y^(r)) without η) is an
    /// integrator: it has an equilibrium only where q = 0 and its eigenvalue is 0 at any point, so no
    /// `nominal` decides its class; the run integrates it forward from its start value, which is stable.
    fn no_equilibrium_note(&self, y0: f64) -> String {
        let pool = &self.model.pool;
        let numeric = self
            .psi_inv
            .iter()
            .any(|p| matches!(p, crate::Solution::Numeric));
        let integrators: Vec<String> = (0..self.eta.len())
            .filter(|&j| {
                !self
                    .zero_dynamics
                    .iter()
                    .any(|&q| pool.depends_on(q, self.eta[j]))
            })
            .map(|j| {
                let state = &self.model.states[self.eta_states[j]].name;
                format!("{} = {state}", pool.symbol_name(self.eta[j]))
            })
            .collect();
        if numeric || integrators.is_empty() {
            return format!(
                "no equilibrium of the zero dynamics found at y = {y0} (Newton's method from several starting \
                 points); set the output's `nominal` value in the model file"
            );
        }
        let (verb, what) = match integrators.len() {
            1 => ("appears", "an integrator"),
            _ => ("appear", "integrators"),
        };
        format!(
            "{} {verb} in no equation of the zero dynamics: {what} (like a charge state or a fuel mass), \
             with no equilibrium at y = {y0} and a zero eigenvalue everywhere, so no `nominal` decides the \
             class; `simulate` integrates it forward (neutrally stable: an error in it stays as it is) from \
             its start value: give `initial = …` on the state or `--initial NAME=VALUE`, not `nominal`",
            integrators.join(", ")
        )
    }

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
        let w = invsim_model_api::InverseModel::info(&model).nominal_w();
        let Ok(eta) = equilibrium(&model, &xi, &w, 0.0, None, &default_starts(y0)) else {
            return unknown(self.no_equilibrium_note(y0));
        };
        let lin = Linearization::at(&model, &xi, &w, &eta, 0.0);
        let class = lin.class();
        let eigenvalues = lin.eigenvalues;
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
