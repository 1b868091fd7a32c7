//! The choice of η scales polynomially with the number of states (greedy rank test, at most n + 1 rank tests)
//! and decides structurally triangular Jacobians exactly: large linear models with r = 1, long linear and
//! nonlinear chains with r = n, and chains observed in the middle (r < n).

use invsim_inversion::{Derivation, DeriveError, Model};
use std::fmt::Write;
use std::path::Path;

/// A model with the given state right-hand sides (`u` the input), parameter k = 1/2 and output `h`.
fn model(rhs: &[String], h: &str) -> String {
    let mut s = String::from("[parameters]\nk = 0.5\n[states]\n");
    for (i, r) in rhs.iter().enumerate() {
        let _ = writeln!(s, "x{} = {{ rhs = \"{r}\" }}", i + 1);
    }
    let _ = write!(
        s,
        "[input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"{h}\"\n"
    );
    s
}

fn derive(text: &str) -> Result<Derivation, DeriveError> {
    let m = Model::from_str(Path::new("test.toml"), text).unwrap_or_else(|e| panic!("{e}"));
    Derivation::new(m)
}

/// xI' = −I·xI + u, y = x1: r = 1.
fn decoupled(n: usize) -> String {
    let rhs: Vec<String> = (1..=n).map(|i| format!("-{i}*x{i} + u")).collect();
    model(&rhs, "x1")
}

/// xI' = decay(xI) + next(xI+1), xn' = decay(xn) + u; `THIS` and `NEXT` stand for xI and xI+1.
fn chain_of(n: usize, decay: &str, next: &str, h: &str) -> String {
    let rhs: Vec<String> = (1..=n)
        .map(|i| {
            let d = decay.replace("THIS", &format!("x{i}"));
            if i == n {
                format!("{d} + u")
            } else {
                format!("{d} + {}", next.replace("NEXT", &format!("x{}", i + 1)))
            }
        })
        .collect();
    model(&rhs, h)
}

/// xI' = −k·xI + xI+1, xn' = −k·xn + u.
fn chain(n: usize, h: &str) -> String {
    chain_of(n, "-k*THIS", "NEXT", h)
}

#[test]
fn many_states_with_relative_degree_one_take_n_rank_tests() {
    for n in [25, 32, 40, 60] {
        let d = derive(&decoupled(n)).unwrap_or_else(|e| panic!("n = {n}: {e}"));
        assert_eq!(d.relative_degree, 1);
        // All g ≠ 0: η are the first n − 1 states in order that keep ∂h/∂x = e_1 complete: x2 … xn.
        assert_eq!(d.eta_states, (1..n).collect::<Vec<_>>(), "n = {n}");
        assert!(
            d.rank_tests <= n + 1,
            "n = {n}: {} rank tests",
            d.rank_tests
        );
    }
}

#[test]
fn linear_chains_derive_with_one_rank_test() {
    // ∂ξ/∂x is unit lower-triangular with binomial entries: decided by exact elimination. (The long chains
    // of 22 … 40 states, which the old singular-value test called singular, are unit tests of
    // `derive::coordinates`: their ψ⁻¹ is large to build and print.)
    for n in [4, 9, 12] {
        let d = derive(&chain(n, "x1")).unwrap_or_else(|e| panic!("n = {n}: {e}"));
        assert_eq!(d.relative_degree, n);
        assert!(d.eta_states.is_empty());
        assert_eq!(d.rank_tests, 1);
    }
}

#[test]
fn chains_observed_near_the_end_keep_the_upstream_states_as_eta() {
    // y = x_m: r = n − m + 1, η = x1 … x_{m−1} (g ≡ 0 there), found in at most n + 1 rank tests.
    for (n, m) in [(30, 24), (40, 33), (24, 2 + 14)] {
        let d = derive(&chain(n, &format!("x{m}"))).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(d.relative_degree, n - m + 1);
        assert_eq!(d.eta_states, (0..m - 1).collect::<Vec<_>>());
        assert!(d.rank_tests <= n + 1);
    }
}

#[test]
fn nonlinear_chains_are_decided_exactly() {
    // xI' = −k·sin(xI)·xI + exp(xI+1/10): a triangular ∂ξ/∂x with products of exponentials on the diagonal
    // (the old singular-value test called n = 10 singular).
    for n in [3, 5] {
        let text = chain_of(n, "-k*sin(THIS)*THIS", "exp(NEXT/10)", "x1");
        let d = derive(&text).unwrap_or_else(|e| panic!("n = {n}: {e}"));
        assert_eq!(d.relative_degree, n);
        assert_eq!(d.rank_tests, 1);
    }
}

#[test]
fn dependent_lie_derivatives_are_reported_as_such() {
    // y = x1 − x2 with x1' = x2' = −x1 + x2 + … : L_f h = 0, so h alone is ξ; r = 1 here, rank fine. A true
    // rank defect needs ∂h/∂x ≡ 0 with r ≥ 1, impossible for h ≠ const; the error is covered by the message.
    let e = DeriveError::NoCoordinates {
        file: "m.toml".into(),
        r: 2,
        n: 3,
        m: 1,
        tol: 1e-9,
    };
    let msg = e.to_string();
    assert!(
        msg.contains("m.toml") && msg.contains("rank below 2"),
        "{msg}"
    );
    assert!(!msg.contains("every choice"), "{msg}");
}

#[test]
fn long_nonlinear_chains_stop_at_the_lie_derivative_budget() {
    // The 40-state chain of the issue and longer ones: an exit-2 error naming the limit, not gigabytes.
    for (n, decay, next) in [
        (40, "-k*sin(THIS)*THIS", "exp(NEXT/10)"),
        (40, "-k*THIS^3", "sin(NEXT)"),
    ] {
        let text = chain_of(n, decay, next, "x1");
        match derive(&text) {
            Err(e @ DeriveError::LieDerivativeTooLarge { .. }) => {
                let msg = e.to_string();
                assert!(msg.contains("MAX_LIE_DERIVATIVE_NODES"), "{msg}");
            }
            Err(e) => panic!("n = {n}: unexpected error {e}"),
            Ok(d) => panic!("n = {n}: derived with r = {}", d.relative_degree),
        }
    }
}
