//! Benchmark: inverse vs forward simulation of the paper's SI-engine car (Fröberg & Nielsen 2004) on the NEDC at
//! equal output grids, one core, the same compiled model (`invsim-models`, generated from
//! `models/si_engine.toml`) behind both.
//!
//! * inverse: `simulate` with the default look-ahead a = 5 s;
//! * forward: `forward::forward` with the default PI driver, bounds ignored, Dormand–Prince 5(4) at
//!   rtol = 1e-8 (the default; also 1e-6 and 1e-10 at dt = 0.01 s).
//!
//! Both keep their time series (as `--out` does). Before the criterion runs, a table of medians over 15 runs
//! each, with the ratio forward/inverse, is printed (the paper reports about 10×).

use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use invsim_model_api::InverseModel;
use invsim_runtime::forward::{forward, ForwardOptions};
use invsim_runtime::{simulate, Cycle, SimulationOptions};

const GRIDS: [f64; 3] = [0.01, 0.1, 1.0];

fn inverse_opts(dt: f64) -> SimulationOptions {
    SimulationOptions {
        dt,
        ..SimulationOptions::default()
    }
}

fn forward_opts(dt: f64, rtol: f64) -> ForwardOptions {
    ForwardOptions {
        dt,
        rtol,
        atol: rtol * 1e-2,
        ..ForwardOptions::default()
    }
}

fn median(mut f: impl FnMut(), runs: usize) -> Duration {
    let mut times: Vec<Duration> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed()
        })
        .collect();
    times.sort();
    times[runs / 2]
}

/// The table of medians and ratios.
fn table(model: &dyn InverseModel, cycle: &Cycle) {
    println!("\nNEDC, si_engine (compiled), medians of 15 runs");
    println!("| dt [s] | samples | inverse | forward (rtol) | steps | ratio forward/inverse |");
    println!("|---|---|---|---|---|---|");
    let mut rows: Vec<(f64, f64)> = GRIDS.iter().map(|&dt| (dt, 1e-8)).collect();
    rows.extend([(0.01, 1e-6), (0.01, 1e-10)]);
    for (dt, rtol) in rows {
        let inv = median(
            || drop(simulate(model, cycle, &inverse_opts(dt)).expect("inverse")),
            15,
        );
        let fopts = forward_opts(dt, rtol);
        let run = forward(model, cycle, &fopts).expect("forward");
        let fwd = median(|| drop(forward(model, cycle, &fopts).expect("forward")), 15);
        println!(
            "| {dt} | {} | {:.3} ms | {:.3} ms ({rtol:e}) | {} | {:.1} |",
            run.summary.samples,
            inv.as_secs_f64() * 1e3,
            fwd.as_secs_f64() * 1e3,
            run.summary.integrator.stats.accepted,
            fwd.as_secs_f64() / inv.as_secs_f64()
        );
    }
    println!();
}

fn inverse_vs_forward(c: &mut Criterion) {
    let model = invsim_models::builtin("si_engine").expect("si_engine is built in");
    let model = model.as_ref();
    let cycle = Cycle::builtin("nedc").expect("built-in NEDC");
    table(model, &cycle);

    let mut group = c.benchmark_group("nedc_si_engine");
    group.sample_size(20);
    group.measurement_time(Duration::from_secs(4));
    for dt in GRIDS {
        let samples = (1180.0 / dt).round() as u64 + 1;
        group.throughput(Throughput::Elements(samples));
        group.bench_with_input(BenchmarkId::new("inverse", dt), &dt, |b, &dt| {
            b.iter(|| {
                simulate(std::hint::black_box(model), &cycle, &inverse_opts(dt)).expect("inverse")
            })
        });
        group.bench_with_input(BenchmarkId::new("forward_rtol1e-8", dt), &dt, |b, &dt| {
            b.iter(|| {
                forward(std::hint::black_box(model), &cycle, &forward_opts(dt, 1e-8))
                    .expect("forward")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, inverse_vs_forward);
criterion_main!(benches);
