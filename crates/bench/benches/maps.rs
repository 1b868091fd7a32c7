//! Benchmark: `si_engine_maps` (a smooth 2-D volumetric-efficiency map inside the dynamics, ψ⁻¹ by Newton's
//! method through it, and a bilinear BSFC map for an output) against `si_engine` (the same car with the
//! analytic air charge and closed-form ψ⁻¹), both compiled, inverted along the NEDC at dt = 0.01 s
//! (118 001 samples) without storing the time series.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use invsim_runtime::{simulate, Cycle, SimulationOptions};

fn nedc_maps(c: &mut Criterion) {
    let cycle = Cycle::builtin("nedc").expect("built-in NEDC");
    let opts = SimulationOptions {
        dt: 0.01,
        keep_series: false,
        ..SimulationOptions::default()
    };
    let mut group = c.benchmark_group("simulate_nedc_dt0.01_maps");
    group.throughput(Throughput::Elements(118_001));
    for name in ["si_engine", "si_engine_maps"] {
        let model = invsim_models::builtin(name).expect("built-in model");
        group.bench_function(name, |b| {
            b.iter(|| {
                simulate(std::hint::black_box(model.as_ref()), &cycle, &opts).expect("simulation")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, nedc_maps);
criterion_main!(benches);
