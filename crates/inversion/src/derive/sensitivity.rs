//! The parameter sensitivities' partial derivatives, in the original states (the layout of
//! `invsim_model_api::SensitivityLayout`): ∂/∂(x, u, p) of ψ's ξ rows (L_f^(i−1) h), of y^(r) = φ(x, w, u)
//! (α_x + β_x·u where y^(r) is affine in u), of the internal states' right-hand sides and of the `[outputs]`.
//!
//! The runtime combines them by the implicit function theorem (x solves ψ(x; p) = (ξ, η), u solves
//! φ(x, u; p) = y^(r)), so one set of expressions serves a closed-form ψ⁻¹, Newton's ψ⁻¹, an isolated input
//! and Newton's input alike. Every parameter is a symbol of the expressions (definitions are substituted
//! when the model is read); a map's grid values are data, not parameters, and have no column.

use super::Derivation;
use invsim_expr::{Id, Symbol};

/// The expressions, row-major: rows ψ_1 … ψ_r, φ, F_η1 … F_η(n−r), o_1 … o_m; columns x_1 … x_n, u,
/// p_1 … p_P.
pub(super) fn sensitivity(d: &mut Derivation) -> Vec<Id> {
    let m = &d.model;
    let u = m.input.symbol;
    let mut columns: Vec<Symbol> = m.state_symbols();
    columns.push(u);
    columns.extend(m.parameters.iter().map(|p| p.symbol));
    let mut rows: Vec<Id> = d.psi[..d.relative_degree].to_vec();
    rows.push(if d.yr_affine {
        let bu = {
            let uv = d.model.pool.var(u);
            d.model.pool.mul2(d.beta_x, uv)
        };
        d.model.pool.add2(d.alpha_x, bu)
    } else {
        d.alpha_x
    });
    rows.extend(d.eta_states.iter().map(|&s| d.model.states[s].rhs));
    rows.extend(d.model.outputs.iter().map(|o| o.expr));
    let pool = &mut d.model.pool;
    let mut out = Vec::with_capacity(rows.len() * columns.len());
    for &row in &rows {
        for &c in &columns {
            out.push(pool.diff(row, c));
        }
    }
    out
}
