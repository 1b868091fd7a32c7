//! The normal-form coordinates: ξ = (h, L_f h, …, L_f^{r−1} h) and η = n − r states chosen so that
//! ψ(x) = (ξ, η) is a coordinate change, ∂(ξ, η)/∂x nonsingular, preferring states with L_g η = g_η ≡ 0
//! (Isidori, *Nonlinear Control Systems*, 3rd ed., Prop. 4.1.3), by a greedy choice with the rank test of
//! `rank.rs` (exact triangular elimination, then a numerical rank test at random probe points).

use super::rank::RankTest;
use crate::model::{derivative_name, Model};
use invsim_expr::{zero_test, Id, Pool, Rng, Symbol};
use std::collections::HashMap;

/// The chosen η and the coordinate change ψ with its Jacobian.
pub(super) struct Coordinates {
    /// Indices of the states chosen as η (`η_j = x_{eta_states[j]}`), ascending.
    pub(super) eta_states: Vec<usize>,
    /// ψ(x) = (ξ, η) in the states: L_f^k h for k < r, then the η states.
    pub(super) psi: Vec<Id>,
    /// ∂ψ/∂x (n × n, row i = ∂ψ_i/∂x).
    pub(super) jacobian: Vec<Vec<Id>>,
    /// Rank tests the choice took (at most n + 1).
    pub(super) rank_tests: usize,
}

/// Every signal's symbol S and its derivatives' S_dk that the derivation has created, in file order.
fn signal_symbols(model: &Model) -> Vec<Symbol> {
    let mut out = Vec::new();
    for s in &model.signals {
        out.push(s.symbol);
        for k in 1..=model.states.len() + 1 {
            if let Some(d) = model.pool.find_symbol(&derivative_name(&s.name, k)) {
                out.push(d);
            }
        }
    }
    out
}

/// Random probe points: parameters at nominal values, states uniformly in [0.2, 3] (signals and their
/// derivatives too).
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
            for s in signal_symbols(model) {
                m.insert(s, rng.uniform(0.2, 3.0));
            }
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
            for s in signal_symbols(model) {
                m.insert(s, rng.uniform(0.2, 3.0));
            }
            m
        })
        .collect()
}

/// The symbols ξ1 … ξr, η1 … η(n−r) and `yr` (= y^(r)).
pub(super) fn coordinate_symbols(
    pool: &mut Pool,
    r: usize,
    n: usize,
) -> (Vec<Symbol>, Vec<Symbol>, Symbol) {
    let xi: Vec<Symbol> = (1..=r).map(|i| pool.symbol(&format!("xi{i}"))).collect();
    let eta: Vec<Symbol> = (1..=n - r)
        .map(|i| pool.symbol(&format!("eta{i}")))
        .collect();
    let yr = pool.symbol("yr");
    (xi, eta, yr)
}

