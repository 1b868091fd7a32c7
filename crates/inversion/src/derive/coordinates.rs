//! The normal-form coordinates: ξ = (h, L_f h, …, L_f^{r−1} h) and η = n − r states chosen so that
//! ψ(x) = (ξ, η) is a coordinate change, ∂(ξ, η)/∂x nonsingular, preferring states with L_g η = g_η ≡ 0
//! (Isidori, *Nonlinear Control Systems*, 3rd ed., Prop. 4.1.3). Nonsingularity is a numerical rank test
//! at random probe points (rows scaled to unit norm, smallest singular value above 1e-9 at most points).

use crate::model::Model;
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

/// Choose η among the states: the first combination of n − r states (those with g ≡ 0 first) that makes
/// ∂(ξ, η)/∂x generically nonsingular, or `None`. A chosen state with L_g η ≠ 0 is reported in `warnings`.
pub(super) fn choose_coordinates(
    model: &mut Model,
    lie: &[Id],
    r: usize,
    eta: &[Symbol],
    warnings: &mut Vec<String>,
) -> Option<Coordinates> {
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
    let mut chosen: Option<Vec<usize>> = None;
    for combo in combinations(&candidates, n - r) {
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
    let mut eta_states = chosen?;
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
    Some(Coordinates {
        eta_states,
        psi,
        jacobian,
    })
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
}
