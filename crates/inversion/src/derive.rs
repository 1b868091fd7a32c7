//! The derivation: Lie derivatives, relative degree, normal-form coordinates, ψ⁻¹, α, β and zero dynamics.
//!
//! For x' = f(x) + g(x)u, y = h(x) (Isidori, *Nonlinear Control Systems*, 3rd ed., §4.1; Khalil,
//! *Nonlinear Systems*, 3rd ed., §13.2; Fröberg & Nielsen 2004, eq. 24–32):
//!
//! * L_f φ = ∇φ · f, and L_f^k h = L_f(L_f^{k−1} h);
//! * the relative degree r is the first k with L_g L_f^{k−1} h ≢ 0 (Isidori Def. 4.1.1, here "not
//!   identically zero" rather than "nonzero at x°", so that singular sets are reported, not hidden);
//! * ξ = (h, L_f h, …, L_f^{r−1} h), η = n − r states chosen so that ∂(ξ, η)/∂x is nonsingular, preferring
//!   states with L_g η = g_η ≡ 0 (Isidori Prop. 4.1.3);
//! * y^(r) = α(ξ, η) + β(ξ, η) u with α = L_f^r h ∘ ψ⁻¹, β = L_g L_f^{r−1} h ∘ ψ⁻¹ (paper eq. 26–28);
//! * zero dynamics dη/dt = L_f η + L_g η · (y^(r) − α)/β, expressed in (ξ, η, y^(r)).

use crate::model::Model;
use invsim_expr::{zero_test, DecidedBy, Func, Id, Node, Number, Pool, Rng, Symbol, ZeroVerdict};
use std::collections::HashMap;
use thiserror::Error;

/// Why a model cannot be inverted.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DeriveError {
    #[error(
        "{file}: the output `{output}` does not depend on the input `{input}` through any number of \
         derivatives: L_g L_f^k h is identically zero for k = 0 … {last} (n = {n}), so the model has no \
         relative degree and cannot be inverted for this output; choose an output the input reaches, or \
         check that the input enters the right-hand sides"
    )]
    NoRelativeDegree {
        file: String,
        output: String,
        input: String,
        n: usize,
        last: usize,
    },
    #[error(
        "{file}: no choice of {m} internal state(s) η completes ξ = (h, …, L_f^(r-1) h) to a coordinate \
         change: ∂(ξ, η)/∂x is singular for every choice (the L_f^k h are not independent)"
    )]
    NoCoordinates { file: String, m: usize },
}

/// How a state of ψ⁻¹ was obtained.
#[derive(Debug, Clone, PartialEq)]
pub enum Solution {
    /// Closed form in ξ, η and parameters.
    Closed(Id),
    /// No closed form was found: solved by Newton's method at run time (Jacobian in [`Derivation::jacobian`]).
    Numeric,
}

/// Everything derived for one model. Expressions live in `model.pool`.
#[derive(Debug, Clone)]
pub struct Derivation {
    pub model: Model,
    /// Relative degree r.
    pub relative_degree: usize,
    /// L_f^k h for k = 0 … r, in the original states.
    pub lie: Vec<Id>,
    /// L_g L_f^k h for k = 0 … r − 1 (all but the last identically zero), in the states.
    pub lg_lie: Vec<Id>,
    /// How each L_g L_f^k h was found zero or nonzero.
    pub lg_decided_by: Vec<DecidedBy>,
    /// The symbols ξ1 … ξr and η1 … η(n−r).
    pub xi: Vec<Symbol>,
    pub eta: Vec<Symbol>,
    /// Indices of the states chosen as η (η_j = x_{eta_states[j]}).
    pub eta_states: Vec<usize>,
    /// ψ(x) = (ξ, η) in the states: lie[0..r] then the η states.
    pub psi: Vec<Id>,
    /// ψ⁻¹ per state.
    pub psi_inv: Vec<Solution>,
    /// ∂ψ/∂x (n × n, row i = ∂ψ_i/∂x), for Newton's method and for the chain rule.
    pub jacobian: Vec<Vec<Id>>,
    /// α and β in (ξ, η) — with any numerically solved states left as state symbols.
    pub alpha: Id,
    pub beta: Id,
    /// α = L_f^r h and β = L_g L_f^{r−1} h in the original states.
    pub alpha_x: Id,
    pub beta_x: Id,
    /// dη_j/dt in (ξ, η, yr) (and numerically solved states, if any).
    pub zero_dynamics: Vec<Id>,
    /// dη_j/dt in (x, yr).
    pub zero_dynamics_x: Vec<Id>,
    /// The symbol `yr` (= y^(r)).
    pub yr: Symbol,
    /// Where β vanishes, in words.
    pub singular: Vec<String>,
    /// Conditions under which the closed-form ψ⁻¹ is valid (divisors nonzero, roots real, branches).
    pub domain: Vec<String>,
    pub warnings: Vec<String>,
}

