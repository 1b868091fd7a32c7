//! Property tests of the derivation against independent numerical references: L_f h computed symbolically
//! agrees with ∇h · f from central finite differences, and ψ(ψ⁻¹(ξ, η)) = (ξ, η) for every acceptance model.

use invsim_inversion::{derive_file, Derivation, Interpreter};
use invsim_model_api::InverseModel;
use proptest::prelude::*;
use std::collections::HashMap;
use std::path::PathBuf;

/// Every loadable model: `models/*.toml`, plus `shared/models/*.toml` when present.
fn models() -> Vec<(String, Derivation)> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut dirs = vec![root.join("models")];
    let shared = root.join("../shared/models");
    if shared.is_dir() {
        dirs.push(shared);
    } else {
        eprintln!("skipping shared models: ../shared not found");
    }
    let mut out = Vec::new();
    for dir in dirs {
        let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        for f in files {
            // Models with signals (total derivatives along x(t), w(t)) and non-affine models have their own tests.
            if let Some(d) = derive_file(&f)
                .ok()
                .filter(|d| d.model.signals.is_empty() && d.affine)
            {
                out.push((f.display().to_string(), d));
            }
        }
    }
    assert!(out.len() >= 2, "no models found");
    out
}

/// A state vector in a physically sensible range for the model (si_engine's pressure is in Pa): the first of a
/// few unit-based ranges where the vector field and the Lie derivatives are finite (diesel_gasflow's pressures
/// lie above ambient, its turbocharger turns at thousands of rad/s).
fn state_point(d: &Derivation, u: &[f64]) -> Vec<f64> {
    let point = |variant: usize| -> Vec<f64> {
        d.model
            .states
            .iter()
            .zip(u)
            .map(|(s, &r)| match (s.unit.as_deref(), variant) {
                (Some("Pa"), 0) => 2e4 + 8e4 * r,
                (Some("Pa"), _) => 1.1e5 + 1.4e5 * r,
                (Some("m/s"), _) => 1.0 + 39.0 * r,
                (Some("rad/s"), 1) => 2e3 + 1e4 * r,
                _ => -1.5 + 3.0 * r,
            })
            .collect()
    };
    let finite = |x: &[f64]| {
        let mut env: HashMap<_, _> = d.model.nominal();
        for (s, v) in d.model.state_symbols().iter().zip(x) {
            env.insert(*s, *v);
        }
        let exprs = d
            .model
            .states
            .iter()
            .map(|s| s.f)
            .chain(d.lie.iter().copied());
        exprs
            .into_iter()
            .all(|e| d.pool().eval(e, &env).is_ok_and(f64::is_finite))
    };
    (0..2)
        .map(point)
        .find(|x| finite(x))
        .unwrap_or_else(|| point(0))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]

    #[test]
    fn lie_derivatives_match_finite_differences(u in proptest::collection::vec(0.05f64..0.95, 8)) {
        for (name, d) in models() {
            let x = state_point(&d, &u);
            let states = d.model.state_symbols();
            let mut env: HashMap<_, _> = d.model.nominal();
            for (s, v) in states.iter().zip(&x) {
                env.insert(*s, *v);
            }
            let f: Vec<f64> = d.model.states.iter().map(|s| d.pool().eval(s.f, &env).unwrap()).collect();
            for k in 0..d.relative_degree {
                // ∇(L_f^k h) · f by 4th-order central differences; `terms` = Σ |∂_i(L_f^k h) f_i|, the size of
                // what the sum cancels (its rounding error is relative to that, not to the small result).
                let (mut grad_dot_f, mut terms) = (0.0, 0.0);
                for (i, s) in states.iter().enumerate() {
                    let h = 1e-3 * x[i].abs().max(1e-2);
                    let at = |dx: f64| {
                        let mut e = env.clone();
                        e.insert(*s, x[i] + dx);
                        d.pool().eval(d.lie[k], &e).unwrap()
                    };
                    let deriv = (-at(2.0 * h) + 8.0 * at(h) - 8.0 * at(-h) + at(-2.0 * h)) / (12.0 * h);
                    grad_dot_f += deriv * f[i];
                    terms += (deriv * f[i]).abs();
                }
                let symbolic = d.pool().eval(d.lie[k + 1], &env).unwrap();
                let scale = symbolic
                    .abs()
                    .max(terms)
                    .max(1e-6 * d.pool().eval(d.lie[k], &env).unwrap().abs())
                    .max(1e-9);
                prop_assert!(
                    (symbolic - grad_dot_f).abs() <= 1e-6 * scale,
                    "{name}: L_f^{} h = {symbolic} vs ∇·f = {grad_dot_f} at {x:?}", k + 1
                );
            }
        }
    }

    #[test]
    fn psi_of_psi_inverse_is_identity(u in proptest::collection::vec(0.05f64..0.95, 8)) {
        for (name, d) in models() {
            let interp = Interpreter::new(&d).unwrap();
            let n = d.n();
            let r = d.relative_degree;
            // A reachable (ξ, η): the image of a state.
            let x0 = state_point(&d, &u);
            let (mut xi, mut eta) = (vec![0.0; r], vec![0.0; n - r]);
            interp.psi(&x0[..n], &[], &mut xi, &mut eta);
            let mut x = vec![1.0; n];
            interp.psi_inv(&xi, &eta, &[], &mut x).unwrap();
            let (mut xi2, mut eta2) = (vec![0.0; r], vec![0.0; n - r]);
            interp.psi(&x, &[], &mut xi2, &mut eta2);
            for (a, b) in xi.iter().chain(&eta).zip(xi2.iter().chain(&eta2)) {
                prop_assert!((a - b).abs() <= 1e-9 * a.abs().max(1.0), "{name}: {a} vs {b} (x = {x:?})");
            }
        }
    }
}
