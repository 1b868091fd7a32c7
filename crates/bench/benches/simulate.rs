//! Benchmark: the hand-written SI engine (Fröberg & Nielsen 2004, eq. 22–32) inverted along the NEDC at
//! dt = 0.01 s (118 001 samples), one core; criterion reports the time per cycle and samples per second.
//!
//! `fresh` allocates the result columns anew (as one `invsim simulate --out` run does), `reused` recycles the
//! previous result's columns (repeated runs), `summary_only` keeps no time series (`keep_series: false`, as
//! without `--out`), `smoother_only` evaluates y_d, ẏ_d, ÿ_d at every sample and nothing else.

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use invsim_runtime::simulate::simulate_reusing;
use invsim_runtime::{simulate, Cycle, SimulationOptions, Smoother};

#[path = "../../runtime/tests/common/mod.rs"]
mod common;

fn nedc_si_engine(c: &mut Criterion) {
    let model = common::SiEngine::new();
    let cycle = Cycle::builtin("nedc").expect("built-in NEDC");
    let opts = SimulationOptions {
        dt: 0.01,
        ..SimulationOptions::default()
    };
    let first = simulate(&model, &cycle, &opts).expect("simulation");
    let samples = first.summary.samples as u64;
    assert_eq!(samples, 118_001);

    let mut group = c.benchmark_group("simulate_nedc_dt0.01");
    group.throughput(Throughput::Elements(samples));
    group.measurement_time(Duration::from_secs(5));
    group.bench_function("si_engine_fresh", |b| {
        b.iter(|| simulate(std::hint::black_box(&model), &cycle, &opts).expect("simulation"))
    });
    let mut previous = Some(first);
    group.bench_function("si_engine_reused", |b| {
        b.iter_custom(|iters| {
            let mut prev = previous.take().expect("a previous result");
            let start = Instant::now();
            for _ in 0..iters {
                prev = simulate_reusing(std::hint::black_box(&model), &cycle, &opts, prev)
                    .expect("simulation");
            }
            let elapsed = start.elapsed();
            previous = Some(prev);
            elapsed
        })
    });
    let lean = SimulationOptions {
        keep_series: false,
        ..opts.clone()
    };
    group.bench_function("si_engine_summary_only", |b| {
        b.iter(|| simulate(std::hint::black_box(&model), &cycle, &lean).expect("simulation"))
    });
    let smoother = Smoother::new(&cycle, opts.lookahead).expect("smoother");
    group.bench_function("smoother_only", |b| {
        b.iter(|| {
            let mut y = [0.0; 3];
            let mut acc = 0.0;
            for k in 0..samples {
                smoother.eval(k as f64 / 100.0, &mut y);
                acc += y[2];
            }
            acc
        })
    });
    group.finish();
}

criterion_group!(benches, nedc_si_engine);
criterion_main!(benches);
