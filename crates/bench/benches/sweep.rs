//! Benchmark: parameter sweeps of the compiled `si_engine` on the NEDC at dt = 0.1 s (11 801 samples per run):
//! 1000 variants (a 40 × 25 grid of mass and drag coefficient) on 1 and on 2 threads; criterion reports the time
//! per sweep and variants per second. The target (invsim issue 14) is 10 000 variants in under 3 s on 2 cores,
//! about 0.5 ms of CPU per variant.

use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use invsim_runtime::{Cycle, SimulationOptions, Sweep};

fn sweep_si_engine_nedc(c: &mut Criterion) {
    let cycle = Cycle::builtin("nedc").expect("built-in NEDC");
    let opts = SimulationOptions::builder()
        .dt(0.1)
        .build()
        .expect("valid options");
    let mut group = c.benchmark_group("sweep_si_engine_nedc_dt0.1");
    group.throughput(Throughput::Elements(1000));
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(10));
    for threads in [1, 2] {
        let sweep = Sweep::new(|| invsim_models::builtin("si_engine").expect("built in"))
            .cycle(&cycle)
            .grid("m", 1000.0, 1800.0, 40)
            .grid("C_d", 0.25, 0.40, 25)
            .options(opts.clone())
            .threads(threads)
            .build()
            .expect("the sweep builds");
        group.bench_function(format!("1000_variants_{threads}_threads"), |b| {
            b.iter(|| {
                let result = sweep.run();
                assert_eq!(result.failed(), 0);
                result
            })
        });
    }
    group.finish();
}

criterion_group!(benches, sweep_si_engine_nedc);
criterion_main!(benches);
