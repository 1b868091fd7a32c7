//! Generated code against the interpreter tape, and the cost of generating code, for `models/si_engine.toml`.
//!
//! * `invert/*`: ψ⁻¹ + α + β (and u = (y'' − α)/β) per point, over 1 000 points with ξ1 ∈ [0, 40] m/s,
//!   ξ2 ∈ [−3, 3] m/s²: the compiled model through the runtime's trait object, the generated typed function,
//!   the interpreter, and for reference one `powf` per point (si_engine's friction term needs one); the same
//!   1 000 points as columns through the batch method (`invert_batch`, trait object and typed), and for
//!   reference the one power per point by `math::pow_pos_slice`;
//! * `outputs/*`: the extra outputs (fuel, engine speed and torque, whose friction term is another fractional
//!   power) at 1 000 states, point by point and by `outputs_batch`;
//! * `generate/*`: formatted Rust source from a derivation, and load + derive + generate from the file.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use invsim_inversion::Interpreter;
use invsim_model_api::InverseModel;
use invsim_models::si_engine;
use std::path::Path;

const POINTS: usize = 1000;

fn model_path() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine.toml")
}

/// Deterministic points spread over the box (a simple LCG, so no extra dependency).
fn points() -> Vec<([f64; 2], f64)> {
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..POINTS)
        .map(|_| ([40.0 * next(), -3.0 + 6.0 * next()], -2.0 + 4.0 * next()))
        .collect()
}

fn invert(c: &mut Criterion) {
    let pts = points();
    let d = invsim_inversion::derive_file(&model_path()).expect("si_engine derives");
    let interp = Interpreter::new(&d).expect("interpreter");
    let compiled: Box<dyn InverseModel> =
        invsim_models::builtin("si_engine").expect("si_engine is built in");
    let pre = si_engine::Precomputed::new(&si_engine::Params::default());
    let mut g = c.benchmark_group("invert");
    g.throughput(Throughput::Elements(POINTS as u64));
    g.bench_function("compiled_trait_object", |b| {
        b.iter(|| {
            let mut x = [0.0; 2];
            let mut acc = 0.0;
            for (xi, yr) in &pts {
                acc += compiled
                    .invert(black_box(xi), &[], &[], black_box(*yr), &mut x)
                    .unwrap_or(f64::NAN)
                    + x[1];
            }
            acc
        })
    });
    g.bench_function("compiled_typed", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for (xi, yr) in &pts {
                let (x, u) = pre.invert(black_box(xi), &[], black_box(*yr));
                acc += u + x[1];
            }
            acc
        })
    });
    // The floor under the generated code: si_engine's one irreducible `powf` per point (friction term), with
    // the same loop, inputs and accumulation.
    let (k3, k4) = (1e-4, 0.59);
    g.bench_function("reference_one_powf", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for (xi, yr) in &pts {
                let v = black_box(xi)[0];
                acc += (k3 + k4 * v * v).powf(0.1) + black_box(*yr);
            }
            acc
        })
    });
    // The same points as columns, through the batch methods.
    let xi1: Vec<f64> = pts.iter().map(|p| p.0[0]).collect();
    let xi2: Vec<f64> = pts.iter().map(|p| p.0[1]).collect();
    let yr: Vec<f64> = pts.iter().map(|p| p.1).collect();
    let (mut x1, mut x2, mut u) = (vec![0.0; POINTS], vec![0.0; POINTS], vec![0.0; POINTS]);
    g.bench_function("compiled_batch_trait_object", |b| {
        b.iter(|| {
            let xi: [&[f64]; 2] = [black_box(&xi1), black_box(&xi2)];
            compiled
                .invert_batch(
                    &xi,
                    &[],
                    &[],
                    black_box(&yr),
                    &mut [&mut x1, &mut x2],
                    &mut u,
                )
                .unwrap_or(());
            u[POINTS - 1] + x2[POINTS - 1]
        })
    });
    g.bench_function("compiled_batch_typed", |b| {
        b.iter(|| {
            pre.invert_batch(
                [black_box(&xi1), black_box(&xi2)],
                [],
                black_box(&yr),
                [&mut x1, &mut x2],
                &mut u,
            );
            u[POINTS - 1] + x2[POINTS - 1]
        })
    });
    // The floor under the batch: the same one power per point, by the vectorised pow.
    let bases: Vec<f64> = xi1.iter().map(|v| k3 + k4 * v * v).collect();
    let mut powers = vec![0.0; POINTS];
    g.bench_function("reference_one_pow_pos_slice", |b| {
        b.iter(|| {
            invsim_model_api::math::pow_pos_slice(black_box(&bases), 0.1, &mut powers);
            powers[POINTS - 1]
        })
    });
    g.bench_function("interpreter", |b| {
        b.iter(|| {
            let mut x = [0.0; 2];
            let mut acc = 0.0;
            for (xi, yr) in &pts {
                acc += interp
                    .invert(black_box(xi), &[], &[], black_box(*yr), &mut x)
                    .unwrap_or(f64::NAN)
                    + x[1];
            }
            acc
        })
    });
    g.finish();
}

fn outputs(c: &mut Criterion) {
    let pts = points();
    let compiled: Box<dyn InverseModel> =
        invsim_models::builtin("si_engine").expect("si_engine is built in");
    // States v ∈ [0, 40] m/s, p_i ∈ [2e4, 1e5] Pa and inputs m_at ∈ [0, 0.08] kg/s from the same generator.
    let v: Vec<f64> = pts.iter().map(|p| p.0[0]).collect();
    let p_i: Vec<f64> = pts.iter().map(|p| 6.0e4 + 1.3e4 * p.0[1]).collect();
    let m_at: Vec<f64> = pts.iter().map(|p| 0.04 + 0.02 * p.1).collect();
    let mut out = vec![vec![0.0; POINTS]; 4];
    let mut g = c.benchmark_group("outputs");
    g.throughput(Throughput::Elements(POINTS as u64));
    g.bench_function("compiled_pointwise", |b| {
        b.iter(|| {
            let mut o = [0.0; 4];
            let mut acc = 0.0;
            for k in 0..POINTS {
                compiled.outputs(black_box(&[v[k], p_i[k]]), &[], black_box(m_at[k]), &mut o);
                acc += o[3];
            }
            acc
        })
    });
    g.bench_function("compiled_batch", |b| {
        b.iter(|| {
            let [o0, o1, o2, o3] = &mut out[..] else {
                unreachable!()
            };
            compiled.outputs_batch(
                &[black_box(&v), black_box(&p_i)],
                &[],
                black_box(&m_at),
                &mut [o0, o1, o2, o3],
            );
            out[3][POINTS - 1]
        })
    });
    g.finish();
}

fn generate(c: &mut Criterion) {
    let path = model_path();
    let d = invsim_inversion::derive_file(&path).expect("si_engine derives");
    let mut g = c.benchmark_group("generate");
    g.bench_function("si_engine_source", |b| {
        b.iter(|| invsim_codegen::generate(black_box(&d), "si_engine.toml").map(|s| s.len()))
    });
    g.bench_function("si_engine_load_derive_generate", |b| {
        b.iter(|| invsim_codegen::generate_file(black_box(&path)).map(|(r, m)| r.len() + m.len()))
    });
    g.finish();
}

criterion_group!(benches, invert, outputs, generate);
criterion_main!(benches);
