//! Which results of the inverse are free of the internal states η ([`invsim_model_api::EtaFree`]): read off
//! the free symbols of the derived expressions.
//!
//! u = (y^(r) − α(ξ, η))/β(ξ, η) is free of η where α and β are (a non-affine y^(r): where the input's
//! closed-form solution u(ξ, η, w, y^(r)) is); an extra output o(x, w, u) where every state it reads is — an
//! η state never, any other through its closed form x_i = ψ⁻¹_i(ξ, η) — and, if it reads u, u is. A state
//! that only Newton's method solves leaves nothing free (its value follows the start the caller gives).

use invsim_expr::{Id, Pool};
use invsim_model_api::EtaFree;

use super::psi_inv::Solution;
use super::Derivation;

impl Derivation {
    /// Which of u and the extra outputs do not depend on η (see the module documentation).
    pub fn eta_free(&self) -> EtaFree {
        let none = EtaFree {
            input: false,
            outputs: vec![false; self.model.outputs.len()],
        };
        let Some(closed) = self.closed_forms() else {
            return none;
        };
        let pool = self.pool();
        let free = |e: Id| !pool.depends_on_any(e, &self.eta);
        let input = match (self.yr_affine, self.input_solution) {
            (true, _) => free(self.alpha) && free(self.beta),
            (false, Some(u)) => free(u),
            (false, None) => false,
        };
        let u = self.model.input.symbol;
        let outputs = self
            .model
            .outputs
            .iter()
            .map(|o| {
                (input || !pool.depends_on(o.expr, u)) && states_free(pool, o.expr, &closed, &free)
            })
            .collect();
        EtaFree { input, outputs }
    }

    /// Each state's closed form in (ξ, η), `None` for an η state (it is η); `None` overall where a state
    /// has no closed form.
    fn closed_forms(&self) -> Option<Vec<(invsim_expr::Symbol, Option<Id>)>> {
        self.model
            .states
            .iter()
            .zip(&self.psi_inv)
            .enumerate()
            .map(|(i, (s, sol))| match sol {
                _ if self.eta_states.contains(&i) => Some((s.symbol, None)),
                Solution::Closed(e) => Some((s.symbol, Some(*e))),
                Solution::Numeric => None,
            })
            .collect()
    }
}

/// Does every state that `e` reads have a closed form free of η?
fn states_free(
    pool: &Pool,
    e: Id,
    closed: &[(invsim_expr::Symbol, Option<Id>)],
    free: &dyn Fn(Id) -> bool,
) -> bool {
    closed
        .iter()
        .filter(|(x, _)| pool.depends_on(e, *x))
        .all(|(_, form)| form.is_some_and(free))
}
