//! Benchmark of the drive-cycle smoother (eq. 33–35): the whole NEDC at dt = 0.01 s (118 001 samples),
//! look-ahead a = 5 s, for derivative orders 0..=2 and 0..=4, point by point (`eval`) and on the grid
//! (`eval_grid`, whole and in the simulation's blocks of 4096 samples, on the 0.01 s grid where every corner
//! has phase 0 and on a grid shifted by 0.003 s), plus building the smoother.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use invsim_runtime::{Cycle, Smoother};

const SAMPLES: usize = 118_001;
const DT: f64 = 0.01;
const LOOKAHEAD: f64 = 5.0;
const BLOCK: usize = 4096;

fn smooth_nedc(c: &mut Criterion) {
    let nedc = Cycle::builtin("nedc").expect("built-in NEDC");
    let smoother = Smoother::new(&nedc, LOOKAHEAD).expect("valid look-ahead");
    let mut group = c.benchmark_group("smooth_nedc_dt0.01_a5");
    group.throughput(Throughput::Elements(SAMPLES as u64));
    for max_order in [2usize, 4] {
        group.bench_function(format!("orders_0_to_{max_order}"), |b| {
            let mut out = vec![0.0; max_order + 1];
            b.iter(|| {
                let mut acc = 0.0;
                for i in 0..SAMPLES {
                    smoother.eval(black_box(i as f64 * DT), &mut out);
                    acc += out[max_order];
                }
                black_box(acc)
            })
        });
        for (name, t0) in [("aligned", 0.0), ("shifted", 0.003)] {
            let times: Vec<f64> = (0..SAMPLES).map(|i| t0 + i as f64 / 100.0).collect();
            let mut cols = vec![vec![0.0; SAMPLES]; max_order + 1];
            for (what, block) in [("whole", SAMPLES), ("blocks", BLOCK)] {
                group.bench_function(format!("grid_{name}_{what}_orders_0_to_{max_order}"), |b| {
                    b.iter(|| {
                        for k0 in (0..SAMPLES).step_by(block) {
                            let k1 = (k0 + block).min(SAMPLES);
                            let mut views: Vec<&mut [f64]> =
                                cols.iter_mut().map(|c| &mut c[k0..k1]).collect();
                            smoother.eval_grid(black_box(&times[k0..k1]), Some(DT), &mut views);
                        }
                        black_box(cols[max_order][SAMPLES / 2])
                    })
                });
            }
        }
    }
    group.finish();
    c.bench_function("smoother_new_nedc", |b| {
        b.iter(|| Smoother::new(black_box(&nedc), LOOKAHEAD))
    });
}

criterion_group!(benches, smooth_nedc);
criterion_main!(benches);
