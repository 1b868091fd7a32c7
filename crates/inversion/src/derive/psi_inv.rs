//! ψ⁻¹, the inverse of the coordinate change ψ(x) = (ξ, η): the equations ξ_k = L_f^{k−1} h(x) are solved
//! for the states that are not η by isolating one unknown at a time — an equation linear in x, or linear
//! in a subterm K(x) that a chain of invertible functions leads to (exp, log, powers, tan, sinh, …, each
//! on its principal branch, with the conditions it needs) — and back-substituted; a state with no closed
//! form is solved by Newton's method at run time (Fröberg & Nielsen 2004, eq. 26–27).

use crate::model::Model;
use invsim_expr::{Func, Id, Node, Pool, Symbol};
use std::collections::HashMap;

/// How a state of ψ⁻¹ was obtained.
#[derive(Debug, Clone, PartialEq)]
pub enum Solution {
    /// Closed form in ξ, η and parameters.
    Closed(Id),
    /// No closed form was found: solved by Newton's method at run time (Jacobian in
    /// [`Derivation::jacobian`](crate::Derivation::jacobian)).
    Numeric,
}

/// ψ⁻¹ per state, the closed forms by state symbol, and the conditions they need.
pub(super) struct Inverse {
    pub(super) psi_inv: Vec<Solution>,
    /// Each state with a closed form → its expression in (ξ, η).
    pub(super) closed: HashMap<Symbol, Id>,
    /// Conditions under which the closed forms are valid (divisors nonzero, roots real, branches).
    pub(super) domain: Vec<(Id, String)>,
}

/// ψ⁻¹ by isolating one unknown at a time; states without a closed form are reported in `warnings`.
pub(super) fn psi_inverse(
    model: &mut Model,
    lie: &[Id],
    xi: &[Symbol],
    eta: &[Symbol],
    eta_states: &[usize],
    warnings: &mut Vec<String>,
) -> Inverse {
    let n = model.states.len();
    let r = xi.len();
    let states = model.state_symbols();
    let pool = &mut model.pool;
    let mut known: HashMap<Symbol, Id> = HashMap::new();
    for (j, &c) in eta_states.iter().enumerate() {
        let e = pool.var(eta[j]);
        known.insert(states[c], e);
    }
    let eqs: Vec<Id> = (0..r)
        .map(|k| {
            let x = pool.var(xi[k]);
            pool.sub(lie[k], x)
        })
        .collect();
    let unknown_states: Vec<Symbol> = (0..n)
        .filter(|i| !eta_states.contains(i))
        .map(|i| states[i])
        .collect();
    let (mut partial, domain) = isolate_all(pool, eqs, &known, &unknown_states);
    // Back-substitute partial solutions until they are free of solved unknowns.
    for _ in 0..=n {
        let snapshot: HashMap<Symbol, Id> = partial.clone();
        for v in partial.values_mut() {
            *v = pool.substitute(*v, &snapshot);
        }
    }
    let mut psi_inv = Vec::with_capacity(n);
    let mut closed: HashMap<Symbol, Id> = known.clone();
    for (i, &x) in states.iter().enumerate() {
        if let Some(&k) = known.get(&x) {
            psi_inv.push(Solution::Closed(k));
        } else if let Some(&s) = partial.get(&x) {
            if pool.depends_on_any(s, &unknown_states) {
                psi_inv.push(Solution::Numeric);
            } else {
                closed.insert(x, s);
                psi_inv.push(Solution::Closed(s));
            }
        } else {
            psi_inv.push(Solution::Numeric);
        }
        if psi_inv[i] == Solution::Numeric {
            warnings.push(format!(
                "state `{}` has no closed form in (ξ, η): ψ⁻¹ is solved by Newton's method",
                model.states[i].name
            ));
        }
    }
    for sol in psi_inv.iter_mut() {
        if let Solution::Closed(e) = sol {
            *e = pool.tidy(*e);
        }
    }
    for (i, sol) in psi_inv.iter().enumerate() {
        if let Solution::Closed(e) = sol {
            closed.insert(states[i], *e);
        }
    }
    Inverse {
        psi_inv,
        closed,
        domain,
    }
}

