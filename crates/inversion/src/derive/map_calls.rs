//! The map calls of the sensitivity rows (`sensitivity.rs`) and each row's partial derivative with respect to
//! each call, from which the runtime builds the derivatives with respect to a map's grid values.
//!
//! A map's value is linear in its grid values v_ij (`invsim_kernel::map`: M_dIJ(a, b) = Σ_ij v_ij Φ_i^(I)(a)
//! Ψ_j^(J)(b)), so for a row E with the calls c = M_dIJ(a_c, b_c) (chain rule, the calls' arguments held):
//!
//! ```text
//! ∂E/∂v_ij = Σ_c ∂E/∂[c] · Φ_i^(I_c)(a_c) Ψ_j^(J_c)(b_c)
//! ```
//!
//! with ∂E/∂[c] the partial derivative of E with respect to the call node treated as an independent symbol:
//! the call replaced by a fresh symbol s, E differentiated by s, s replaced by the call again. A call nested
//! in another call's argument (bsfc(w_e, T_e) with eta_vol in T_e) is thereby differentiated through the outer
//! call too. The runtime evaluates ∂E/∂[c] and the calls' arguments at a point; the basis weights are the
//! map's (`Map::weights`), so the grid values in use (`--map`) are those differentiated.

use invsim_expr::{Id, Node, Pool};
use invsim_model_api::MapCall;

/// The name of the symbol that stands for a call while a row is differentiated by it (no model-file name
/// can contain the brackets).
const CALL_SYMBOL: &str = "⟨map call⟩";

/// A map call of the rows: the node, the map (its index among the pool's maps, the model's order) with the
/// derivative orders, and the arguments (a, b), b = 0 for a 1-D map.
pub(super) struct Call {
    pub(super) id: Id,
    pub(super) site: MapCall,
    pub(super) args: [Id; 2],
}

/// The distinct map calls in `rows`, in the order of a post-order walk of the rows (deterministic).
pub(super) fn calls_in(pool: &mut Pool, rows: &[Id]) -> Vec<Call> {
    let zero = pool.zero();
    pool.topological(rows)
        .into_iter()
        .filter_map(|id| {
            let (m, o, args) = match *pool.node(id) {
                Node::Map(m, o, a) => (m, o, [a, zero]),
                Node::Map2(m, o, a, b) => (m, o, [a, b]),
                _ => return None,
            };
            let orders = [o[0] as usize, o[1] as usize];
            Some(Call {
                id,
                site: MapCall {
                    map: m.index(),
                    orders,
                },
                args,
            })
        })
        .collect()
}

/// ∂`row`/∂[`call`] (the module documentation).
pub(super) fn by_call(pool: &mut Pool, row: Id, call: Id) -> Id {
    let s = pool.symbol(CALL_SYMBOL);
    let sv = pool.var(s);
    let held = pool.replace(row, call, sv);
    let d = pool.diff(held, s);
    pool.replace(d, sv, call)
}
