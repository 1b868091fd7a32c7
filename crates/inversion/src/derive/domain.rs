//! The domain of the inverse: where β(ξ, η) vanishes (the singular set, where u = (y^(r) − α)/β is
//! undefined; Isidori, *Nonlinear Control Systems*, 3rd ed., §4.1, relative degree lost), and the
//! conditions under which the closed-form ψ⁻¹ is valid (divisors nonzero, roots real, branches).

use invsim_expr::{Id, Node, Number, Pool, Rng, Symbol};
use std::collections::HashMap;

/// The conditions worth reporting: those on parameters alone (true at the nominal values, or the model
/// would not derive) are dropped; the others are stated in (ξ, η) or, for branches, in the states.
pub(super) fn domain_conditions(
    pool: &Pool,
    domain: Vec<(Id, String)>,
    params: &[Symbol],
) -> Vec<String> {
    let mut domain: Vec<String> = domain
        .into_iter()
        .filter(|(e, _)| pool.free_symbols(*e).iter().any(|s| !params.contains(s)))
        .map(|(_, text)| text)
        .collect();
    domain.dedup();
    domain
}

/// Describe where β(ξ, η) vanishes: symbolic factors that are coordinates (β = 0 on ξ1 = 0), parameter
/// factors that are zero at their nominal values, and sign changes of other factors found by probing.
pub(super) fn singular_set(
    pool: &mut Pool,
    beta: Id,
    nominal: &HashMap<Symbol, f64>,
    xi: &[Symbol],
    eta: &[Symbol],
) -> Vec<String> {
    let mut out = Vec::new();
    if pool.as_number(beta).is_some() {
        return out;
    }
    let factors: Vec<Id> = match pool.node(beta) {
        Node::Mul(fs) => fs.to_vec(),
        _ => vec![beta],
    };
    let coords: Vec<Symbol> = xi.iter().chain(eta).copied().collect();
    let mut rng = Rng::new(0xBE7A);
    for fct in factors {
        if pool.as_number(fct).is_some() {
            continue;
        }
        let (base, exp) = match pool.node(fct) {
            Node::Pow(b, p) => (*b, pool.as_number(*p)),
            _ => (fct, Some(Number::ONE)),
        };
        let negative_power = exp.is_some_and(|e| e.is_negative());
        if !pool.depends_on_any(base, &coords) {
            // A parameter combination: singular only for particular parameter values.
            if let Ok(v) = pool.eval(base, nominal) {
                if v == 0.0 && !negative_power {
                    out.push(format!(
                        "{} = 0 at the nominal parameter values",
                        pool.display(base)
                    ));
                }
            }
            continue;
        }
        if negative_power {
            continue;
        }
        if pool.as_symbol(base).is_some() {
            out.push(format!(
                "on {} = 0 (β = {})",
                pool.display(base),
                pool.display(beta)
            ));
            continue;
        }
        // Probe for a sign change of the factor over random coordinates.
        let syms: Vec<Symbol> = pool.free_symbols(base).to_vec();
        let (mut pos, mut neg) = (false, false);
        for _ in 0..64 {
            let mut vals = nominal.clone();
            for &s in &syms {
                if !nominal.contains_key(&s) {
                    vals.insert(s, rng.uniform(-3.0, 3.0));
                }
            }
            if let Ok(v) = pool.eval(base, &vals) {
                if v > 0.0 {
                    pos = true;
                }
                if v < 0.0 {
                    neg = true;
                }
            }
        }
        if pos && neg {
            out.push(format!(
                "where {} = 0 (a sign change found by probing; β = {})",
                pool.display(base),
                pool.display(beta)
            ));
        }
    }
    out
}
