//! A causal run's zero dynamics with the reference from the sub-grid (the default) against the smoother
//! evaluated pointwise at every stage time: driveline (three internal states, stiff) on the NEDC and the UDDS at
//! dt = 0.1 s, bev (the charge state; grade and auxiliary-load signals) on the NEDC, UDDS and WLTC class 3b at
//! dt = 0.1 s: every state within 1e-9 of its largest magnitude and every integral within 1e-9
//! relative.

use crate::common::integrals_deviation;
use invsim_runtime::{simulate, Cycle, SimulationOptions, SimulationResult, ZeroDynamicsReference};

/// The largest deviation of `a` from `b`: each state's and η's column norm-wise, max_k |a_k − b_k| / max_k |b_k|
/// (a state through 0 has no relative error of its own there: driveline's shaft twist at a standstill, 3e-10
/// rad, differs by 1e-12 rad, the integrator's absolute tolerance, between the two references), and the
/// integrals (relative).
fn deviation(a: &SimulationResult, b: &SimulationResult, columns: &[String]) -> (f64, f64) {
    let mut states = 0.0f64;
    for name in columns {
        let (x, y) = (a.column(name).expect(name), b.column(name).expect(name));
        let top = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = x
            .iter()
            .zip(y)
            .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
        if top > 0.0 {
            states = states.max(worst / top);
        }
    }
    let integrals = integrals_deviation(&a.summary.totals.integrals, &b.summary.totals.integrals);
    (states, integrals)
}

#[test]
fn sub_grid_zero_dynamics_equal_the_pointwise_ones() {
    let cases: [(&str, &[&str], &[f64]); 2] = [
        ("driveline", &["nedc", "udds"], &[0.1]),
        ("bev", &["nedc", "udds", "wltc3b"], &[0.1]),
    ];
    for (name, cycles, dts) in cases {
        let model = invsim_models::builtin(name).expect("built in");
        let info = model.info();
        assert!(info.n_eta > 0, "{name} has internal dynamics");
        let mut columns = info.states.clone();
        columns.extend((1..=info.n_eta).map(|j| format!("eta{j}")));
        for cycle in cycles.iter().map(|c| Cycle::builtin(c).expect("built in")) {
            for &dt in dts {
                let run = |zd| {
                    let opts = SimulationOptions::builder()
                        .dt(dt)
                        .zero_dynamics_reference(zd)
                        .build()
                        .expect("valid options");
                    simulate(model.as_ref(), &cycle, &opts).expect("runs")
                };
                let fine = run(ZeroDynamicsReference::SubGrid);
                let pointwise = run(ZeroDynamicsReference::Pointwise);
                let (states, integrals) = deviation(&fine, &pointwise, &columns);
                let at = format!("{name} {} dt {dt}", cycle.name);
                eprintln!("{at}: states {states:e}, integrals {integrals:e}");
                assert!(states < 1e-9, "{at}: states {states:e}");
                assert!(integrals < 1e-9, "{at}: integrals {integrals:e}");
            }
        }
    }
}
