//! Benchmark: the imported 2012 Ford Fusion (`models/vehicles/ford_fusion_2012.toml`, FASTSim's parameters)
//! on UDDS at FASTSim's own 1 s grid, in-process: the whole inverse simulation (smoothing, inversion, extra
//! outputs, the fuel integral) through the interpreter, as `invsim simulate` runs an imported model. FASTSim's
//! `SimDrive.walk()` on the same cycle is timed by `tests/fastsim/time_walk.py`; goal ≥ 100× FASTSim per run.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use invsim_inversion::{derive_file, Interpreter};
use invsim_runtime::{simulate, Cycle, SimulationOptions};
use std::hint::black_box;
use std::path::PathBuf;

fn fusion_udds(c: &mut Criterion) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../models/vehicles/ford_fusion_2012.toml");
    let d = derive_file(&path).expect("the imported Fusion derives");
    let interp = Interpreter::new(&d).expect("interpreter");
    let cycle = Cycle::builtin("udds").expect("udds");
    let mut group = c.benchmark_group("imported Fusion UDDS dt=1");
    group.throughput(Throughput::Elements(1370));
    for (what, keep) in [("summary only", false), ("all columns", true)] {
        let opts = SimulationOptions {
            dt: 1.0,
            lookahead: 1.0,
            keep_series: keep,
            ..SimulationOptions::default()
        };
        group.bench_function(what, |b| {
            b.iter(|| black_box(simulate(&interp, &cycle, &opts).unwrap().summary.samples))
        });
    }
    group.finish();
}

criterion_group!(benches, fusion_udds);
criterion_main!(benches);
