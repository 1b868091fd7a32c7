//! Benchmark: the cost of exact gradients (`--gradient`) against the same run without them, compiled:
//! si_engine (r = n: pointwise chain rule) on NEDC at dt = 0.01 s with 10 parameters, and driveline (stiff
//! zero dynamics: η by the run's Dormand–Prince steps, the sensitivities by Gauss–Legendre over each step) on
//! NEDC at dt = 0.1 s with every parameter. Issue target: 10 parameters within 3× of the plain run.

use criterion::{criterion_group, criterion_main, Criterion};
use invsim_runtime::{simulate, Cycle, SimulationOptions};
use std::hint::black_box;
use std::time::Duration;

/// si_engine's 10 parameters of the vehicle, the driveline and the engine.
const SI_ENGINE_TEN: [&str; 10] = [
    "m", "C_d", "A_f", "c_r", "eta_trm", "J_e", "V_d", "eta_th", "i_t", "r_w",
];

fn options(dt: f64, gradient: Option<Vec<String>>) -> SimulationOptions {
    SimulationOptions::builder()
        .dt(dt)
        .keep_series(false)
        .gradient(gradient)
        .build()
        .expect("valid options")
}

fn gradient(c: &mut Criterion) {
    let cycle = Cycle::builtin("nedc").expect("nedc");
    let ten: Vec<String> = SI_ENGINE_TEN.iter().map(|s| s.to_string()).collect();
    let cases = [
        ("si_engine dt=0.01", 0.01, Some(ten)),
        ("driveline dt=0.1", 0.1, Some(vec!["all".to_string()])),
    ];
    let mut group = c.benchmark_group("gradient NEDC, compiled");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(10));
    for (name, dt, names) in cases {
        let model_name = name.split(' ').next().expect("a model name");
        let model = invsim_models::builtin(model_name).expect("built in");
        for (label, wanted) in [("plain", None), ("with gradient", names)] {
            let opts = options(dt, wanted);
            group.bench_function(format!("{name} {label}"), |b| {
                b.iter(|| {
                    black_box(
                        simulate(model.as_ref(), &cycle, &opts)
                            .unwrap()
                            .summary
                            .samples,
                    )
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, gradient);
criterion_main!(benches);
