//! Benchmark: si_engine_5speed (16 modes, interpreted) against the one-gear si_engine (compiled and
//! interpreted) inverted along the NEDC at dt = 0.01 s (118 001 samples), one core; and si_engine_5speed on
//! the UDDS at dt = 1 s (where the zero dynamics of the brake and idle modes dominate) with their reference
//! from the sub-grid (the default) and from the smoother evaluated pointwise at every stage time.

use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use invsim_runtime::modes::{
    simulate_modes, simulate_modes_with_reference, ModalOptions, Switching, ZeroDynamicsReference,
};
use invsim_runtime::{simulate, Cycle, SimulationOptions};

#[path = "../../runtime/tests/modes_support.rs"]
mod support;

fn nedc_modes(c: &mut Criterion) {
    let cycle = Cycle::builtin("nedc").expect("built-in NEDC");
    let five = support::five_speed();
    let spec = support::spec(&five, support::speed_schedule(&five));
    let opts = ModalOptions {
        dt: 0.01,
        switching: Switching::Reentry,
        ..ModalOptions::default()
    };
    let compiled = invsim_models::builtin("si_engine").expect("si_engine is built in");
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine.toml");
    let d = invsim_inversion::derive_file(&path).expect("si_engine derives");
    let interpreted = invsim_inversion::Interpreter::new(&d).expect("interpreter");
    let single = SimulationOptions {
        dt: 0.01,
        ..SimulationOptions::default()
    };

    let mut group = c.benchmark_group("modes_nedc_dt0.01");
    group.throughput(Throughput::Elements(118_001));
    group.measurement_time(Duration::from_secs(5));
    group.bench_function("si_engine_5speed_interpreted", |b| {
        b.iter(|| simulate_modes(std::hint::black_box(&spec), &cycle, &opts).expect("run"))
    });
    group.bench_function("si_engine_compiled", |b| {
        b.iter(|| simulate(std::hint::black_box(compiled.as_ref()), &cycle, &single).expect("run"))
    });
    group.bench_function("si_engine_interpreted", |b| {
        b.iter(|| simulate(std::hint::black_box(&interpreted), &cycle, &single).expect("run"))
    });
    group.bench_function("si_engine_5speed_interpreted_pointwise_zd", |b| {
        b.iter(|| {
            let zd = ZeroDynamicsReference::Pointwise;
            simulate_modes_with_reference(std::hint::black_box(&spec), &cycle, &opts, &[], zd)
                .expect("run")
        })
    });
    group.finish();
}

fn udds_zero_dynamics(c: &mut Criterion) {
    let cycle = Cycle::builtin("udds").expect("built-in UDDS");
    let five = support::five_speed();
    let spec = support::spec(&five, support::speed_schedule(&five));
    let opts = ModalOptions {
        dt: 1.0,
        switching: Switching::Reentry,
        ..ModalOptions::default()
    };
    let mut group = c.benchmark_group("modes_udds_dt1");
    group.throughput(Throughput::Elements(1_370));
    group.measurement_time(Duration::from_secs(5));
    for (name, zd) in [
        ("sub_grid", ZeroDynamicsReference::SubGrid),
        ("pointwise", ZeroDynamicsReference::Pointwise),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| {
                simulate_modes_with_reference(std::hint::black_box(&spec), &cycle, &opts, &[], zd)
                    .expect("run")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, nedc_modes, udds_zero_dynamics);
criterion_main!(benches);
