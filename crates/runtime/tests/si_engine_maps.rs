//! `si_engine_maps` (a volumetric-efficiency map inside the dynamics, a BSFC map for an output) on the NEDC:
//! the inverse satisfies the model's equations at every sample (1e-8 relative), the replay tracks, a constant
//! eta_vol map gives si_engine's results (with s_i = that constant, y_i = 0) within 1e-9, and the compiled and
//! the interpreted model agree (1e-12 relative on every closed-form function at the run's points).

use invsim_inversion::{Derivation, Interpreter, Model};
use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, SimulationOptions, SimulationResult};
use std::path::PathBuf;

fn compiled(name: &str) -> Box<dyn InverseModel> {
    invsim_models::builtin(name).expect("built-in model")
}

fn run(model: &dyn InverseModel, verify: bool) -> SimulationResult {
    let cycle = Cycle::builtin("nedc").expect("built-in cycle");
    let opts = SimulationOptions::builder()
        .verify(verify)
        .keep_series(true)
        .build()
        .expect("options");
    simulate(model, &cycle, &opts).expect("the run succeeds")
}

fn col<'a>(r: &'a SimulationResult, name: &str) -> &'a [f64] {
    r.column(name).unwrap_or_else(|| panic!("column {name}"))
}

#[test]
fn the_inverse_satisfies_the_model_equations_at_every_sample() {
    let m = compiled("si_engine_maps");
    let r = run(m.as_ref(), true);
    let (v, p, u) = (col(&r, "v"), col(&r, "p_i"), col(&r, "m_at"));
    let (y0, y1, y2) = (col(&r, "yd_0"), col(&r, "yd_1"), col(&r, "yd_2"));
    let mut dx = [0.0; 2];
    for k in 0..v.len() {
        let x = [v[k], p[k]];
        // y = h(x), y' = L_f h = dv/dt of the original equations, y'' = α + β u.
        assert!(
            (m.h(&x, &[]) - y0[k]).abs() <= 1e-8 * y0[k].abs().max(1.0),
            "h at sample {k}"
        );
        m.rhs(&x, &[], u[k], &mut dx);
        assert!(
            (dx[0] - y1[k]).abs() <= 1e-8 * y1[k].abs().max(1.0),
            "dv/dt at {k}: {} vs {}",
            dx[0],
            y1[k]
        );
        let xi = [y0[k], y1[k]];
        let (a, b) = (m.alpha(&xi, &[], &[]), m.beta(&xi, &[], &[]));
        let scale = a.abs() + (b * u[k]).abs() + y2[k].abs();
        // Relative to the terms, at least 1 m/s² (at standstill α and βu cancel to rounding of O(1) terms).
        assert!(
            (a + b * u[k] - y2[k]).abs() <= 1e-8 * scale.max(1.0),
            "y'' at {k}: {a} + {b}·{}",
            u[k]
        );
    }
    let err = r
        .summary
        .max_abs_tracking_error
        .expect("--verify gives the tracking error");
    assert!(err < 1e-3, "replay tracking error {err} m/s");
}

#[test]
fn a_constant_eta_vol_map_is_si_engine_with_the_constant_charge_slope() {
    let c = 0.85;
    let mut maps = compiled("si_engine_maps");
    let x: Vec<f64> = vec![0.0, 400.0, 800.0];
    let y: Vec<f64> = vec![0.0, 1.0e5];
    maps.set_map("eta_vol", (&x, Some(&y), &[c; 6]))
        .expect("eta_vol is a 2-D map");
    let mut si = compiled("si_engine");
    si.set_param("s_i", c).unwrap();
    si.set_param("y_i", 0.0).unwrap();
    let (a, b) = (run(maps.as_ref(), false), run(si.as_ref(), false));
    for name in ["m_at", "v", "p_i", "fuel", "T_e"] {
        let (ca, cb) = (col(&a, name), col(&b, name));
        let scale = cb.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for (k, (p, q)) in ca.iter().zip(cb).enumerate() {
            assert!(
                (p - q).abs() <= 1e-9 * scale,
                "{name} at sample {k}: {p} vs {q}"
            );
        }
    }
    let (fa, fb) = (
        a.summary.totals.integrals["fuel"],
        b.summary.totals.integrals["fuel"],
    );
    assert!((fa - fb).abs() <= 1e-9 * fb, "{fa} vs {fb}");
}

