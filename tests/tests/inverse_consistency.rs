//! The inverse simulation satisfies the original model: along NEDC, at every sample, the state and input that
//! the inverse computes make dx/dt = f(x) + g(x)·u hold, with dx/dt taken by the chain rule through ψ⁻¹ from
//! the smoother's exact derivatives (dξ_i/dt = y_d^(i), dη/dt = q(ξ, η, y^(r))) — an independent check of
//! α, β and ψ⁻¹. And the compiled and the interpreted engines agree.

use invsim_expr::{Id, Symbol, Tape};
use invsim_inversion::{derive_file, Derivation, Interpreter, Solution};
use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, SimulationOptions, SimulationResult};
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn run(model: &dyn InverseModel, dt: f64, engine: &str) -> SimulationResult {
    let cycle = Cycle::builtin("nedc").unwrap();
    let opts = SimulationOptions {
        dt,
        engine: engine.to_string(),
        ..SimulationOptions::default()
    };
    simulate(model, &cycle, &opts).unwrap()
}

/// ∂ψ⁻¹/∂(ξ, η) compiled over (ξ, η, params); `None` if ψ⁻¹ is not closed-form.
fn psi_inv_jacobian(d: &Derivation) -> Option<Tape> {
    let mut pool = d.pool().clone();
    let coords: Vec<Symbol> = d.xi.iter().chain(&d.eta).copied().collect();
    let mut exprs: Vec<Id> = Vec::new();
    for sol in &d.psi_inv {
        let Solution::Closed(e) = sol else {
            return None;
        };
        for &c in &coords {
            exprs.push(pool.diff(*e, c));
        }
    }
    let inputs: Vec<Symbol> = coords
        .iter()
        .copied()
        .chain(d.model.parameters.iter().map(|p| p.symbol))
        .collect();
    let values: Vec<f64> = d.model.parameters.iter().map(|p| p.value).collect();
    Some(
        Tape::compile(&pool, &exprs, &inputs)
            .unwrap()
            .specialize(&values),
    )
}

#[test]
fn si_engine_inverse_satisfies_the_original_equations_on_nedc() {
    let d = derive_file(&root().join("models/si_engine.toml")).unwrap();
    let interp = Interpreter::new(&d).unwrap();
    let res = run(&interp, 0.01, "interpreted");
    assert_eq!(res.len(), 118_001);
    let jac = psi_inv_jacobian(&d).expect("si_engine's psi_inv is closed-form");
    let (r, n) = (d.relative_degree, d.n());
    let yd: Vec<&[f64]> = (0..=r).map(|k| res.yd(k).unwrap()).collect();
    let u = res.input();
    let xs: Vec<&[f64]> = d
        .model
        .states
        .iter()
        .map(|s| res.column(&s.name).unwrap())
        .collect();
    // Per sample and state: the residual of dx/dt = f + g·u, relative to the magnitude of the terms that
    // balance, |f_s| + |g_s·u|, floored at 1e-6 of that magnitude's largest value over the run (at a constant
    // speed both sides are ~0 while f's own parts — traction and resistance — are not).
    let mut rows = Vec::with_capacity(res.len());
    let mut j = vec![0.0; n * r];
    let mut dx = vec![0.0; n];
    let mut f = vec![0.0; n];
    let mut peak = vec![0.0f64; n];
    for k in 0..res.len() {
        let xi: Vec<f64> = (0..r).map(|i| yd[i][k]).collect();
        let x: Vec<f64> = xs.iter().map(|c| c[k]).collect();
        jac.eval(&xi, &mut j);
        interp.rhs(&x, &[], u[k], &mut dx);
        interp.rhs(&x, &[], 0.0, &mut f);
        let row: Vec<(f64, f64, f64)> = (0..n)
            .map(|s| {
                // Chain rule: dx_s/dt = Σ_i ∂ψ⁻¹_s/∂ξ_i · y_d^(i+1).
                let chain: f64 = (0..r).map(|i| j[s * r + i] * yd[i + 1][k]).sum();
                let magnitude = f[s].abs() + (dx[s] - f[s]).abs();
                peak[s] = peak[s].max(magnitude);
                (chain, dx[s], magnitude)
            })
            .collect();
        rows.push(row);
    }
    let mut worst = (0.0f64, 0usize, 0usize);
    for (k, row) in rows.iter().enumerate() {
        for (s, &(chain, rhs, magnitude)) in row.iter().enumerate() {
            let rel = (chain - rhs).abs() / magnitude.max(1e-6 * peak[s]);
            if rel > worst.0 {
                worst = (rel, k, s);
            }
        }
    }
    assert!(worst.0 < 1e-8, "worst relative residual {worst:?}");
}

#[test]
fn compiled_and_interpreted_si_engine_agree_on_nedc() {
    let path = root().join("models/si_engine.toml");
    let d = derive_file(&path).unwrap();
    let interp = Interpreter::new(&d).unwrap();
    let compiled =
        invsim_models::by_hash(&d.model.source_hash).expect("si_engine is a built-in model");
    let a = run(&interp, 0.01, "interpreted");
    let b = run(compiled.as_ref(), 0.01, "compiled");
    assert_eq!(a.columns, b.columns);
    for (name, (ca, cb)) in a.columns.iter().zip(a.data.iter().zip(&b.data)) {
        let scale = ca.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
        // Relative to the value, with a floor of 1e-15 of the column's scale: a quantity that passes through
        // zero by cancellation (T_e of a standing car, the difference of pressures of order 1e5 Pa) carries
        // the rounding of its terms, not of its value.
        for (k, (x, y)) in ca.iter().zip(cb).enumerate() {
            assert!(
                (x - y).abs() <= 1e-10 * x.abs().max(1e-5 * scale),
                "{name}[{k}]: interpreted {x} vs compiled {y}"
            );
        }
    }
    assert_eq!(
        a.summary.totals.integrals.len(),
        b.summary.totals.integrals.len()
    );
    for (key, va) in &a.summary.totals.integrals {
        let vb = b.summary.totals.integrals[key];
        assert!((va - vb).abs() <= 1e-10 * va.abs(), "{key}: {va} vs {vb}");
    }
}
