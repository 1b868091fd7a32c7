//! Benchmark: `derive` of the paper's si_engine model, from the TOML text to the JSON document (issue target:
//! under 5 ms in release), and the interpreter tape evaluating α and β (target: under 50 ns per point).

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use invsim_inversion::{Derivation, Interpreter, Model};
use invsim_model_api::InverseModel;
use std::path::Path;

fn si_engine_text() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine.toml");
    std::fs::read_to_string(path).expect("models/si_engine.toml")
}

fn derive(c: &mut Criterion) {
    let text = si_engine_text();
    c.bench_function("derive si_engine: parse to JSON", |b| {
        b.iter(|| {
            let model = Model::from_str(Path::new("si_engine.toml"), black_box(&text)).unwrap();
            let d = Derivation::new(model).unwrap();
            black_box(serde_json::to_string(&d.to_json()).unwrap())
        })
    });
}

fn tape(c: &mut Criterion) {
    let model = Model::from_str(Path::new("si_engine.toml"), &si_engine_text()).unwrap();
    let d = Derivation::new(model).unwrap();
    let interp = Interpreter::new(&d).unwrap();
    let points: Vec<[f64; 2]> = (0..1024)
        .map(|i| [0.5 + 0.03 * i as f64, -2.0 + 0.004 * i as f64])
        .collect();
    c.bench_function("interpreter alpha + beta per point (si_engine)", |b| {
        let mut k = 0;
        b.iter(|| {
            let xi = &points[k & 1023];
            k += 1;
            black_box(interp.alpha(black_box(xi), &[], &[]) + interp.beta(black_box(xi), &[], &[]))
        })
    });
    // The tape of (α, β) specialised to the parameters, evaluated over a block of 1024 points.
    let syms: Vec<_> =
        d.xi.iter()
            .copied()
            .chain(d.model.parameters.iter().map(|p| p.symbol))
            .collect();
    let values: Vec<f64> = d.model.parameters.iter().map(|p| p.value).collect();
    let ab = invsim_expr::Tape::compile(d.pool(), &[d.alpha, d.beta], &syms)
        .unwrap()
        .specialize(&values);
    let xi1: Vec<f64> = points.iter().map(|p| p[0]).collect();
    let xi2: Vec<f64> = points.iter().map(|p| p[1]).collect();
    let (mut a, mut bb) = (vec![0.0; 1024], vec![0.0; 1024]);
    let mut group = c.benchmark_group("tape alpha + beta, batches of 1024 points (si_engine)");
    group.throughput(criterion::Throughput::Elements(1024));
    group.bench_function("eval_batch", |b| {
        b.iter(|| {
            ab.eval_batch(&[black_box(&xi1), black_box(&xi2)], &mut [&mut a, &mut bb]);
            black_box(a[17] + bb[5])
        })
    });
    group.finish();
    c.bench_function("interpreter invert (x, u) per point (si_engine)", |b| {
        let mut k = 0;
        let mut x = [0.0; 2];
        b.iter(|| {
            let xi = &points[k & 1023];
            k += 1;
            black_box(interp.invert(black_box(xi), &[], &[], 0.1, &mut x).unwrap())
        })
    });
}

criterion_group!(benches, derive, tape);
criterion_main!(benches);
