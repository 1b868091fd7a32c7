//! Benchmarks of the expression engine on the paper's SI-engine model: evaluating α(ξ) and β(ξ) from one
//! compiled tape (target: under 50 ns per point), and the symbolic pipeline parse → L_f² h → print.

use criterion::{black_box, criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use invsim_expr::{Id, Pool, Symbol, Tape};

/// α(ξ) and β(ξ) of si_engine.md with symbolic parameters.
const ALPHA: &str = "(1.8*c2*xi1^0.8 + 2*c1*xi1)*xi2 \
                     + c3*(c5*xi1 + c6*xi1*(xi2 - c1*xi1^2 - c2*xi1^1.8 - c4)/c3)";
const BETA: &str = "c3*c7";
const INPUTS: [&str; 9] = ["xi1", "xi2", "c1", "c2", "c3", "c4", "c5", "c6", "c7"];
/// Representative parameter values (magnitudes as in the model at the table's parameters).
const PARAMS: [f64; 7] = [-3.1e-4, -2.2e-3, 1.3e-4, -0.12, 2.9e3, -0.21, 4.6e7];

fn alpha_beta_tape() -> Tape {
    let mut pool = Pool::new();
    let outputs = [pool.parse(ALPHA).unwrap(), pool.parse(BETA).unwrap()];
    let inputs: Vec<Symbol> = INPUTS.iter().map(|n| pool.symbol(n)).collect();
    Tape::compile(&pool, &outputs, &inputs).unwrap()
}

/// Points along a drive cycle: speeds 1–35 m/s, accelerations ±1.5 m/s² (ξ2 = dv/dt).
fn points(n: usize) -> Vec<[f64; 9]> {
    (0..n)
        .map(|k| {
            let t = k as f64 / n as f64;
            let xi1 = 1.0 + 34.0 * (0.5 - 0.5 * (6.0 * t).cos());
            let xi2 = 1.5 * (17.0 * t).sin();
            let mut p = [0.0; 9];
            p[0] = xi1;
            p[1] = xi2;
            p[2..].copy_from_slice(&PARAMS);
            p
        })
        .collect()
}

fn tape_eval(c: &mut Criterion) {
    let tape = alpha_beta_tape();
    let pts = points(1024);
    let mut group = c.benchmark_group("alpha_beta");
    group.throughput(Throughput::Elements(pts.len() as u64));
    group.bench_function("eval_in", |b| {
        let mut buf = tape.new_buffer();
        let mut out = [0.0; 2];
        b.iter(|| {
            let mut acc = 0.0;
            for p in &pts {
                tape.eval_in(&mut buf, black_box(p), &mut out);
                acc += out[0] + out[1];
            }
            acc
        })
    });
    group.bench_function("eval", |b| {
        let mut out = [0.0; 2];
        b.iter(|| {
            let mut acc = 0.0;
            for p in &pts {
                tape.eval(black_box(p), &mut out);
                acc += out[0] + out[1];
            }
            acc
        })
    });
    // The parameters fixed once (Tape::specialize): per point only what depends on ξ remains.
    let fixed = tape.specialize(&PARAMS);
    group.bench_function("eval_in_specialized", |b| {
        let mut buf = fixed.new_buffer();
        let mut out = [0.0; 2];
        b.iter(|| {
            let mut acc = 0.0;
            for p in &pts {
                fixed.eval_in(&mut buf, black_box(&p[..2]), &mut out);
                acc += out[0] + out[1];
            }
            acc
        })
    });
    group.finish();
}

/// The Lie derivative L_field e over the states (v, p_i).
fn lie(pool: &mut Pool, e: Id, states: [Symbol; 2], field: [Id; 2]) -> Id {
    let terms: Vec<Id> = states
        .into_iter()
        .zip(field)
        .map(|(s, fs)| {
            let d = pool.diff(e, s);
            pool.mul2(d, fs)
        })
        .collect();
    pool.add(&terms)
}

fn symbolic(c: &mut Criterion) {
    c.bench_function("parse_diff_print_lf2h", |b| {
        b.iter_batched(
            Pool::new,
            |mut pool| {
                let f = [
                    pool.parse(black_box("c1*v^2 + c2*v^1.8 + c3*p_i + c4"))
                        .unwrap(),
                    pool.parse(black_box("c5*v + c6*v*p_i")).unwrap(),
                ];
                let h = pool.parse(black_box("v")).unwrap();
                let states = [pool.symbol("v"), pool.symbol("p_i")];
                let lf_h = lie(&mut pool, h, states, f);
                let lf2_h = lie(&mut pool, lf_h, states, f);
                pool.display(lf2_h)
            },
            BatchSize::SmallInput,
        )
    });
}

criterion_group!(benches, tape_eval, symbolic);
criterion_main!(benches);