/// Solve the equations `eqs` (each `= 0`) for the unknown states by isolation, repeatedly: first those
/// with a single unknown, then any unknown of the others. Returns the partial solutions (possibly in terms
/// of each other) and the conditions they need.
fn isolate_all(
    pool: &mut Pool,
    mut eqs: Vec<Id>,
    known: &HashMap<Symbol, Id>,
    unknown_states: &[Symbol],
) -> (HashMap<Symbol, Id>, Vec<(Id, String)>) {
    let mut domain: Vec<(Id, String)> = Vec::new();
    let mut partial: HashMap<Symbol, Id> = HashMap::new();
    loop {
        let mut progress = false;
        for pass in 0..2 {
            let mut i = 0;
            while i < eqs.len() {
                let mut all = known.clone();
                all.extend(partial.iter().map(|(k, v)| (*k, *v)));
                let e = pool.substitute(eqs[i], &all);
                let unk: Vec<Symbol> = unknown_states
                    .iter()
                    .copied()
                    .filter(|s| pool.depends_on(e, *s) && !all.contains_key(s))
                    .collect();
                if unk.is_empty() || (pass == 0 && unk.len() != 1) {
                    i += 1;
                    continue;
                }
                let mut solved = false;
                for &x in &unk {
                    if let Some((sol, conds)) = isolate(pool, e, x) {
                        partial.insert(x, sol);
                        domain.extend(conds);
                        solved = true;
                        break;
                    }
                }
                if solved {
                    eqs.remove(i);
                    progress = true;
                } else {
                    i += 1;
                }
            }
            if progress {
                break;
            }
        }
        if !progress {
            break;
        }
    }
    (partial, domain)
}

/// Solve `e = 0` for `x`, if `x` can be isolated: `e` linear in `x`, or linear in a subterm K(x) that an
/// invertible function chain leads to. Returns the solution and the conditions it needs.
pub fn isolate(pool: &mut Pool, e: Id, x: Symbol) -> Option<(Id, Vec<(Id, String)>)> {
    let mut conds = Vec::new();
    // Candidate kernels: subterms containing x, smallest first (x itself first).
    let mut kernels: Vec<Id> = pool
        .topological(&[e])
        .into_iter()
        .filter(|&k| k != e && pool.depends_on(k, x))
        .collect();
    kernels.sort_by_key(|&k| pool.dag_size(&[k]));
    let z = pool.sym("__isolate_kernel");
    let zs = pool.as_symbol(z)?;
    for k in kernels {
        let ez = pool.replace(e, k, z);
        if pool.depends_on(ez, x) {
            continue;
        }
        // Linear in z: ez = a z + b with a, b free of z.
        let a = pool.diff(ez, zs);
        if pool.depends_on(a, zs) || pool.is_zero(a) {
            continue;
        }
        let zero = pool.zero();
        let b = pool.substitute(ez, &HashMap::from([(zs, zero)]));
        let nb = pool.neg(b);
        let rhs = pool.div(nb, a);
        if pool.as_number(a).is_none() {
            conds.push((a, format!("{} ≠ 0", pool.display(a))));
        }
        if let Some(sol) = invert_kernel(pool, k, rhs, x, &mut conds) {
            return Some((sol, conds));
        }
        conds.clear();
    }
    None
}

/// Solve K(x) = rhs for x by undoing the outermost invertible operation of K repeatedly.
fn invert_kernel(
    pool: &mut Pool,
    k: Id,
    rhs: Id,
    x: Symbol,
    conds: &mut Vec<(Id, String)>,
) -> Option<Id> {
    if pool.as_symbol(k) == Some(x) {
        return Some(rhs);
    }
    match pool.node(k).clone() {
        Node::Pow(b, p) if !pool.depends_on(p, x) => {
            // b^p = rhs ⇒ b = rhs^(1/p) (principal branch).
            let ip = pool.recip(p);
            let s = pool.pow(rhs, ip);
            match pool.as_number(p) {
                Some(n) if n.as_integer().is_some_and(|i| i % 2 != 0) => {}
                Some(n) if n.as_integer().is_some() => {
                    conds.push((rhs, format!("{} ≥ 0", pool.display(rhs))));
                    conds.push((
                        b,
                        format!("{} ≥ 0 (the positive root is taken)", pool.display(b)),
                    ));
                }
                _ => conds.push((rhs, format!("{} ≥ 0", pool.display(rhs)))),
            }
            invert_kernel(pool, b, s, x, conds)
        }
        Node::Pow(b, p) if !pool.depends_on(b, x) => {
            // b^p = rhs ⇒ p = log(rhs)/log(b).
            let l = pool.call(Func::Log, rhs);
            let lb = pool.call(Func::Log, b);
            let s = pool.div(l, lb);
            conds.push((rhs, format!("{} > 0", pool.display(rhs))));
            invert_kernel(pool, p, s, x, conds)
        }
        Node::Call(f, a) => {
            let s = invert_function(pool, f, a, rhs, conds)?;
            invert_kernel(pool, a, s, x, conds)
        }
        Node::Add(ts) => {
            // Exactly one term contains x: T = rhs − (others).
            let (with, without): (Vec<Id>, Vec<Id>) =
                ts.iter().partition(|&&t| pool.depends_on(t, x));
            if with.len() != 1 {
                return None;
            }
            let others = pool.add(&without);
            let s = pool.sub(rhs, others);
            invert_kernel(pool, with[0], s, x, conds)
        }
        Node::Mul(fs) => {
            let (with, without): (Vec<Id>, Vec<Id>) =
                fs.iter().partition(|&&t| pool.depends_on(t, x));
            if with.len() != 1 {
                return None;
            }
            let others = pool.mul(&without);
            if pool.as_number(others).is_none() {
                conds.push((others, format!("{} ≠ 0", pool.display(others))));
            }
            let s = pool.div(rhs, others);
            invert_kernel(pool, with[0], s, x, conds)
        }
        _ => None,
    }
}

