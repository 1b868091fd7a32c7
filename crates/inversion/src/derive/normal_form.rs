//! The normal form in (ξ, η): y^(r) = α(ξ, η) + β(ξ, η) u with α = L_f^r h ∘ ψ⁻¹ and
//! β = L_g L_f^{r−1} h ∘ ψ⁻¹ (Fröberg & Nielsen 2004, eq. 26–28; Isidori, *Nonlinear Control Systems*,
//! 3rd ed., §4.1), and the zero dynamics dη/dt = L_f η + L_g η · (y^(r) − α)/β in (ξ, η, y^(r)).

use invsim_expr::{Id, Pool, Symbol};
use std::collections::HashMap;

/// α, β and the zero dynamics, in (ξ, η) and in the states.
pub(super) struct NormalForm {
    /// α and β in (ξ, η) — with any numerically solved states left as state symbols.
    pub(super) alpha: Id,
    pub(super) beta: Id,
    /// dη_j/dt in (ξ, η, yr).
    pub(super) zero_dynamics: Vec<Id>,
    /// dη_j/dt in (x, yr).
    pub(super) zero_dynamics_x: Vec<Id>,
}

/// The Lie derivatives and ψ⁻¹ an expression in the states is rewritten with.
pub(super) struct ToCoordinates<'a> {
    /// L_f^k h for k = 0 … r.
    pub(super) lie: &'a [Id],
    /// ξ1 … ξr.
    pub(super) xi: &'a [Symbol],
    /// ψ⁻¹ in closed form, by state symbol.
    pub(super) closed: &'a HashMap<Symbol, Id>,
}

impl ToCoordinates<'_> {
    /// Express `e` in (ξ, η): first replace each L_f^k h (k < r) that occurs as a subterm by ξ_{k+1} (it
    /// often does: L_f^2 h contains L_f h when h is a state), then substitute ψ⁻¹ for the remaining states.
    /// This keeps α in the paper's structure (eq. 28) instead of re-expanding ξ2 in terms of ξ.
    pub(super) fn apply(&self, pool: &mut Pool, e: Id) -> Id {
        let mut e = e;
        for k in (1..self.xi.len()).rev() {
            let x = pool.var(self.xi[k]);
            e = pool.replace_product(e, self.lie[k], x);
        }
        let e = pool.substitute(e, self.closed);
        pool.tidy(e)
    }
}

/// α = L_f^r h, β = L_g L_f^{r−1} h and the zero dynamics dη/dt = f_η + g_η (yr − α)/β of the states
/// `eta_states`, each also in (ξ, η).
pub(super) fn normal_form(
    pool: &mut Pool,
    coords: &ToCoordinates<'_>,
    (alpha_x, beta_x): (Id, Id),
    (f, g): (&[Id], &[Id]),
    eta_states: &[usize],
    yr: Symbol,
) -> NormalForm {
    let alpha = coords.apply(pool, alpha_x);
    let beta = coords.apply(pool, beta_x);

    // Zero dynamics: dη/dt = f_η + g_η (yr − α)/β.
    let yr_e = pool.var(yr);
    let num = pool.sub(yr_e, alpha_x);
    let u_x = pool.div(num, beta_x);
    let mut zero_dynamics_x = Vec::with_capacity(eta_states.len());
    let mut zero_dynamics = Vec::with_capacity(eta_states.len());
    for &c in eta_states {
        let gu = pool.mul(&[g[c], u_x]);
        let q = pool.add(&[f[c], gu]);
        zero_dynamics_x.push(q);
        zero_dynamics.push(coords.apply(pool, q));
    }
    NormalForm {
        alpha,
        beta,
        zero_dynamics,
        zero_dynamics_x,
    }
}
