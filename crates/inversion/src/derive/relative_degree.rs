//! The relative degree r: the first k with L_g L_f^{k−1} h ≢ 0 (Isidori, *Nonlinear Control Systems*,
//! 3rd ed., Def. 4.1.1, here "not identically zero" rather than "nonzero at x°", so that singular sets are
//! reported, not hidden), along with L_f^k h for k = 0 … r and L_g L_f^k h for k = 0 … r − 1.

use super::lie::lie_derivative;
use invsim_expr::{zero_test, DecidedBy, Id, Pool, Symbol, ZeroVerdict};
use std::collections::HashMap;

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

/// The first k ≤ n with L_g L_f^(k-1) h ≢ 0, or `None` if the input reaches the output through no number
/// of derivatives. A zero found only by numeric probing is reported in `warnings`.
pub(super) fn relative_degree(
    pool: &mut Pool,
    h: Id,
    f: &[Id],
    g: &[Id],
    states: &[Symbol],
    nominal: &HashMap<Symbol, f64>,
    warnings: &mut Vec<String>,
) -> Option<RelativeDegree> {
    let n = states.len();
    let mut lie = vec![h];
    let mut lg_lie = Vec::new();
    let mut lg_decided_by = Vec::new();
    for k in 0..n {
        let lg = lie_derivative(pool, lie[k], g, states);
        let verdict = zero_test(pool, lg, nominal);
        lg_lie.push(lg);
        lg_decided_by.push(verdict.decided_by());
        if let ZeroVerdict::Zero(DecidedBy::Probing) = verdict {
            warnings.push(format!(
                "L_g L_f^{k} h = {} was taken as identically zero by numeric probing",
                pool.display(lg)
            ));
        }
        let next = lie_derivative(pool, lie[k], f, states);
        lie.push(next);
        if !verdict.is_zero() {
            return Some(RelativeDegree {
                r: k + 1,
                lie,
                lg_lie,
                lg_decided_by,
            });
        }
    }
    None
}
