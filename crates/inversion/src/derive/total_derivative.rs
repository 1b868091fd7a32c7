//! The total time derivative along the model and the exogenous signals (contract §5):
//!
//! D e = Σ_i ∂e/∂x_i · (f_i + g_i u) + Σ_S Σ_k ∂e/∂S_dk · S_d(k+1)   (S_d0 = S),
//!
//! split as D e = D_f e + (L_g e) u with the drift part D_f e = L_f e + Σ_S Σ_k ∂e/∂S_dk · S_d(k+1) and the
//! input part L_g e = Σ_i ∂e/∂x_i · g_i (signals do not depend on the input). Without signals D_f is the Lie
//! derivative L_f. The signals' derivatives S_d1, S_d2, … are ordinary symbols: the signal chain
//! S → S_d1 → S_d2 → … is appended to the state vector as extra coordinates with drift S_d(k+1) and gain 0,
//! so that the Lie derivative of `lie.rs` computes D on the extended vector field (the standard treatment of
//! known time-varying inputs by augmenting the state with their derivatives; Isidori, *Nonlinear Control
//! Systems*, 3rd ed., §4.5, tracking with known exogenous signals).

use super::lie::lie_derivative;
use crate::model::{derivative_name, Model};
use invsim_expr::{Id, Pool, Symbol};

/// The vector field of the total derivative: the states, then each signal's chain S, S_d1, …, S_d(K−1).
#[derive(Debug, Clone)]
pub struct TotalDerivative {
    /// x_1 … x_n, then S_d0 … S_d(K−1) per signal.
    coordinates: Vec<Symbol>,
    /// f_1 … f_n, then S_d1 … S_dK per signal.
    drift: Vec<Id>,
    /// g_1 … g_n, then 0 per signal coordinate.
    gain: Vec<Id>,
    /// Per signal, the symbols S_d0 … S_dK.
    chains: Vec<Vec<Symbol>>,
}

impl TotalDerivative {
    /// The field of `model` with each signal's derivatives up to order `orders` (D^k e needs S_dk for an e
    /// that depends on S, so `orders` = n + 1 covers every D^k h, k ≤ n + 1… up to α = D^r h).
    pub fn new(model: &mut Model, orders: usize) -> TotalDerivative {
        let drift: Vec<Id> = model.states.iter().map(|s| s.f).collect();
        TotalDerivative::with_drift(model, orders, drift)
    }

    /// The field whose drift is the whole right-hand side rhs(x, u) (for a model not affine in the input):
    /// then `drift` is the total derivative D e with the input, and ∂(D e)/∂u replaces L_g e.
    pub fn along_rhs(model: &mut Model, orders: usize) -> TotalDerivative {
        let drift: Vec<Id> = model.states.iter().map(|s| s.rhs).collect();
        TotalDerivative::with_drift(model, orders, drift)
    }

    fn with_drift(model: &mut Model, orders: usize, mut drift: Vec<Id>) -> TotalDerivative {
        let mut coordinates = model.state_symbols();
        let mut gain: Vec<Id> = model.states.iter().map(|s| s.g).collect();
        let mut chains = Vec::with_capacity(model.signals.len());
        let zero = model.pool.zero();
        for s in &model.signals {
            let mut chain = vec![s.symbol];
            for k in 1..=orders {
                chain.push(model.pool.symbol(&derivative_name(&s.name, k)));
            }
            for k in 0..orders {
                coordinates.push(chain[k]);
                drift.push(model.pool.var(chain[k + 1]));
                gain.push(zero);
            }
            chains.push(chain);
        }
        TotalDerivative {
            coordinates,
            drift,
            gain,
            chains,
        }
    }

    /// D_f e = L_f e + Σ_S Σ_k ∂e/∂S_dk · S_d(k+1): the total derivative with u = 0.
    pub fn drift(&self, pool: &mut Pool, e: Id) -> Id {
        lie_derivative(pool, e, &self.drift, &self.coordinates)
    }

    /// L_g e = Σ_i ∂e/∂x_i · g_i: the factor of u in the total derivative.
    pub fn gain(&self, pool: &mut Pool, e: Id) -> Id {
        lie_derivative(pool, e, &self.gain, &self.coordinates)
    }

    /// The symbols S, S_d1, …, S_dr of every signal in file order: the layout of the signal-values slice
    /// `w` of `InverseModel` for relative degree r.
    pub fn w_symbols(&self, r: usize) -> Vec<Symbol> {
        self.chains
            .iter()
            .flat_map(|c| c[..=r.min(c.len() - 1)].iter().copied())
            .collect()
    }
}
