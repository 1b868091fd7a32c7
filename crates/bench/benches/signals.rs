//! Benchmark: si_engine_grade (road grade and auxiliary load as signals, smoothed with their exact
//! derivatives) against si_engine without signals, both compiled, on NEDC at dt = 0.01 s (118 001 samples)
//! with a grade column. Target: within 1.5× of si_engine.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, SimulationOptions};
use std::hint::black_box;

fn signals(c: &mut Criterion) {
    let plain = invsim_models::builtin("si_engine").expect("si_engine is built in");
    let graded = invsim_models::builtin("si_engine_grade").expect("si_engine_grade is built in");
    let mut cycle = Cycle::builtin("nedc").expect("nedc");
    cycle.grade = Some(
        cycle
            .time
            .iter()
            .map(|&t| 0.03 * (t / 97.0).sin())
            .collect(),
    );
    let opts = SimulationOptions {
        dt: 0.01,
        keep_series: false,
        ..SimulationOptions::default()
    };
    let mut group = c.benchmark_group("simulate NEDC dt=0.01, compiled");
    group.throughput(Throughput::Elements(118_001));
    group.sample_size(30);
    for (name, model) in [
        ("si_engine", plain.as_ref() as &dyn InverseModel),
        ("si_engine_grade with a grade signal", graded.as_ref()),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| black_box(simulate(model, &cycle, &opts).unwrap().summary.samples))
        });
    }
    group.finish();
}

criterion_group!(benches, signals);
criterion_main!(benches);
