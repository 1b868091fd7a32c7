//! The parameter sensitivities' partial derivatives, in the original states (the layout of
//! `invsim_model_api::SensitivityLayout`): ∂/∂(x, u, p) of ψ's ξ rows (L_f^(i−1) h), of y^(r) = φ(x, w, u)
//! (α_x + β_x·u where y^(r) is affine in u), of the internal states' right-hand sides and of the `[outputs]`,
//! ∂/∂[c] of each by each map call c of the rows (`map_calls.rs`: the derivatives with respect to a map's grid
//! values) and ∂/∂S of each by each signal's value S (a mode's decided input is a signal), the calls'
//! arguments closing the list.
//!
//! The runtime combines them by the implicit function theorem (x solves ψ(x; p) = (ξ, η), u solves
//! φ(x, u; p) = y^(r)), so one set of expressions serves a closed-form ψ⁻¹, Newton's ψ⁻¹, an isolated input
//! and Newton's input alike. Every parameter is a symbol of the expressions (definitions are substituted
//! when the model is read); a map's grid values enter through the map calls' columns.

use super::map_calls::{by_call, calls_in};
use crate::model::Model;
use invsim_expr::{Id, Symbol};
use invsim_model_api::MapCall;

/// The expressions, row-major: rows ψ_1 … ψ_r (`psi_xi`), φ, F_η1 … F_η(n−r), o_1 … o_m; columns x_1 … x_n,
/// u, p_1 … p_P, the map calls c_1 … c_C, the signals' values S_1 … S_S; then the calls' arguments (a_1, b_1, …, a_C, b_C). φ = α_x + β_x·u
/// where y^(r) is affine in u (`yr_affine`), else α_x (= φ(x, w, u)). Returned with the calls' maps and orders.
pub(super) fn sensitivity(
    model: &mut Model,
    psi_xi: &[Id],
    (alpha_x, beta_x, yr_affine): (Id, Id, bool),
    eta_states: &[usize],
) -> (Vec<Id>, Vec<MapCall>) {
    let u = model.input.symbol;
    let mut columns: Vec<Symbol> = model.state_symbols();
    columns.push(u);
    columns.extend(model.parameters.iter().map(|p| p.symbol));
    let mut rows: Vec<Id> = psi_xi.to_vec();
    rows.push(if yr_affine {
        let uv = model.pool.var(u);
        let bu = model.pool.mul2(beta_x, uv);
        model.pool.add2(alpha_x, bu)
    } else {
        alpha_x
    });
    rows.extend(eta_states.iter().map(|&s| model.states[s].rhs));
    rows.extend(model.outputs.iter().map(|o| o.expr));
    let pool = &mut model.pool;
    let calls = calls_in(pool, &rows);
    let signals: Vec<Symbol> = model.signals.iter().map(|s| s.symbol).collect();
    let width = columns.len() + calls.len() + signals.len();
    let mut out = Vec::with_capacity(rows.len() * width + 2 * calls.len());
    for &row in &rows {
        for &c in &columns {
            out.push(pool.diff(row, c));
        }
        for c in &calls {
            out.push(by_call(pool, row, c.id));
        }
        for &s in &signals {
            out.push(pool.diff(row, s));
        }
    }
    out.extend(calls.iter().flat_map(|c| c.args));
    (out, calls.iter().map(|c| c.site).collect())
}