/// Solve f(a) = rhs for a, for an invertible function f (on its principal branch), with the conditions
/// that needs; `None` for `abs` and `sign`.
fn invert_function(
    pool: &mut Pool,
    f: Func,
    a: Id,
    rhs: Id,
    conds: &mut Vec<(Id, String)>,
) -> Option<Id> {
    let half = pool.rational(1, 2);
    let one = pool.one();
    let s = match f {
        Func::Exp => {
            conds.push((rhs, format!("{} > 0", pool.display(rhs))));
            pool.call(Func::Log, rhs)
        }
        Func::Log => pool.call(Func::Exp, rhs),
        Func::Atan => pool.call(Func::Tan, rhs),
        Func::Tan => {
            conds.push((
                a,
                format!("|{}| < pi/2 (principal branch)", pool.display(a)),
            ));
            pool.call(Func::Atan, rhs)
        }
        Func::Sinh => {
            // asinh y = log(y + sqrt(y² + 1))
            let y2 = pool.powi(rhs, 2);
            let s1 = pool.add(&[y2, one]);
            let sq = pool.sqrt(s1);
            let arg = pool.add(&[rhs, sq]);
            pool.call(Func::Log, arg)
        }
        Func::Cosh => {
            // acosh y = log(y + sqrt(y² − 1)), branch a ≥ 0
            conds.push((a, format!("{} ≥ 0 (branch of acosh)", pool.display(a))));
            let y2 = pool.powi(rhs, 2);
            let m1 = pool.int(-1);
            let s1 = pool.add(&[y2, m1]);
            let sq = pool.sqrt(s1);
            let arg = pool.add(&[rhs, sq]);
            pool.call(Func::Log, arg)
        }
        Func::Tanh => {
            // atanh y = log((1 + y)/(1 − y))/2
            conds.push((rhs, format!("|{}| < 1", pool.display(rhs))));
            let p = pool.add(&[one, rhs]);
            let q = pool.sub(one, rhs);
            let frac = pool.div(p, q);
            let l = pool.call(Func::Log, frac);
            pool.mul(&[half, l])
        }
        Func::Sin | Func::Cos => {
            // asin y = atan(y/sqrt(1 − y²)); acos y = pi/2 − asin y
            conds.push((rhs, format!("|{}| < 1", pool.display(rhs))));
            let y2 = pool.powi(rhs, 2);
            let s1 = pool.sub(one, y2);
            let sq = pool.sqrt(s1);
            let ratio = pool.div(rhs, sq);
            let asin = pool.call(Func::Atan, ratio);
            if f == Func::Sin {
                conds.push((
                    a,
                    format!("|{}| ≤ pi/2 (principal branch)", pool.display(a)),
                ));
                asin
            } else {
                conds.push((
                    a,
                    format!("0 ≤ {} ≤ pi (principal branch)", pool.display(a)),
                ));
                let pi = pool.pi();
                let hp = pool.mul(&[half, pi]);
                pool.sub(hp, asin)
            }
        }
        Func::Abs | Func::Sign => return None,
    };
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isolates_through_invertible_functions() {
        let mut p = Pool::new();
        let x = p.symbol("x");
        let e = p.parse("a*exp(2*x) + b").unwrap();
        let (sol, conds) = isolate(&mut p, e, x).unwrap();
        let vals = HashMap::from([(p.symbol("a"), 2.0), (p.symbol("b"), -6.0)]);
        let xv = p.eval(sol, &vals).unwrap();
        assert!((xv - 3f64.ln() / 2.0).abs() < 1e-14, "{}", p.display(sol));
        assert!(!conds.is_empty());
        let e = p.parse("c*x^1.8 - d").unwrap();
        let (sol, _) = isolate(&mut p, e, x).unwrap();
        let vals = HashMap::from([(p.symbol("c"), 2.0), (p.symbol("d"), 8.0)]);
        assert!((p.eval(sol, &vals).unwrap() - 4f64.powf(1.0 / 1.8)).abs() < 1e-14);
        let e = p.parse("x*exp(x) - 1").unwrap();
        assert!(isolate(&mut p, e, x).is_none());
    }
}