/// L_v φ = Σ_i ∂φ/∂x_i · v_i.
pub fn lie_derivative(pool: &mut Pool, phi: Id, v: &[Id], states: &[Symbol]) -> Id {
    let mut terms = Vec::with_capacity(states.len());
    for (i, &x) in states.iter().enumerate() {
        if !pool.depends_on(phi, x) || pool.is_zero(v[i]) {
            continue;
        }
        let d = pool.diff(phi, x);
        terms.push(pool.mul(&[d, v[i]]));
    }
    pool.add(&terms)
}

/// Random probe points: parameters at nominal values, states uniformly in [0.2, 3].
fn probe_points(model: &Model, count: usize, seed: u64) -> Vec<HashMap<Symbol, f64>> {
    let mut rng = Rng::new(seed);
    let nominal = model.nominal();
    let states = model.state_symbols();
    (0..count)
        .map(|_| {
            let mut m = nominal.clone();
            for &s in &states {
                m.insert(s, rng.uniform(0.2, 3.0));
            }
            m.insert(model.input.symbol, rng.uniform(0.2, 3.0));
            m
        })
        .collect()
}

/// Wider probe points for models whose expressions are not finite anywhere on [0.2, 3] (physical units: a
/// pressure in Pa under a square root of 1 − p_amb/p): every state log-uniform over [1e-3, 1e7].
fn wide_probe_points(model: &Model, count: usize, seed: u64) -> Vec<HashMap<Symbol, f64>> {
    let mut rng = Rng::new(seed);
    let nominal = model.nominal();
    let states = model.state_symbols();
    (0..count)
        .map(|_| {
            let mut m = nominal.clone();
            for &s in &states {
                m.insert(s, 10f64.powf(rng.uniform(-3.0, 7.0)));
            }
            m.insert(model.input.symbol, rng.uniform(0.2, 3.0));
            m
        })
        .collect()
}

/// [`generically_nonsingular`] on `points`, or on `wide` where the matrix is finite at none of `points`.
fn generically_nonsingular_or_wide(
    pool: &Pool,
    rows: &[Vec<Id>],
    points: &[HashMap<Symbol, f64>],
    wide: &[HashMap<Symbol, f64>],
) -> bool {
    let finite_somewhere = points.iter().any(|p| {
        rows.iter()
            .flatten()
            .all(|&e| pool.eval(e, p).is_ok_and(|v| v.is_finite()))
    });
    if finite_somewhere {
        generically_nonsingular(pool, rows, points)
    } else {
        generically_nonsingular(pool, rows, wide)
    }
}

/// Numerical rank test of an n×n matrix of expressions: nonsingular at most probe points.
fn generically_nonsingular(pool: &Pool, rows: &[Vec<Id>], points: &[HashMap<Symbol, f64>]) -> bool {
    let n = rows.len();
    let mut good = 0;
    let mut tried = 0;
    for p in points {
        let mut m = nalgebra::DMatrix::<f64>::zeros(n, n);
        let mut ok = true;
        for i in 0..n {
            for j in 0..n {
                match pool.eval(rows[i][j], p) {
                    Ok(v) if v.is_finite() => m[(i, j)] = v,
                    _ => ok = false,
                }
            }
        }
        if !ok {
            continue;
        }
        tried += 1;
        // Scale rows so that the test is unit-independent.
        for i in 0..n {
            let norm = m.row(i).norm();
            if norm > 0.0 {
                let scaled = m.row(i) / norm;
                m.set_row(i, &scaled);
            }
        }
        let sv = m.svd(false, false).singular_values;
        let min = sv.iter().copied().fold(f64::INFINITY, f64::min);
        if min > 1e-9 {
            good += 1;
        }
    }
    tried > 0 && good * 2 > tried
}

