//! Whether the zero dynamics are affine in the internal states: dη/dt = q(ξ, η, w, y^(r)) with
//! ∂q_i/∂η_j free of η for every i, j, that is q = A(ξ, w, y^(r)) η + b(ξ, w, y^(r)) ([`ModelInfo`]'s
//! `zero_dynamics_affine`). A runtime integrates such dynamics by the variation of constants,
//! η(t₁) = e^(∫A) η(t₀) + ∫ e^(∫_s^(t₁) A) b(s) ds, instead of an explicit method whose step the stiffness
//! of A bounds (an intake manifold's filling: A ≈ −25 1/s).
//!
//! Read off the derived expressions: every q_i is written in (ξ, η, w, y^(r)) and the parameters alone (a
//! state left to Newton's method, or the input of a non-affine model, makes the answer no), and each
//! ∂q_i/∂η_j (`Pool::diff`, a map's derivative map where a map reads η) reads no η.
//!
//! [`ModelInfo`]: invsim_model_api::ModelInfo

use invsim_expr::{Id, Symbol};

use crate::model::Model;

/// Where every q in `zero_dynamics` reads no state and not the input of `model` (which ψ⁻¹ left to Newton's
/// method, or a non-affine model's u) and is affine in `eta` (at least one η): the coefficients
/// [∂q_i/∂η_j row-major, then q_i], which at η = 0 are A and b of q = A η + b (the runtime's variation of
/// constants takes them from one evaluation); `None` otherwise.
pub(super) fn affine_in_eta(
    model: &mut Model,
    zero_dynamics: &[Id],
    eta: &[Symbol],
) -> Option<Vec<Id>> {
    let mut excluded: Vec<Symbol> = model.states.iter().map(|s| s.symbol).collect();
    excluded.push(model.input.symbol);
    let pool = &mut model.pool;
    if eta.is_empty()
        || zero_dynamics
            .iter()
            .any(|&q| pool.depends_on_any(q, &excluded))
    {
        return None;
    }
    let mut coefficients = Vec::with_capacity(zero_dynamics.len() * (eta.len() + 1));
    for &q in zero_dynamics {
        for &e in eta {
            let d = pool.diff(q, e);
            if pool.depends_on_any(d, eta) {
                return None;
            }
            coefficients.push(d);
        }
    }
    coefficients.extend_from_slice(zero_dynamics);
    Some(coefficients)
}
