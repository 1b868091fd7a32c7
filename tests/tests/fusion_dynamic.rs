//! `models/ford_fusion_2012_dynamic.toml` (FASTSim's Fusion with si_engine's intake-manifold dynamics) on NEDC
//! and UDDS: the inverse satisfies the original equations at every sample (dx/dt from the chain rule through
//! ψ⁻¹ and the smoother's exact derivatives against f(x) + g(x)·u), the forward replay of the computed input
//! tracks the reference (`verify`), and its parameters are the imported Fusion's wherever both have one.

use invsim_expr::{Id, Symbol, Tape};
use invsim_inversion::{derive_file, Derivation, Interpreter, Solution};
use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, SimulationOptions};
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// ∂ψ⁻¹/∂ξ compiled over (ξ, w, params) (r = n: no η; w the signal values, the grade and its derivatives).
fn psi_inv_jacobian(d: &Derivation) -> Tape {
    let mut pool = d.pool().clone();
    let coords: Vec<Symbol> = d.xi.clone();
    let mut exprs: Vec<Id> = Vec::new();
    for sol in &d.psi_inv {
        let Solution::Closed(e) = sol else {
            panic!("psi_inv is closed-form");
        };
        for &c in &coords {
            exprs.push(pool.diff(*e, c));
        }
    }
    let inputs: Vec<Symbol> = coords
        .iter()
        .copied()
        .chain(d.w.iter().copied())
        .chain(d.model.parameters.iter().map(|p| p.symbol))
        .collect();
    let values: Vec<f64> = d.model.parameters.iter().map(|p| p.value).collect();
    Tape::compile(&pool, &exprs, &inputs)
        .unwrap()
        .specialize(&values)
}

/// The worst residual of dx/dt = f + g·u over the run, relative to |f| + |g·u| (floored at 1e-6 of its peak).
fn worst_residual(d: &Derivation, interp: &Interpreter, cycle: &str) -> f64 {
    let opts = SimulationOptions {
        dt: 0.05,
        ..SimulationOptions::default()
    };
    let res = simulate(interp, &Cycle::builtin(cycle).unwrap(), &opts).unwrap();
    let jac = psi_inv_jacobian(d);
    let (r, n) = (d.relative_degree, d.n());
    assert_eq!((r, n), (2, 2));
    let yd: Vec<&[f64]> = (0..=r).map(|k| res.yd(k).unwrap()).collect();
    let u = res.input();
    let xs: Vec<&[f64]> = d
        .model
        .states
        .iter()
        .map(|s| res.column(&s.name).unwrap())
        .collect();
    // w = (grade, grade_d1, grade_d2): the built-in cycles are flat, so the chain rule's terms in dw/dt vanish.
    let names = ["grade", "grade_d1", "grade_d2"];
    let ws: Vec<&[f64]> = names.iter().map(|c| res.column(c).unwrap()).collect();
    assert!(
        ws.iter().all(|c| c.iter().all(|&g| g == 0.0)),
        "{cycle} is flat"
    );
    let (mut j, mut dx, mut f) = (vec![0.0; n * r], vec![0.0; n], vec![0.0; n]);
    let mut rows = Vec::new();
    let mut peak = vec![0.0f64; n];
    for k in 0..res.len() {
        let w: Vec<f64> = ws.iter().map(|c| c[k]).collect();
        let args: Vec<f64> = (0..r).map(|i| yd[i][k]).chain(w.iter().copied()).collect();
        let x: Vec<f64> = xs.iter().map(|c| c[k]).collect();
        jac.eval(&args, &mut j);
        interp.rhs(&x, &w, u[k], &mut dx);
        interp.rhs(&x, &w, 0.0, &mut f);
        let row: Vec<(f64, f64)> = (0..n)
            .map(|s| {
                let chain: f64 = (0..r).map(|i| j[s * r + i] * yd[i + 1][k]).sum();
                let magnitude = f[s].abs() + (dx[s] - f[s]).abs();
                peak[s] = peak[s].max(magnitude);
                ((chain - dx[s]).abs(), magnitude)
            })
            .collect();
        rows.push(row);
    }
    rows.iter()
        .flat_map(|row| row.iter().enumerate())
        .map(|(s, &(err, magnitude))| err / magnitude.max(1e-6 * peak[s]))
        .fold(0.0, f64::max)
}

#[test]
fn dynamic_fusion_inverse_satisfies_the_original_equations_on_nedc_and_udds() {
    let d = derive_file(&root().join("models/ford_fusion_2012_dynamic.toml")).unwrap();
    let interp = Interpreter::new(&d).unwrap();
    for cycle in ["nedc", "udds"] {
        let worst = worst_residual(&d, &interp, cycle);
        assert!(worst < 1e-8, "{cycle}: worst relative residual {worst}");
    }
}

#[test]
fn dynamic_fusion_replay_tracks_the_reference_on_nedc_and_udds() {
    let d = derive_file(&root().join("models/ford_fusion_2012_dynamic.toml")).unwrap();
    let interp = Interpreter::new(&d).unwrap();
    for cycle in ["nedc", "udds"] {
        let opts = SimulationOptions {
            dt: 0.1,
            verify: true,
            ..SimulationOptions::default()
        };
        let res = simulate(&interp, &Cycle::builtin(cycle).unwrap(), &opts).unwrap();
        let err = res.summary.max_abs_tracking_error.unwrap();
        // O(dt²) replay error: si_engine's is below 1e-2 m/s at dt = 0.1 s.
        assert!(err < 2e-3, "{cycle}: replay tracking error {err} m/s");
        let fuel = res.summary.totals.integrals["fuel"];
        assert!(fuel > 0.0 && fuel.is_finite(), "{cycle}: fuel {fuel}");
    }
}

#[test]
fn dynamic_fusion_keeps_the_imported_parameters() {
    let read = |p: &str| derive_file(&root().join(p)).unwrap().model.parameters;
    let dynamic = read("models/ford_fusion_2012_dynamic.toml");
    let imported = read("models/vehicles/ford_fusion_2012.toml");
    let mut shared = 0;
    for p in &imported {
        if let Some(q) = dynamic.iter().find(|q| q.name == p.name) {
            assert_eq!(p.value, q.value, "{}", p.name);
            shared += 1;
        }
    }
    // chassis 7 + aux, transmission, fuel + rho_a, g_0 + P_fc_max, P_idle
    assert!(shared >= 7 + 3 + 2 + 2, "only {shared} shared parameters");
    // The engine efficiency table: the dynamic model's map fc_map is the imported model's, line for line.
    let text = |p: &str| std::fs::read_to_string(root().join(p)).unwrap();
    let map = |t: &str| {
        let start = t.find("[maps.fc_map]").expect("an fc_map");
        t[start..].split("\n\n").next().unwrap().to_string()
    };
    assert_eq!(
        map(&text("models/ford_fusion_2012_dynamic.toml")),
        map(&text("models/vehicles/ford_fusion_2012.toml")),
        "the engine efficiency map is the imported one"
    );
}
