//! The relative degree r: the first k with L_g D_f^{k−1} h ≢ 0 (D_f the total derivative of
//! `total_derivative.rs`, L_f when the model has no signals) (Isidori, *Nonlinear Control Systems*,
//! 3rd ed., Def. 4.1.1, here "not identically zero" rather than "nonzero at x°", so that singular sets are
//! reported, not hidden), along with L_f^k h for k = 0 … r and L_g L_f^k h for k = 0 … r − 1.

use super::total_derivative::TotalDerivative;
use invsim_expr::{zero_test, DecidedBy, Id, Pool, Symbol, ZeroVerdict};
use std::collections::HashMap;

/// Largest DAG (distinct nodes, shared subterms counted once) of one Lie derivative L_f^k h. Chains of
/// nonlinear states grow L_f^k h geometrically (a 40-state chain x_i' = −k·sin(x_i)·x_i + exp(x_{i+1}/10)
/// would need gigabytes); the shipped models stay below 2 000 nodes.
pub const MAX_LIE_DERIVATIVE_NODES: usize = 20_000;

/// Why no relative degree was found.
pub(super) enum NoRelativeDegree {
    /// L_g L_f^k h ≡ 0 for every k < n.
    Unreachable,
    /// L_f^k h has more than [`MAX_LIE_DERIVATIVE_NODES`] nodes.
    TooLarge { k: usize, nodes: usize },
}

/// The relative degree and the Lie derivatives that found it.
pub(super) struct RelativeDegree {
    /// Relative degree r.
    pub(super) r: usize,
    /// L_f^k h for k = 0 … r.
    pub(super) lie: Vec<Id>,
    /// L_g L_f^k h for k = 0 … r − 1 (all but the last identically zero).
    pub(super) lg_lie: Vec<Id>,
    /// How each L_g L_f^k h was found zero or nonzero.
    pub(super) lg_decided_by: Vec<DecidedBy>,
}

/// The first k ≤ n with L_g L_f^(k-1) h ≢ 0, or why there is none: the input reaches the output through no
/// number of derivatives, or a Lie derivative outgrew [`MAX_LIE_DERIVATIVE_NODES`]. A zero found only by
/// numeric probing is reported in `warnings`.
pub(super) fn relative_degree(
    pool: &mut Pool,
    h: Id,
    field: &TotalDerivative,
    n: usize,
    nominal: &HashMap<Symbol, f64>,
    warnings: &mut Vec<String>,
) -> Result<RelativeDegree, NoRelativeDegree> {
    let mut lie = vec![h];
    let mut lg_lie = Vec::new();
    let mut lg_decided_by = Vec::new();
    for k in 0..n {
        let lg = field.gain(pool, lie[k]);
        let verdict = zero_test(pool, lg, nominal);
        lg_lie.push(lg);
        lg_decided_by.push(verdict.decided_by());
        if let ZeroVerdict::Zero(DecidedBy::Probing) = verdict {
            warnings.push(format!(
                "L_g L_f^{k} h = {} was taken as identically zero by numeric probing",
                pool.display(lg)
            ));
        }
        let next = field.drift(pool, lie[k]);
        let nodes = pool.dag_size(&[next]);
        if nodes > MAX_LIE_DERIVATIVE_NODES {
            return Err(NoRelativeDegree::TooLarge { k: k + 1, nodes });
        }
        lie.push(next);
        if !verdict.is_zero() {
            return Ok(RelativeDegree {
                r: k + 1,
                lie,
                lg_lie,
                lg_decided_by,
            });
        }
    }
    Err(NoRelativeDegree::Unreachable)
}
