//! Benchmark: stable (non-causal) inversion of `models/diesel_gasflow.toml` — non-minimum-phase zero dynamics,
//! integrated as the bounded solution of a boundary-value problem (`invsim_runtime::stable`) — along the NEDC at
//! dt = 0.01 s (118 001 samples), one core. The target is below 50 ms per cycle for the compiled model.
//!
//! `compiled` is the whole `simulate` call (classification, collocation solve, the inverse at every sample, the
//! extra outputs, the summary) on the generated code; `compiled_summary_only` keeps no time series;
//! `interpreted` runs the interpreter tape instead.

use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use invsim_runtime::{simulate, Cycle, SimulationOptions};

fn nedc_diesel(c: &mut Criterion) {
    let compiled = invsim_models::builtin("diesel_gasflow").expect("diesel_gasflow is built in");
    let root =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/diesel_gasflow.toml");
    let derivation = invsim_inversion::derive_file(&root).expect("diesel_gasflow derives");
    let interpreted = invsim_inversion::Interpreter::new(&derivation).expect("interpreter");
    let cycle = Cycle::builtin("nedc").expect("built-in NEDC");
    let opts = SimulationOptions {
        dt: 0.01,
        ..SimulationOptions::default()
    };
    let first = simulate(compiled.as_ref(), &cycle, &opts).expect("simulation");
    assert_eq!(first.summary.inversion, "stable");
    let samples = first.summary.samples as u64;
    assert_eq!(samples, 118_001);

    let mut group = c.benchmark_group("stable_nedc_dt0.01");
    group.throughput(Throughput::Elements(samples));
    group.measurement_time(Duration::from_secs(8));
    group.bench_function("diesel_gasflow_compiled", |b| {
        b.iter(|| {
            simulate(std::hint::black_box(compiled.as_ref()), &cycle, &opts).expect("simulation")
        })
    });
    let lean = SimulationOptions {
        keep_series: false,
        ..opts.clone()
    };
    group.bench_function("diesel_gasflow_compiled_summary_only", |b| {
        b.iter(|| {
            simulate(std::hint::black_box(compiled.as_ref()), &cycle, &lean).expect("simulation")
        })
    });
    group.sample_size(10);
    group.bench_function("diesel_gasflow_interpreted", |b| {
        b.iter(|| simulate(std::hint::black_box(&interpreted), &cycle, &opts).expect("simulation"))
    });
    group.finish();
}

criterion_group!(benches, nedc_diesel);
criterion_main!(benches);