impl Derivation {
    /// Derive the normal form of a loaded model.
    pub fn new(model: Model) -> Result<Derivation, DeriveError> {
        let mut model = model;
        let n = model.states.len();
        let states = model.state_symbols();
        let nominal = model.nominal();
        let f: Vec<Id> = model.states.iter().map(|s| s.f).collect();
        let g: Vec<Id> = model.states.iter().map(|s| s.g).collect();
        let file = model.file.display().to_string();
        let params: Vec<Symbol> = model.parameters.iter().map(|p| p.symbol).collect();
        let pool = &mut model.pool;
        let mut warnings = Vec::new();

        // Relative degree: first k with L_g L_f^(k-1) h ≢ 0.
        let mut lie = vec![model.output.h];
        let mut lg_lie = Vec::new();
        let mut lg_decided_by = Vec::new();
        let mut r = None;
        for k in 0..n {
            let lg = lie_derivative(pool, lie[k], &g, &states);
            let verdict = zero_test(pool, lg, &nominal);
            lg_lie.push(lg);
            lg_decided_by.push(verdict.decided_by());
            if let ZeroVerdict::Zero(DecidedBy::Probing) = verdict {
                warnings.push(format!(
                    "L_g L_f^{k} h = {} was taken as identically zero by numeric probing",
                    pool.display(lg)
                ));
            }
            let next = lie_derivative(pool, lie[k], &f, &states);
            lie.push(next);
            if !verdict.is_zero() {
                r = Some(k + 1);
                break;
            }
        }
        let Some(r) = r else {
            return Err(DeriveError::NoRelativeDegree {
                file,
                output: model.output.name.clone(),
                input: model.input.name.clone(),
                n,
                last: n.saturating_sub(1),
            });
        };
        let decoupling = *lg_lie.last().expect("r ≥ 1 implies one L_g L_f^k h");
        let alpha_x = lie[r];

        let xi: Vec<Symbol> = (1..=r).map(|i| pool.symbol(&format!("xi{i}"))).collect();
        let eta: Vec<Symbol> = (1..=n - r)
            .map(|i| pool.symbol(&format!("eta{i}")))
            .collect();
        let yr = pool.symbol("yr");

        // Choose η among the states.
        let points = probe_points(&model, 12, 0xC0FFEE);
        let wide = if n > r {
            wide_probe_points(&model, 512, 0x5CA1E)
        } else {
            Vec::new()
        };
        let pool = &mut model.pool;
        let jac_xi: Vec<Vec<Id>> = (0..r)
            .map(|k| states.iter().map(|&x| pool.diff(lie[k], x)).collect())
            .collect();
        let mut candidates: Vec<usize> = (0..n).collect();
        let g_zero: Vec<bool> = g
            .iter()
            .map(|&gi| zero_test(pool, gi, &nominal).is_zero())
            .collect();
        candidates.sort_by_key(|&i| (!g_zero[i], i));
        let m = n - r;
        let mut chosen: Option<Vec<usize>> = None;
        for combo in combinations(&candidates, m) {
            let mut rows = jac_xi.clone();
            for &c in &combo {
                let row: Vec<Id> = (0..n)
                    .map(|j| if j == c { pool.one() } else { pool.zero() })
                    .collect();
                rows.push(row);
            }
            if generically_nonsingular_or_wide(pool, &rows, &points, &wide) {
                chosen = Some(combo);
                break;
            }
        }
        let Some(mut eta_states) = chosen else {
            return Err(DeriveError::NoCoordinates { file, m });
        };
        eta_states.sort_unstable();
        for &c in &eta_states {
            if !g_zero[c] {
                warnings.push(format!(
                    "internal coordinate {} = {} has L_g η ≠ 0: the zero dynamics depend on the input",
                    pool.symbol_name(eta[eta_states.iter().position(|&e| e == c).unwrap_or(0)]),
                    model.states[c].name
                ));
            }
        }
        let mut psi: Vec<Id> = lie[..r].to_vec();
        let mut jacobian = jac_xi;
        for &c in &eta_states {
            psi.push(pool.var(states[c]));
            jacobian.push(
                (0..n)
                    .map(|j| if j == c { pool.one() } else { pool.zero() })
                    .collect(),
            );
        }

        // ψ⁻¹ by isolating one unknown at a time.
        let mut known: HashMap<Symbol, Id> = HashMap::new();
        for (j, &c) in eta_states.iter().enumerate() {
            let e = pool.var(eta[j]);
            known.insert(states[c], e);
        }
        let mut domain: Vec<(Id, String)> = Vec::new();
        let mut eqs: Vec<Id> = (0..r)
            .map(|k| {
                let x = pool.var(xi[k]);
                pool.sub(lie[k], x)
            })
            .collect();
        let unknown_states: Vec<Symbol> = (0..n)
            .filter(|i| !eta_states.contains(i))
            .map(|i| states[i])
            .collect();
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

        // Express α, β and the zero dynamics in (ξ, η): first replace each L_f^k h (k < r) that occurs as a
        // subterm by ξ_{k+1} (it often does: L_f^2 h contains L_f h when h is a state), then substitute ψ⁻¹
        // for the remaining states. This keeps α in the paper's structure (eq. 28) instead of re-expanding
        // ξ2 in terms of ξ.
        let lie_to_xi = |pool: &mut Pool, e: Id| -> Id {
            let mut e = e;
            for k in (1..r).rev() {
                let x = pool.var(xi[k]);
                e = pool.replace_product(e, lie[k], x);
            }
            e
        };
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
        let to_coords = |pool: &mut Pool, e: Id| -> Id {
            let e = lie_to_xi(pool, e);
            let e = pool.substitute(e, &closed);
            pool.tidy(e)
        };
        let alpha = to_coords(pool, alpha_x);
        let beta = to_coords(pool, decoupling);

        // Zero dynamics: dη/dt = f_η + g_η (yr − α)/β.
        let yr_e = pool.var(yr);
        let num = pool.sub(yr_e, alpha_x);
        let u_x = pool.div(num, decoupling);
        let mut zero_dynamics_x = Vec::with_capacity(m);
        let mut zero_dynamics = Vec::with_capacity(m);
        for &c in &eta_states {
            let gu = pool.mul(&[g[c], u_x]);
            let q = pool.add(&[f[c], gu]);
            zero_dynamics_x.push(q);
            zero_dynamics.push(to_coords(pool, q));
        }

        let singular = singular_set(pool, beta, &nominal, &xi, &eta);
        for s in &singular {
            warnings.push(format!("β vanishes: {s}"));
        }
        // Conditions on parameters alone (true at the nominal values, or the model would not derive) are not
        // worth reporting; the others are stated in (ξ, η) or, for branches, in the states.
        let mut domain: Vec<String> = domain
            .into_iter()
            .filter(|(e, _)| pool.free_symbols(*e).iter().any(|s| !params.contains(s)))
            .map(|(_, text)| text)
            .collect();
        domain.dedup();

        Ok(Derivation {
            model,
            relative_degree: r,
            lie,
            lg_lie,
            lg_decided_by,
            xi,
            eta,
            eta_states,
            psi,
            psi_inv,
            jacobian,
            alpha,
            beta,
            alpha_x,
            beta_x: decoupling,
            zero_dynamics,
            zero_dynamics_x,
            yr,
            singular,
            domain,
            warnings,
        })
    }