/// Choose η among the states: n − r states, those with g ≡ 0 first (then by index), chosen greedily — a
/// state joins η when ξ together with the states chosen so far and it remains independent, i.e. when ∂ξ/∂x
/// restricted to the other columns keeps full row rank r (`rank.rs`). For a linear matroid this greedy
/// choice is the lexicographically first basis, the first combination an enumeration of subsets in the same
/// order would find (Oxley, *Matroid Theory*, 2nd ed., §1.8), in at most n + 1 rank tests instead of
/// C(n, n − r). `Err` with the number of rank tests if ∂ξ/∂x has rank below r. A chosen state with
/// L_g η ≠ 0 is reported in `warnings`.
pub(super) fn choose_coordinates(
    model: &mut Model,
    lie: &[Id],
    r: usize,
    eta: &[Symbol],
    warnings: &mut Vec<String>,
) -> Result<Coordinates, usize> {
    let n = model.states.len();
    let states = model.state_symbols();
    let nominal = model.nominal();
    let g: Vec<Id> = model.states.iter().map(|s| s.g).collect();
    let points = probe_points(model, 12, 0xC0FFEE);
    let wide = if n > r {
        wide_probe_points(model, 512, 0x5CA1E)
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
    let mut rank = RankTest::new(pool, &jac_xi, &nominal, &points, &wide);
    let mut xi_columns: Vec<usize> = (0..n).collect();
    if !rank.full_row_rank(&xi_columns) {
        return Err(rank.tests);
    }
    let mut eta_states = Vec::with_capacity(n - r);
    for &c in &candidates {
        if eta_states.len() == n - r {
            break;
        }
        let rest: Vec<usize> = xi_columns.iter().copied().filter(|&j| j != c).collect();
        if rank.full_row_rank(&rest) {
            eta_states.push(c);
            xi_columns = rest;
        }
    }
    if eta_states.len() < n - r {
        return Err(rank.tests);
    }
    let rank_tests = rank.tests;
    eta_states.sort_unstable();
    for (j, &c) in eta_states.iter().enumerate() {
        if !g_zero[c] {
            let state = &model.states[c].name;
            warnings.push(format!(
                "internal coordinate {} = {state} has L_g η ≠ 0: the input acts on `{state}` directly and \
                 no state free of it could be chosen, so the zero dynamics dη/dt = L_f η + L_g η · u depend \
                 on the input, through u = (y^(r) − α)/β on the reference's r-th derivative; expected for a \
                 state the input drives (a charge state, a pressure), and the run handles it",
                pool.symbol_name(eta[j]),
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
    Ok(Coordinates {
        eta_states,
        psi,
        jacobian,
        rank_tests,
    })
}

#[cfg(test)]
mod tests {
    use super::super::relative_degree::{relative_degree, RelativeDegree};
    use super::super::total_derivative::TotalDerivative;
    use super::*;
    use std::fmt::Write;
    use std::path::Path;

    /// xI' = decay(xI) + next(xI+1), xn' = decay(xn) + u, y = x1 (`THIS`, `NEXT` stand for xI, xI+1).
    fn chain(n: usize, decay: &str, next: &str) -> Model {
        let mut s = String::from("[parameters]\nk = 0.5\n[states]\n");
        for i in 1..=n {
            let d = decay.replace("THIS", &format!("x{i}"));
            let tail = if i == n {
                "u".to_string()
            } else {
                next.replace("NEXT", &format!("x{}", i + 1))
            };
            let _ = writeln!(s, "x{i} = {{ rhs = \"{d} + {tail}\" }}");
        }
        s.push_str("[input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"x1\"\n");
        Model::from_str(Path::new("chain.toml"), &s).unwrap_or_else(|e| panic!("{e}"))
    }

    /// The relative degree and the result of the choice of η with its number of rank tests.
    fn choose(mut model: Model) -> (usize, Result<Vec<usize>, usize>, usize) {
        let (states, nominal, h) = (model.state_symbols(), model.nominal(), model.output.h);
        let field = TotalDerivative::new(&mut model, states.len() + 1);
        let mut warnings = Vec::new();
        let Ok(RelativeDegree { r, lie, .. }) = relative_degree(
            &mut model.pool,
            h,
            &field,
            states.len(),
            &nominal,
            &mut warnings,
        ) else {
            panic!("no relative degree");
        };
        let (_, eta, _) = coordinate_symbols(&mut model.pool, r, states.len());
        match choose_coordinates(&mut model, &lie, r, &eta, &mut warnings) {
            Ok(c) => (r, Ok(c.eta_states), c.rank_tests),
            Err(tests) => (r, Err(tests), tests),
        }
    }

    #[test]
    fn long_linear_chains_are_nonsingular() {
        // ∂ξ/∂x is unit lower-triangular, entries C(k, j)·(−k)^(k−j): the old singular-value test called
        // it singular from n = 22 on.
        for n in [21, 22, 30, 40] {
            let (r, eta, tests) = choose(chain(n, "-k*THIS", "NEXT"));
            assert_eq!(r, n);
            assert_eq!(eta, Ok(Vec::new()), "n = {n}");
            assert_eq!(tests, 1);
        }
    }

    #[test]
    fn long_nonlinear_chains_are_nonsingular() {
        for n in [6, 8, 10] {
            let (r, eta, tests) = choose(chain(n, "-k*sin(THIS)*THIS", "exp(NEXT/10)"));
            assert_eq!(r, n);
            assert_eq!(eta, Ok(Vec::new()), "n = {n}");
            assert_eq!(tests, 1);
        }
    }
}