fn interpreted() -> Interpreter {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine_maps.toml");
    let d = Derivation::new(Model::from_path(&path).expect("model")).expect("derivation");
    Interpreter::new(&d).expect("interpreter")
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(1e-300)
}

#[test]
fn compiled_and_interpreted_agree() {
    let (c, i) = (compiled("si_engine_maps"), interpreted());
    let r = run(c.as_ref(), false);
    let (v, p, u) = (col(&r, "v"), col(&r, "p_i"), col(&r, "m_at"));
    let n_out = c.info().outputs.len();
    let (mut oc, mut oi) = (vec![0.0; n_out], vec![0.0; n_out]);
    // Each quantity relative to its largest magnitude over the run (values that cancel to ~0 at standstill
    // carry the rounding of their O(1) terms).
    let mut scale = vec![0.0_f64; 4 + n_out];
    let mut rows: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    for k in (0..v.len()).step_by(7) {
        let x = [v[k], p[k]];
        let (mut dc, mut di) = ([0.0; 2], [0.0; 2]);
        c.rhs(&x, &[], u[k], &mut dc);
        i.rhs(&x, &[], u[k], &mut di);
        c.outputs(&x, &[], u[k], &mut oc);
        i.outputs(&x, &[], u[k], &mut oi);
        let (mut xc, mut xi_) = ([0.0; 2], [0.0; 2]);
        c.psi(&x, &[], &mut xc, &mut []);
        i.psi(&x, &[], &mut xi_, &mut []);
        let a: Vec<f64> = dc.iter().chain(&xc).chain(&oc).copied().collect();
        let b: Vec<f64> = di.iter().chain(&xi_).chain(&oi).copied().collect();
        for (s, x) in scale.iter_mut().zip(&a) {
            *s = s.max(x.abs());
        }
        rows.push((a, b));
        // Through Newton's method (tolerance 1e-13 on ψ): α and β agree to the solver's accuracy.
        let xi = [xc[0], xc[1]];
        let (ac, ai) = (c.alpha(&xi, &[], &[]), i.alpha(&xi, &[], &[]));
        let (bc, bi) = (c.beta(&xi, &[], &[]), i.beta(&xi, &[], &[]));
        assert!(close(bc, bi, 1e-10), "β at {k}: {bc} vs {bi}");
        assert!(
            (ac - ai).abs() <= 1e-10 * (ac.abs().max(1.0)),
            "α at {k}: {ac} vs {ai}"
        );
    }
    for (k, (a, b)) in rows.iter().enumerate() {
        for (j, ((x, y), s)) in a.iter().zip(b).zip(&scale).enumerate() {
            assert!(
                (x - y).abs() <= 1e-12 * s,
                "point {k}, quantity {j}: {x} vs {y} (scale {s})"
            );
        }
    }
}

#[test]
fn the_map_option_replaces_data_in_both_engines_alike() {
    let (mut c, mut i) = (compiled("si_engine_maps"), interpreted());
    let x = [0.0, 300.0, 900.0];
    let y = [0.0, 5.0e4, 1.2e5];
    let values = [0.6, 0.7, 0.8, 0.65, 0.8, 0.9, 0.6, 0.75, 0.85];
    for m in [c.as_mut() as &mut dyn InverseModel, &mut i] {
        m.set_map("eta_vol", (&x, Some(&y), &values)).unwrap();
        assert!(
            m.set_map("eta_vol", (&x, None, &values[..3])).is_err(),
            "arity is kept"
        );
        assert!(m.set_map("nope", (&x, None, &values[..3])).is_err());
    }
    let mut dc = [0.0; 2];
    let mut di = [0.0; 2];
    c.rhs(&[12.0, 4.0e4], &[], 0.01, &mut dc);
    i.rhs(&[12.0, 4.0e4], &[], 0.01, &mut di);
    assert!(close(dc[1], di[1], 1e-12), "{} vs {}", dc[1], di[1]);
}
