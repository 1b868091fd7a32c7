//! Benchmark: the whole inverse simulation of the paper's si_engine over NEDC at dt = 0.01 s (118 001
//! samples, smoothing included) with the compiled engine (`invsim-models`) and the interpreter tape
//! (`invsim-inversion`). Targets: compiled ≥ 20 M samples/s (< 6 ms), interpreted within 5× of compiled.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use invsim_inversion::{derive_file, Interpreter};
use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, SimulationOptions};
use std::hint::black_box;
use std::path::PathBuf;

fn engines(c: &mut Criterion) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine.toml");
    let d = derive_file(&path).expect("models/si_engine.toml derives");
    let interp = Interpreter::new(&d).expect("interpreter");
    let compiled = invsim_models::by_hash(&d.model.source_hash).expect("si_engine is built in");
    let cycle = Cycle::builtin("nedc").expect("nedc");
    let mut group = c.benchmark_group("simulate si_engine NEDC dt=0.01");
    group.throughput(Throughput::Elements(118_001));
    group.sample_size(30);
    for (engine, model, keep) in [
        (
            "compiled, summary only",
            compiled.as_ref() as &dyn InverseModel,
            false,
        ),
        ("compiled, all columns", compiled.as_ref(), true),
        (
            "interpreted, summary only",
            &interp as &dyn InverseModel,
            false,
        ),
        ("interpreted, all columns", &interp, true),
    ] {
        let opts = SimulationOptions {
            dt: 0.01,
            keep_series: keep,
            ..SimulationOptions::default()
        };
        group.bench_function(engine, |b| {
            b.iter(|| black_box(simulate(model, &cycle, &opts).unwrap().summary.samples))
        });
    }
    group.finish();
}

criterion_group!(benches, engines);
criterion_main!(benches);
