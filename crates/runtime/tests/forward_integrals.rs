//! The forward run's integrals do not depend on the output grid (issue 15, defect 12): the accumulated outputs
//! and ∫ y dt are quadrature states of the solver, so the fuel at dt = 1 s and dt = 0.001 s agree to 1e-6
//! relative (they differed by 2.7 % with the trapezoid of the grid), and they converge to the integral of a
//! tighter-tolerance run.

use invsim_model_api::InverseModel;
use invsim_runtime::forward::{self, Bounds, ForwardOptions, Method};
use invsim_runtime::Cycle;

fn model(name: &str) -> Box<dyn InverseModel> {
    invsim_models::builtin(name).expect("built-in model")
}

/// The integrals (in the model's order) and the distance driven of one run.
fn integrals(name: &str, cycle: &str, opts: ForwardOptions) -> (Vec<f64>, f64) {
    let cycle = Cycle::builtin(cycle).expect("built-in cycle");
    let r = forward::forward(model(name).as_ref(), &cycle, &opts).expect("forward run");
    let s = &r.summary;
    let v: Vec<f64> = s.totals.integrals.values().copied().collect();
    assert!(!v.is_empty(), "{name} has accumulated outputs");
    (v, s.distance_driven_m)
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs())
}

#[test]
fn forward_integrals_do_not_depend_on_dt() {
    let cases = [
        ("si_engine", "nedc", Bounds::Ignore, Method::Dopri5),
        ("si_engine", "udds", Bounds::Enforce, Method::Dopri5),
        ("si_engine", "ece", Bounds::Ignore, Method::Rosenbrock23),
    ];
    for (name, cycle, bounds, method) in cases {
        let run = |dt: f64| {
            integrals(
                name,
                cycle,
                ForwardOptions {
                    dt,
                    bounds,
                    method,
                    keep_series: false,
                    ..ForwardOptions::default()
                },
            )
        };
        let (coarse, d_coarse) = run(1.0);
        for dt in [0.1, 0.001] {
            let (fine, d_fine) = run(dt);
            for (a, b) in coarse.iter().zip(&fine) {
                assert!(close(*a, *b, 1e-6), "{name} {cycle} dt {dt}: {a} vs {b}");
            }
            assert!(close(d_coarse, d_fine, 1e-6), "{d_coarse} vs {d_fine}");
        }
    }
}

#[test]
fn forward_integrals_converge_with_the_tolerance() {
    let run = |rtol: f64| {
        integrals(
            "si_engine",
            "nedc",
            ForwardOptions {
                dt: 1.0,
                rtol,
                atol: rtol * 1e-2,
                keep_series: false,
                ..ForwardOptions::default()
            },
        )
    };
    let (default, _) = run(1e-8);
    let (tight, d_tight) = run(1e-11);
    for (a, b) in default.iter().zip(&tight) {
        assert!(close(*a, *b, 1e-6), "{a} vs {b}");
    }
    // The vehicle follows the cycle closely: the distance driven is the cycle's 11 013 m.
    assert!((d_tight - 11_013.2).abs() < 1.0, "{d_tight}");
}
