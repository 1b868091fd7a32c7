//! Partial derivatives in normal-form coordinates, for the sensitivities of a run's gradient.
//!
//! With ψ⁻¹ in closed form and y^(r) affine in the input, the zero dynamics and the extra outputs are
//! expressions in (ξ, η, w, y^(r)) and the parameters: x = ψ⁻¹(ξ, η) and u = (y^(r) − α)/β substituted
//! (`normal_form.rs`; Isidori, *Nonlinear Control Systems*, 3rd ed., §4.1):
//!
//! ```text
//! dη/dt = q(ξ, η, w, y^(r); p) = L_f η + L_g η · (y^(r) − α)/β,    o(ξ, η, w, y^(r); p) = o(ψ⁻¹(ξ, η), w, u)
//! ```
//!
//! so the matrices of the sensitivity equations dS/dt = A S + B (A = ∂q/∂η, B = ∂q/∂p), the outputs'
//! do/dp = ∂o/∂p + ∂o/∂η S, and the columns of the reference ∂/∂ξ and ∂/∂y^(r) (a mode's re-entry transition
//! moves the reference) are their symbolic partial derivatives — the numbers the runtime otherwise assembles at
//! every point from the partial derivatives in the states by the implicit function theorem
//! (`sensitivity.rs`). A map call is differentiated as everywhere (`M_dIJ` by its arguments); the derivatives
//! with respect to a map's grid values stay with that route, which keeps the calls' columns. The outputs'
//! partial derivatives are wanted at a sample's
//! (x, u), so they are written back in the states ([`at_state`]): ξ = ψ_ξ(x), η = x_η, y^(r) = α_x + β_x·u.

use super::normal_form::ToCoordinates;
use crate::model::Model;
use invsim_expr::{Id, Pool, Symbol};
use std::collections::HashMap;

/// The normal form the Jacobians are taken of: the coordinates' symbols, ψ's ξ rows in the states, the η
/// states, α_x and β_x (y^(r) = α_x + β_x·u) and the zero dynamics in (ξ, η, w, y^(r)).
pub(super) struct Normal<'a> {
    pub(super) xi: &'a [Symbol],
    pub(super) eta: &'a [Symbol],
    pub(super) yr: Symbol,
    pub(super) psi_xi: &'a [Id],
    pub(super) eta_states: &'a [usize],
    pub(super) phi: (Id, Id),
    pub(super) zero_dynamics: &'a [Id],
}

/// The zero dynamics' Jacobian in (ξ, η, w, y^(r)) and the outputs' at the states ([`at_state`]), each
/// `None` where there are no such rows.
pub(super) fn jacobians(
    model: &mut Model,
    coords: &ToCoordinates<'_>,
    n: &Normal<'_>,
) -> (Option<Vec<Id>>, Option<Vec<Id>>) {
    let params: Vec<Symbol> = model.parameters.iter().map(|p| p.symbol).collect();
    let states = model.state_symbols();
    let outputs: Vec<Id> = model.outputs.iter().map(|o| o.expr).collect();
    let u = model.input.symbol;
    let (alpha_x, beta_x) = n.phi;
    let pool = &mut model.pool;
    let columns = Columns {
        eta: n.eta,
        xi: n.xi,
        yr: n.yr,
        params: &params,
    };
    let zero = jacobian(pool, n.zero_dynamics, &columns);
    let outputs = outputs_in_coordinates(pool, coords, &outputs, (u, n.yr, alpha_x, beta_x));
    let outputs = jacobian(pool, &outputs, &columns).map(|j| {
        let at = (n.psi_xi, &states[..], n.eta_states);
        at_state(pool, &j, (n.xi, n.eta, n.yr), at, (u, alpha_x, beta_x))
    });
    (zero, outputs)
}

/// The columns of a normal-form Jacobian: η_1 … η_ne, ξ_1 … ξ_r, y^(r), p_1 … p_P.
struct Columns<'a> {
    eta: &'a [Symbol],
    xi: &'a [Symbol],
    yr: Symbol,
    params: &'a [Symbol],
}

/// ∂row/∂(η, ξ, y^(r), p) of every row, row-major; `None` without rows.
fn jacobian(pool: &mut Pool, rows: &[Id], columns: &Columns<'_>) -> Option<Vec<Id>> {
    if rows.is_empty() {
        return None;
    }
    let by: Vec<Symbol> = columns
        .eta
        .iter()
        .chain(columns.xi)
        .chain(std::iter::once(&columns.yr))
        .chain(columns.params)
        .copied()
        .collect();
    let mut out = Vec::with_capacity(rows.len() * by.len());
    for &row in rows {
        for &c in &by {
            out.push(pool.diff(row, c));
        }
    }
    Some(out)
}

/// The rows `rows` (in (ξ, η, w, y^(r))) at the point of the states x and the input u: ξ = ψ_ξ(x) (`psi`, the
/// first r), η_j = x_(s_j) (`eta_states`), y^(r) = α_x + β_x·u — so that they are evaluated where the outputs
/// are, at a sample's (x, u).
fn at_state(
    pool: &mut Pool,
    rows: &[Id],
    (xi, eta, yr): (&[Symbol], &[Symbol], Symbol),
    (psi, states, eta_states): (&[Id], &[Symbol], &[usize]),
    (u, alpha_x, beta_x): (Symbol, Id, Id),
) -> Vec<Id> {
    let uv = pool.var(u);
    let bu = pool.mul2(beta_x, uv);
    let yr_x = pool.add2(alpha_x, bu);
    let mut map: HashMap<Symbol, Id> = xi.iter().copied().zip(psi.iter().copied()).collect();
    for (&e, &s) in eta.iter().zip(eta_states) {
        let x = pool.var(states[s]);
        map.insert(e, x);
    }
    map.insert(yr, yr_x);
    // Substituted only: a tidy pass over every entry (it orders terms by their printed form) costs seconds for
    // a model with modes and changes nothing the code generation's own simplification would not.
    rows.iter().map(|&e| pool.substitute(e, &map)).collect()
}

/// The outputs `outputs` (in the states and the input u) in (ξ, η, w, y^(r)): u = (y^(r) − α_x)/β_x, then
/// ψ⁻¹ (`coords`).
fn outputs_in_coordinates(
    pool: &mut Pool,
    coords: &ToCoordinates<'_>,
    outputs: &[Id],
    (u, yr, alpha_x, beta_x): (Symbol, Symbol, Id, Id),
) -> Vec<Id> {
    let yr_e = pool.var(yr);
    let num = pool.sub(yr_e, alpha_x);
    let u_x = pool.div(num, beta_x);
    let input = HashMap::from([(u, u_x)]);
    outputs
        .iter()
        .map(|&o| {
            let o_x = pool.substitute(o, &input);
            coords.apply(pool, o_x)
        })
        .collect()
}
