//! Benchmark: a 2-D smooth map lookup with its first and second partial derivatives (value, ∂a, ∂b, ∂aa, ∂ab,
//! ∂bb in one pass: `Map::eval` with orders [2, 2]) over a batch of points spread over the grid, the same through
//! `Map::partials2` (the generated code's call, with its memo), batched (`Map::partials2_batch`, structure of
//! arrays), the value alone batched (`Map::values_batch`), every partial without the memo
//! (`Map::partials2_fresh`, Newton's call) and the value alone; criterion reports the time per point. The
//! grid is si_engine_maps' eta_vol (8 × 5, smooth 0.5). Then the same for 1-D maps: a smooth curve (M, M', M''
//! point by point and batched) and the imported Fusion's efficiency curve (12 points, `interp = "linear"`,
//! clamp) as the interpreter's batch tape calls it (`Map::partial_unmemoized`, the value alone) and batched.
//!
//! Criterion times the wall clock: on a machine shared with other work the figures include the time the
//! benchmark waited for a processor.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use invsim_kernel::map::{Extrapolate, Interp, Map, MapSettings};

fn eta_vol() -> Map {
    let x = vec![50.0, 100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0];
    let y = vec![2.0e4, 4.0e4, 6.0e4, 8.0e4, 1.0e5];
    let v: Vec<f64> = x
        .iter()
        .flat_map(|&w| {
            y.iter()
                .map(move |&p| (0.96 - 8000.0 / p) * (0.9 + 1e-4 * w))
        })
        .collect();
    let s = MapSettings {
        smooth: 0.5,
        extrapolate: Extrapolate::Clamp,
        interp: Interp::Smooth,
    };
    Map::new_2d(x, y, v, s).expect("valid map")
}

fn lookup(c: &mut Criterion) {
    let map = eta_vol();
    let n = 4096;
    let points: Vec<[f64; 2]> = (0..n)
        .map(|k| {
            let t = k as f64 / n as f64;
            [30.0 + 700.0 * t, 1.5e4 + 9.0e4 * ((7.0 * t).fract())]
        })
        .collect();
    let mut group = c.benchmark_group("map2d");
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function("value_first_second_partials", |b| {
        let mut out = [0.0; 9];
        b.iter(|| {
            let mut acc = 0.0;
            for p in &points {
                map.eval(std::hint::black_box(p), [2, 2], &mut out);
                acc += out[0] + out[1] + out[2] + out[3] + out[4] + out[6];
            }
            acc
        })
    });
    // What generated code calls: every partial up to order 2 per argument through the per-thread memo
    // (each point new, so every call evaluates).
    group.bench_function("partials2_generated_code_call", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for p in &points {
                let out = map.partials2(std::hint::black_box(p));
                acc += out[0] + out[1] + out[2] + out[3] + out[4] + out[6];
            }
            acc
        })
    });
    let (a, bb): (Vec<f64>, Vec<f64>) = points.iter().map(|p| (p[0], p[1])).unzip();
    group.bench_function("partials2_batch", |b| {
        let mut out = vec![0.0; 9 * n];
        b.iter(|| {
            map.partials2_batch(
                std::hint::black_box(&a),
                std::hint::black_box(&bb),
                &mut out,
            );
            out[0] + out[n] + out[2 * n] + out[3 * n] + out[4 * n] + out[6 * n]
        })
    });
    group.bench_function("values_batch", |b| {
        let mut out = vec![0.0; n];
        b.iter(|| {
            map.values_batch(
                std::hint::black_box(&a),
                std::hint::black_box(&bb),
                &mut out,
            );
            out[0] + out[n / 2]
        })
    });
    // What Newton's iterations in generated code call: every partial up to order 2, no memo.
    group.bench_function("partials2_fresh", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for p in &points {
                let out = map.partials2_fresh(std::hint::black_box(p));
                acc += out[0] + out[1] + out[2] + out[3] + out[4] + out[6];
            }
            acc
        })
    });
    group.bench_function("value", |b| {
        let mut out = [0.0; 1];
        b.iter(|| {
            let mut acc = 0.0;
            for p in &points {
                map.eval(std::hint::black_box(p), [0, 0], &mut out);
                acc += out[0];
            }
            acc
        })
    });
    group.finish();
}

/// The Fusion's `fc_map` (models/vehicles/ford_fusion_2012.toml) and a smooth 1-D curve on the same grid.
fn curves() -> [(&'static str, Map); 2] {
    let x = vec![
        0.0, 0.005, 0.015, 0.04, 0.06, 0.1, 0.14, 0.2, 0.4, 0.6, 0.8, 1.0,
    ];
    let v = vec![
        0.1, 0.12, 0.16, 0.22, 0.28, 0.33, 0.35, 0.36, 0.35, 0.34, 0.32, 0.3,
    ];
    let linear = MapSettings {
        smooth: 0.5,
        extrapolate: Extrapolate::Clamp,
        interp: Interp::Linear,
    };
    let smooth = MapSettings {
        interp: Interp::Smooth,
        ..linear
    };
    [
        (
            "fusion_linear",
            Map::new_1d(x.clone(), v.clone(), linear).expect("valid map"),
        ),
        ("smooth", Map::new_1d(x, v, smooth).expect("valid map")),
    ]
}

/// The value at every point as the interpreter's batch tape asks for it, one call per point (a function of its
/// own, so that a profile counts its calls: `Map::partial_unmemoized` inlines into this loop).
#[inline(never)]
fn values_unmemoized(map: &Map, a: &[f64]) -> f64 {
    a.iter()
        .map(|&x| map.partial_unmemoized(&[x, 0.0], [0, 0]))
        .sum()
}

fn lookup_1d(c: &mut Criterion) {
    let n = 4096;
    let a: Vec<f64> = (0..n)
        .map(|k| -0.05 + 1.1 * ((k as f64 * 0.618_034).fract()))
        .collect();
    let mut group = c.benchmark_group("map1d");
    group.throughput(Throughput::Elements(n as u64));
    for (name, map) in curves() {
        group.bench_function(format!("{name}/partial_unmemoized_value"), |b| {
            b.iter(|| values_unmemoized(&map, std::hint::black_box(&a)))
        });
        group.bench_function(format!("{name}/partials2"), |b| {
            b.iter(|| {
                let mut acc = 0.0;
                for &x in &a {
                    let out = map.partials2(&[std::hint::black_box(x)]);
                    acc += out[0] + out[1] + out[2];
                }
                acc
            })
        });
        group.bench_function(format!("{name}/partials2_batch"), |b| {
            let mut out = vec![0.0; 3 * n];
            b.iter(|| {
                map.partials2_batch(std::hint::black_box(&a), &[], &mut out);
                out[0] + out[n] + out[2 * n]
            })
        });
    }
    group.finish();
}

criterion_group!(benches, lookup, lookup_1d);
criterion_main!(benches);