    pub fn pool(&self) -> &Pool {
        &self.model.pool
    }

    /// Number of states n.
    pub fn n(&self) -> usize {
        self.model.states.len()
    }

    /// Are all entries of ψ⁻¹ in closed form?
    pub fn psi_inv_closed(&self) -> bool {
        self.psi_inv
            .iter()
            .all(|s| matches!(s, Solution::Closed(_)))
    }
}

/// All `k`-subsets of `items`, in lexicographic order of positions.
fn combinations(items: &[usize], k: usize) -> Vec<Vec<usize>> {
    if k == 0 {
        return vec![Vec::new()];
    }
    let mut out = Vec::new();
    for (i, &first) in items.iter().enumerate() {
        for mut rest in combinations(&items[i + 1..], k - 1) {
            rest.insert(0, first);
            out.push(rest);
        }
    }
    out
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

/// Describe where β(ξ, η) vanishes: symbolic factors that are coordinates (β = 0 on ξ1 = 0), parameter
/// factors that are zero at their nominal values, and sign changes of other factors found by probing.
fn singular_set(
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn combinations_in_order() {
        assert_eq!(
            combinations(&[0, 1, 2], 2),
            vec![vec![0, 1], vec![0, 2], vec![1, 2]]
        );
        assert_eq!(combinations(&[5, 7], 0), vec![Vec::<usize>::new()]);
        assert_eq!(combinations(&[5, 7], 2), vec![vec![5, 7]]);
    }

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
