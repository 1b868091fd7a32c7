//! Tests for the kernel (eq. 33–35 of Fröberg & Nielsen 2004) and the smoother: every value is checked
//! against an independent computation — adaptive Gauss–Kronrod quadrature of the convolution integral with
//! the kernel written out here, finite differences, or the raw cycle where it is linear.

use std::path::{Path, PathBuf};

use invsim_runtime::smoother::SmootherError;
use invsim_runtime::{Cycle, Kernel, Smoother};
use proptest::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

const C0_REFERENCE: f64 = 0.443_993_816_168_079_4;
const LOOKAHEADS: [f64; 4] = [1.0, 2.0, 5.0, 10.0];

// ---------------------------------------------------------------------------------------------------------
// Adaptive Gauss–Kronrod (7/15) quadrature, independent of the crate

const XGK: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
const WGK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_2,
    0.140_653_259_715_525_9,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_8,
];
const WG: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// One 15-point Kronrod panel: (integral, |K15 − G7|, ∫|f|).
fn gk15(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> (f64, f64, f64) {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let fc = f(c);
    let (mut rk, mut rg, mut ra) = (fc * WGK[7], fc * WG[3], fc.abs() * WGK[7]);
    for j in 0..7 {
        let (f1, f2) = (f(c - h * XGK[j]), f(c + h * XGK[j]));
        rk += WGK[j] * (f1 + f2);
        ra += WGK[j] * (f1.abs() + f2.abs());
        if j % 2 == 1 {
            rg += WG[j / 2] * (f1 + f2);
        }
    }
    (rk * h, ((rk - rg) * h).abs(), ra * h.abs())
}

/// Adaptive bisection until |K15 − G7| ≤ tol (split between halves) or only rounding is left.
fn integrate(f: &dyn Fn(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    fn go(f: &dyn Fn(f64) -> f64, a: f64, b: f64, tol: f64, depth: u32) -> f64 {
        let (r, err, rabs) = gk15(f, a, b);
        if err <= tol || err <= 1e-14 * rabs || depth == 0 {
            return r;
        }
        let m = 0.5 * (a + b);
        go(f, a, m, 0.5 * tol, depth - 1) + go(f, m, b, 0.5 * tol, depth - 1)
    }
    go(f, a, b, tol, 40)
}

/// `∫ f` over `[a, b]`, split at the given break points.
fn integrate_pieces(f: &dyn Fn(f64) -> f64, a: f64, b: f64, breaks: &[f64], tol: f64) -> f64 {
    let mut points = vec![a];
    points.extend(breaks.iter().copied().filter(|&x| x > a && x < b));
    points.push(b);
    points
        .windows(2)
        .map(|w| integrate(f, w[0], w[1], tol))
        .sum()
}

#[test]
fn quadrature_rule_is_exact_for_polynomials() {
    // K15 is exact up to degree 22, G7 up to 13.
    let (r, _, _) = gk15(&|x: f64| x.powi(20) + 3.0 * x.powi(7), -1.0, 1.0);
    assert!((r - 2.0 / 21.0).abs() < 1e-15, "{r}");
    let (r, err, _) = gk15(&|x: f64| x.powi(12), -1.0, 1.0);
    assert!((r - 2.0 / 13.0).abs() < 1e-15 && err < 1e-15, "{r} {err}");
    let r = integrate(&|x: f64| x.cos(), 0.0, 10.0, 1e-14);
    assert!((r - 10f64.sin()).abs() < 1e-14);
}

// ---------------------------------------------------------------------------------------------------------
// The kernel written out independently: g(t) = exp(−a²/(a² − t²)), its first two derivatives by hand.

/// ∫_{−1}^{1} exp(−1/(1 − u²)) du by quadrature.
fn c0_by_quadrature() -> f64 {
    let h = |u: f64| {
        let q = (1.0 - u) * (1.0 + u);
        if q > 0.0 {
            (-1.0 / q).exp()
        } else {
            0.0
        }
    };
    integrate_pieces(&h, -1.0, 1.0, &[-0.5, 0.0, 0.5], 1e-18)
}

/// k^(n)(s) for n = 0, 1, 2 from h(u) = e^(−w), h' = −2u w² h, h'' = (6u⁴ − 2) w⁴ h, w = 1/(1 − u²).
fn reference_kernel(n: usize, s: f64, a: f64) -> f64 {
    let u = s / a;
    let q = (1.0 - u) * (1.0 + u);
    if q <= 0.0 {
        return 0.0;
    }
    let w = 1.0 / q;
    let h = (-w).exp();
    let unit = match n {
        0 => h,
        1 => -2.0 * u * w * w * h,
        2 => (6.0 * u.powi(4) - 2.0) * w.powi(4) * h,
        _ => unreachable!("only orders 0–2 are written out"),
    };
    unit / (C0_REFERENCE * a.powi(n as i32 + 1))
}

// ---------------------------------------------------------------------------------------------------------
// Kernel

#[test]
fn normalisation_constant() {
    let c0 = c0_by_quadrature();
    assert!((c0 - C0_REFERENCE).abs() < 3e-16, "C0 = {c0:e}");
    assert_eq!(invsim_runtime::kernel::UNIT_NORMALISATION, C0_REFERENCE);
    for a in LOOKAHEADS {
        let k = Kernel::new(a);
        assert_eq!(k.half_width(), a);
        assert!((k.normalisation() - C0_REFERENCE * a).abs() < 1e-15 * a);
        let total = integrate_pieces(&|t| k.value(t), -a, a, &[0.0], 1e-17);
        assert!((total - 1.0).abs() < 1e-15, "a = {a}: ∫k = {total}");
        // value is g/C
        // (near the edge, rounding t/a is amplified by d ln g/dt ≈ 2a/(a − |t|)²: tolerance grows there)
        for (t, tol) in [
            (-0.7 * a, 1e-15),
            (-0.1 * a, 4e-16),
            (0.0, 4e-16),
            (0.3 * a, 1e-15),
            (0.99 * a, 1e-12),
        ] {
            let g = (-a * a / ((a - t) * (a + t))).exp();
            let expected = g / (C0_REFERENCE * a);
            assert!(
                (k.value(t) - expected).abs() <= tol * expected,
                "a = {a}, t = {t}"
            );
        }
    }
}

#[test]
fn integral_matches_quadrature_to_full_precision() {
    let mut rng = StdRng::seed_from_u64(33);
    let mut worst: f64 = 0.0;
    for a in [1.0, 2.0, 5.0, 10.0, 0.3, 37.0] {
        let k = Kernel::new(a);
        let density = |s: f64| reference_kernel(0, s, a);
        for _ in 0..200 {
            let t: f64 = rng.gen_range(-a..a);
            let q = integrate(&density, -a, t, 1e-18);
            let err = (k.integral(t) - q).abs();
            worst = worst.max(err);
            assert!(
                err <= 1e-15,
                "a = {a}, t = {t}: K = {}, quadrature {q}",
                k.integral(t)
            );
        }
        assert_eq!(k.integral(-a), 0.0);
        assert_eq!(k.integral(a), 1.0);
        assert_eq!(k.integral(-2.0 * a), 0.0);
        assert_eq!(k.integral(f64::INFINITY), 1.0);
        assert!(k.integral(f64::NAN).is_nan());
        assert!((k.integral(0.0) - 0.5).abs() < 2e-16);
    }
    eprintln!("worst |K − quadrature| = {worst:e}");
}

#[test]
fn integral_is_symmetric_and_monotone() {
    let k = Kernel::new(3.0);
    let mut previous = 0.0;
    for i in 0..=60_000 {
        let t = -3.0 + i as f64 * 1e-4;
        let v = k.integral(t);
        assert!(v >= previous - 2e-16, "not monotone at {t}");
        assert!((0.0..=1.0).contains(&v));
        assert!((v + k.integral(-t) - 1.0).abs() <= 2.3e-16, "t = {t}");
        previous = v;
    }
}

#[test]
fn moment_and_ramp_match_quadrature() {
    let mut rng = StdRng::seed_from_u64(7);
    for a in LOOKAHEADS {
        let k = Kernel::new(a);
        let first_moment = |s: f64| s * reference_kernel(0, s, a);
        for _ in 0..100 {
            let t: f64 = rng.gen_range(-1.2 * a..1.2 * a);
            let m = integrate(&first_moment, -a, t.clamp(-a, a), 1e-18);
            assert!((k.moment(t) - m).abs() <= 1e-15 * a, "a = {a}, t = {t}");
            // R(t) = ∫ k(σ) (t − σ)₊ dσ
            let ramp = integrate(
                &|s| reference_kernel(0, s, a) * (t - s).max(0.0),
                -a,
                t.clamp(-a, a),
                1e-18,
            );
            assert!((k.ramp(t) - ramp).abs() <= 2e-15 * a, "a = {a}, t = {t}");
            assert!((k.ramp_offset(t) - (ramp - t.max(0.0))).abs() <= 2e-15 * a);
            assert!((k.ramp_offset(t) - k.ramp_offset(-t)).abs() <= 1e-16 * a);
            let (ki, ro) = k.integral_and_ramp_offset(t);
            assert_eq!(ki, k.integral(t));
            assert_eq!(ro, k.ramp_offset(t));
        }
        assert_eq!(k.ramp(-a), 0.0);
        assert_eq!(k.ramp(2.0 * a), 2.0 * a);
        assert_eq!(k.moment(a), 0.0);
    }
}

/// `f'(x)` by the 8th-order central difference.
fn central_difference(f: &dyn Fn(f64) -> f64, x: f64, h: f64) -> f64 {
    const C: [f64; 4] = [4.0 / 5.0, -1.0 / 5.0, 4.0 / 105.0, -1.0 / 280.0];
    C.iter()
        .enumerate()
        .map(|(i, c)| {
            let d = (i + 1) as f64 * h;
            c * (f(x + d) - f(x - d))
        })
        .sum::<f64>()
        / h
}

#[test]
fn kernel_derivatives_match_the_hand_written_ones() {
    let mut rng = StdRng::seed_from_u64(1);
    for a in LOOKAHEADS {
        let k = Kernel::new(a);
        for _ in 0..300 {
            let t: f64 = rng.gen_range(-a..a);
            for n in 0..=2 {
                let r = reference_kernel(n, t, a);
                let scale = [0.37, 0.8, 7.5][n] / (C0_REFERENCE * a.powi(n as i32 + 1));
                assert!(
                    (k.derivative(n, t) - r).abs() <= 1e-14 * scale,
                    "n = {n}, a = {a}, t = {t}"
                );
            }
        }
    }
}

#[test]
fn kernel_derivatives_match_finite_differences() {
    let mut rng = StdRng::seed_from_u64(2);
    for a in LOOKAHEADS {
        let k = Kernel::new(a);
        for n in 1..=10 {
            // Scale of k^(n): its largest magnitude on a grid.
            let scale = (0..2000)
                .map(|i| k.derivative(n, -a + a * i as f64 / 1000.0).abs())
                .fold(0.0, f64::max);
            let lower = |t: f64| k.derivative(n - 1, t);
            for _ in 0..60 {
                let t: f64 = rng.gen_range(-a..a);
                // Near ±a the kernel varies on the scale (1 − u²)², so the step shrinks there.
                let q = 1.0 - (t / a).powi(2);
                let fd = central_difference(&lower, t, 2e-3 * a * (25.0 * q * q).min(1.0));
                let v = k.derivative(n, t);
                assert!(
                    (v - fd).abs() <= 1e-8 * scale,
                    "order {n}, a = {a}, t = {t}: {v} vs {fd} (scale {scale:e})"
                );
            }
        }
    }
}

#[test]
fn kernel_derivative_vector_and_symmetry() {
    let k = Kernel::new(2.5);
    let mut rng = StdRng::seed_from_u64(3);
    let mut all = [0.0; 14];
    for _ in 0..200 {
        let t: f64 = rng.gen_range(-2.5..2.5);
        k.derivatives(t, &mut all);
        for (n, &v) in all.iter().enumerate() {
            let single = k.derivative(n, t);
            assert!(
                (v - single).abs() <= 1e-14 * single.abs().max(1e-300),
                "n = {n}"
            );
            // k is even: k^(n)(−t) = (−1)^n k^(n)(t)
            let mirrored = k.derivative(n, -t) * if n % 2 == 0 { 1.0 } else { -1.0 };
            assert!(
                (mirrored - single).abs() <= 1e-14 * single.abs().max(1e-300),
                "n = {n}"
            );
        }
    }
    // Orders beyond the precomputed table (built on demand) are defined and finite; in double precision
    // they carry few correct digits, so only their consistency with the table at the boundary is checked.
    let mut wide = [0.0; 40];
    k.derivatives(0.9, &mut wide);
    assert!(wide.iter().all(|v| v.is_finite()));
    assert_eq!(wide[32], k.derivative(32, 0.9));
    let (a, b) = (wide[35], k.derivative(35, 0.9));
    assert!((a - b).abs() <= 1e-12 * b.abs(), "{a} vs {b}");
    assert_eq!(k.derivative(60, 2.5), 0.0);
}

#[test]
fn kernel_derivatives_vanish_smoothly_at_the_edges() {
    for a in LOOKAHEADS {
        let k = Kernel::new(a);
        let mut all = [0.0; 12];
        for e in 1..=15 {
            for sign in [-1.0, 1.0] {
                let t = sign * a * (1.0 - 10f64.powi(-e));
                k.derivatives(t, &mut all);
                for (n, &v) in all.iter().enumerate() {
                    assert!(v.is_finite(), "a = {a}, t = {t}, order {n}");
                    let single = k.derivative(n, t);
                    assert!(single.is_finite());
                    if e >= 4 {
                        // w ≥ 5000: e^(−w) w^(2n) is far below any double.
                        assert_eq!(single, 0.0, "a = {a}, 1 − 1e-{e}, order {n}");
                    }
                }
                assert!(
                    k.integral(t).is_finite() && k.ramp(t).is_finite() && k.moment(t).is_finite()
                );
            }
        }
        for t in [-a, a, 1.5 * a, -7.0 * a, f64::INFINITY, f64::NEG_INFINITY] {
            for n in 0..12 {
                assert_eq!(k.derivative(n, t), 0.0, "a = {a}, t = {t}, order {n}");
            }
            k.derivatives(t, &mut all);
            assert!(all.iter().all(|&v| v == 0.0));
        }
        // Just inside the edge, in the log-space regime (w > 700), values are tiny but well defined.
        let t = a * (1.0 - 5e-4);
        assert!(k.derivative(8, t).abs() < 1e-200);
    }
}

// ---------------------------------------------------------------------------------------------------------
// Smoother

/// `y_d^(n)(t) = ∫ k^(n)(t − τ) y_c(τ) dτ` (n ≤ 2) by quadrature, split at the cycle's samples.
fn convolution(cycle: &Cycle, a: f64, n: usize, t: f64) -> f64 {
    let f = |tau: f64| reference_kernel(n, t - tau, a) * cycle.speed_at(tau);
    integrate_pieces(&f, t - a, t + a, &cycle.time, 1e-13)
}

fn random_times(rng: &mut StdRng, cycle: &Cycle, a: f64, count: usize) -> Vec<f64> {
    let (t0, t1) = (cycle.time[0], cycle.time[cycle.time.len() - 1]);
    let mut times: Vec<f64> = (0..count).map(|_| rng.gen_range(t0 - a..t1 + a)).collect();
    // Also exactly at corners and at corners ± a.
    for _ in 0..count / 10 {
        let i = rng.gen_range(0..cycle.time.len());
        times.push(cycle.time[i]);
        times.push(cycle.time[i] + a);
        times.push(cycle.time[i] - a);
    }
    times
}

fn check_against_quadrature(cycle: &Cycle, lookaheads: &[f64], count: usize, seed: u64) {
    let mut rng = StdRng::seed_from_u64(seed);
    for &a in lookaheads {
        let s = Smoother::new(cycle, a).unwrap();
        let mut worst = [0.0f64; 3];
        for t in random_times(&mut rng, cycle, a, count) {
            let mut out = [0.0; 3];
            s.eval(t, &mut out);
            for n in 0..3 {
                let q = convolution(cycle, a, n, t);
                let err = (out[n] - q).abs();
                worst[n] = worst[n].max(err);
                assert!(
                    err <= 1e-9,
                    "{} a = {a}, t = {t}: y_d^({n}) = {} but quadrature gives {q}",
                    cycle.name,
                    out[n]
                );
            }
        }
        eprintln!(
            "{} a = {a}: worst |y_d^(n) − quadrature| for n = 0, 1, 2: {:.1e} {:.1e} {:.1e}",
            cycle.name, worst[0], worst[1], worst[2]
        );
    }
}

#[test]
fn nedc_matches_quadrature_of_the_convolution() {
    let nedc = Cycle::builtin("nedc").unwrap();
    check_against_quadrature(&nedc, &LOOKAHEADS, 200, 11);
}

#[test]
fn shared_cycles_match_quadrature_of_the_convolution() {
    let Some(dir) = shared_cycles() else { return };
    for (file, seed) in [("udds.csv", 12), ("wltc_3b.csv", 13)] {
        let cycle = Cycle::from_csv_path(&dir.join(file)).unwrap();
        check_against_quadrature(&cycle, &[1.0, 5.0], 200, seed);
    }
}

/// Corners of the raw cycle (slope changes above rounding), with the cycle held constant outside.
fn raw_corners(cycle: &Cycle) -> Vec<f64> {
    let n = cycle.time.len();
    let slope = |i: usize| {
        if i + 1 < n {
            (cycle.speed[i + 1] - cycle.speed[i]) / (cycle.time[i + 1] - cycle.time[i])
        } else {
            0.0
        }
    };
    let mut corners = Vec::new();
    let mut before = 0.0;
    for i in 0..n {
        let after = slope(i);
        if (after - before).abs() > 1e-12 * (1.0 + after.abs()) {
            corners.push(cycle.time[i]);
        }
        before = after;
    }
    corners
}

#[test]
fn smoothed_cycle_equals_raw_cycle_where_it_is_linear() {
    let nedc = Cycle::builtin("nedc").unwrap();
    let corners = raw_corners(&nedc);
    let mut rng = StdRng::seed_from_u64(5);
    for a in LOOKAHEADS {
        let s = Smoother::new(&nedc, a).unwrap();
        let mut found = 0;
        for _ in 0..20_000 {
            let t: f64 = rng.gen_range(-20.0..1200.0);
            if corners.iter().any(|&c| c > t - a && c < t + a) {
                continue;
            }
            found += 1;
            let mut out = [0.0; 4];
            s.eval(t, &mut out);
            let slope = (nedc.speed_at(t + 1e-3) - nedc.speed_at(t - 1e-3)) / 2e-3;
            assert!(
                (out[0] - nedc.speed_at(t)).abs() <= 1e-12,
                "a = {a}, t = {t}"
            );
            assert!((out[1] - slope).abs() <= 1e-9, "a = {a}, t = {t}");
            assert_eq!(out[2], 0.0);
            assert_eq!(out[3], 0.0);
        }
        assert!(found >= 200, "a = {a}: only {found} linear stretches found");
    }
}

#[test]
fn derivatives_match_finite_differences_of_eval() {
    let nedc = Cycle::builtin("nedc").unwrap();
    let mut rng = StdRng::seed_from_u64(8);
    for a in LOOKAHEADS {
        let s = Smoother::new(&nedc, a).unwrap();
        let scales: Vec<f64> = (0..=5)
            .map(|n| {
                (0..12_000)
                    .map(|i| s.derivative(n, i as f64 * 0.1).abs())
                    .fold(0.0, f64::max)
            })
            .collect();
        for _ in 0..300 {
            let t: f64 = rng.gen_range(-a..1180.0 + a);
            let mut out = [0.0; 5];
            s.eval(t, &mut out);
            for n in 1..=4 {
                let lower = |x: f64| s.derivative(n - 1, x);
                let fd = central_difference(&lower, t, 1e-3 * a);
                assert!(
                    (out[n] - fd).abs() <= 1e-8 * scales[n],
                    "a = {a}, t = {t}, order {n}: {} vs {fd}",
                    out[n]
                );
            }
        }
    }
}

#[test]
fn high_orders_up_to_ten_are_consistent() {
    let ece = Cycle::builtin("ece").unwrap();
    let s = Smoother::new(&ece, 5.0).unwrap();
    let mut rng = StdRng::seed_from_u64(9);
    let scales: Vec<f64> = (0..=11)
        .map(|n| {
            (0..20_000)
                .map(|i| s.derivative(n, i as f64 * 0.01).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let mut out = [0.0; 12];
    for _ in 0..100 {
        let t: f64 = rng.gen_range(0.0..195.0);
        s.eval(t, &mut out);
        assert!(out.iter().all(|v| v.is_finite()));
        for n in 5..=11 {
            let fd = central_difference(&|x| s.derivative(n - 1, x), t, 2e-3);
            assert!(
                (out[n] - fd).abs() <= 1e-6 * scales[n],
                "order {n}, t = {t}: {} vs {fd} (scale {:e})",
                out[n],
                scales[n]
            );
        }
        // eval with fewer outputs gives the same leading values
        let mut short = [0.0; 3];
        s.eval(t, &mut short);
        assert_eq!(short, out[..3]);
    }
}

#[test]
fn held_constant_outside_the_cycle() {
    let c = Cycle::from_csv_str("held", "t,mps\n0,3\n10,5\n20,5\n").unwrap();
    let s = Smoother::new(&c, 2.0).unwrap();
    let mut out = [0.0; 6];
    for t in [-100.0, -2.0, 22.0, 1e6, f64::NEG_INFINITY, f64::INFINITY] {
        s.eval(t, &mut out);
        let expected = if t < 0.0 { 3.0 } else { 5.0 };
        assert_eq!(out[0], expected, "t = {t}");
        assert!(out[1..].iter().all(|&v| v == 0.0), "t = {t}: {out:?}");
    }
    // Just inside the first corner's reach the smoothed speed starts to move.
    s.eval(-1.0, &mut out);
    assert!(out[0] > 3.0 && out[1] > 0.0);
    // NaN in, NaN out; an empty output slice is fine.
    s.eval(f64::NAN, &mut out);
    assert!(out.iter().all(|v| v.is_nan()));
    s.eval(1.0, &mut []);
    assert_eq!(s.corners().0, &[0.0, 10.0]);
    assert_eq!(s.support(), Some((-2.0, 12.0)));
}

#[test]
fn constant_cycle_has_no_corners() {
    let c = Cycle::from_csv_str("flat", "t,mps\n0,7\n1,7\n50,7\n").unwrap();
    let s = Smoother::new(&c, 5.0).unwrap();
    assert!(s.corners().0.is_empty());
    let mut out = [1.0; 4];
    s.eval(3.0, &mut out);
    assert_eq!(out, [7.0, 0.0, 0.0, 0.0]);
}

#[test]
fn smoothing_preserves_distance() {
    // ∫ y_d = ∫ y_c when the cycle starts and ends at rest (the kernel has unit mass).
    let nedc = Cycle::builtin("nedc").unwrap();
    for a in LOOKAHEADS {
        let s = Smoother::new(&nedc, a).unwrap();
        let breaks: Vec<f64> = nedc.time.iter().flat_map(|&t| [t - a, t, t + a]).collect();
        let total = integrate_pieces(&|t| s.derivative(0, t), -a, 1180.0 + a, &breaks, 1e-10);
        assert!(
            (total - nedc.distance()).abs() < 1e-8,
            "a = {a}: {total} vs {}",
            nedc.distance()
        );
    }
}

#[test]
fn invalid_inputs_are_errors() {
    let nedc = Cycle::builtin("nedc").unwrap();
    for a in [0.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let e = Smoother::new(&nedc, a).unwrap_err();
        assert!(
            matches!(e, SmootherError::InvalidLookahead(_)),
            "{a}: {e:?}"
        );
        assert!(e.to_string().contains("look-ahead"), "{e}");
    }
    let mut broken = nedc.clone();
    broken.time[5] = broken.time[4];
    let e = Smoother::new(&broken, 5.0).unwrap_err();
    assert!(matches!(e, SmootherError::InvalidCycle(_)));
    assert!(e.to_string().contains("strictly increasing"), "{e}");
    let s = Smoother::new(&nedc, 5.0).unwrap();
    assert_eq!(s.lookahead(), 5.0);
    assert_eq!(s.kernel().half_width(), 5.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// On random cycles y_d, y_d', y_d'' agree with quadrature, and y_d stays within the cycle's range
    /// (the kernel is a positive weight of unit mass).
    #[test]
    fn random_cycles(
        steps in prop::collection::vec((0.05f64..20.0, 0.0f64..40.0), 2..40),
        a in 0.2f64..12.0,
        frac in 0.0f64..1.0,
    ) {
        let mut time = Vec::new();
        let mut speed = Vec::new();
        let mut t = 0.0;
        for (dt, v) in steps {
            t += dt;
            time.push(t);
            speed.push(v);
        }
        let cycle = Cycle { tolerance: invsim_runtime::cycle::Tolerance::EPA, name: "random".into(), time, speed, grade: None, columns: Vec::new() };
        let s = Smoother::new(&cycle, a).unwrap();
        let (t0, t1) = (cycle.time[0] - a, cycle.time[cycle.time.len() - 1] + a);
        let t = t0 + frac * (t1 - t0);
        let mut out = [0.0; 3];
        s.eval(t, &mut out);
        for (n, &v) in out.iter().enumerate() {
            let q = convolution(&cycle, a, n, t);
            prop_assert!((v - q).abs() <= 1e-9 * (1.0 + q.abs()), "order {}: {} vs {}", n, v, q);
        }
        let lo = cycle.speed.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = cycle.speed.iter().copied().fold(0.0, f64::max);
        prop_assert!(out[0] >= lo - 1e-12 && out[0] <= hi + 1e-12);
    }
}

// ---------------------------------------------------------------------------------------------------------

fn shared_cycles() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/cycles");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipping: ../shared not found");
        None
    }
}

/// Grid times as the simulation forms them: `t0 + k/m` when `m = 1/dt` is a whole number (the correctly
/// rounded `k·dt`), else `t0 + k·dt`.
fn grid_times(t0: f64, dt: f64, n: usize) -> Vec<f64> {
    let per_second = 1.0 / dt;
    let whole = (per_second - per_second.round()).abs() < 1e-9 && per_second >= 1.0;
    (0..n)
        .map(|k| {
            if whole {
                t0 + k as f64 / per_second.round()
            } else {
                t0 + k as f64 * dt
            }
        })
        .collect()
}

/// Largest difference between `eval_grid` (in blocks of `block` samples, like the simulation) and `eval`
/// at every time, per order, relative to the order's largest magnitude on the grid.
fn grid_error(
    s: &Smoother,
    times: &[f64],
    dt: Option<f64>,
    orders: usize,
    block: usize,
) -> Vec<f64> {
    let n = times.len();
    let mut cols = vec![vec![0.0; n]; orders];
    for k0 in (0..n).step_by(block) {
        let k1 = (k0 + block).min(n);
        let mut views: Vec<&mut [f64]> = cols.iter_mut().map(|c| &mut c[k0..k1]).collect();
        s.eval_grid(&times[k0..k1], dt, &mut views);
    }
    let mut reference = vec![vec![0.0; n]; orders];
    let mut one = vec![0.0; orders];
    for (k, &t) in times.iter().enumerate() {
        s.eval(t, &mut one);
        for (col, &v) in reference.iter_mut().zip(&one) {
            col[k] = v;
        }
    }
    (0..orders)
        .map(|o| {
            let scale = reference[o].iter().fold(1e-300_f64, |m, v| m.max(v.abs()));
            let worst = cols[o]
                .iter()
                .zip(&reference[o])
                .fold(0.0, |m: f64, (g, r)| m.max((g - r).abs()));
            worst / scale
        })
        .collect()
}

/// `eval_grid` (corner by corner, kernel terms from per-phase tables on regular grids, sample by sample
/// otherwise) gives the values of `eval` (time by time) within 1e-12 of each order's scale, for every order
/// a model of relative degree up to 5 uses (y_d … y_d^(6)), on aligned and unaligned grids, whole or in
/// blocks.
#[test]
fn grid_evaluation_matches_pointwise() {
    let nedc = Cycle::builtin("nedc").unwrap();
    let odd = Cycle {
        tolerance: invsim_runtime::cycle::Tolerance::EPA,
        name: "odd".into(),
        time: vec![0.0, 3.3, 7.05, 9.0, 20.123],
        speed: vec![0.0, 4.0, 4.0, 9.5, 0.0],
        grade: None,
        columns: Vec::new(),
    };
    let mut ece_shifted = Cycle::builtin("ece").unwrap();
    for t in &mut ece_shifted.time {
        *t += 0.37; // every corner off a 0.1 s grid by the same phase
    }
    let cases: &[(&Cycle, f64, f64, f64, usize)] = &[
        (&nedc, 5.0, 0.0, 0.01, 118_001),
        (&nedc, 5.0, 0.0, 0.001, 250_001),
        (&nedc, 5.0, 0.0, 1.0, 1_181),
        (&nedc, 5.0, 0.5, 1.0, 1_181),
        (&nedc, 2.0, 0.0, 0.1, 11_801),
        (&nedc, 5.0, 0.0, 0.3, 3_934),
        (&nedc, 1.0, 3.0, 0.07, 2_000),
        (&nedc, 5.0, -7.123, 0.1, 11_900),
        (&nedc, 0.5, 0.001, 0.001, 60_000),
        (&ece_shifted, 5.0, 0.0, 0.1, 2_000),
        (&ece_shifted, 3.0, -1.0, 0.3, 700),
        (&odd, 1.5, -2.0, 0.05, 500),
        (&odd, 0.3, 0.0, 0.011, 2_000),
        (&odd, 4.0, 0.25, 0.001, 25_000),
    ];
    let mut overall = [0.0f64; 7];
    for &(cycle, a, t0, dt, n) in cases {
        let s = Smoother::new(cycle, a).unwrap();
        let times = grid_times(t0, dt, n);
        for (block, step) in [(n, Some(dt)), (4096, Some(dt)), (777, Some(dt)), (n, None)] {
            let worst = grid_error(&s, &times, step, 7, block);
            for (o, w) in worst.iter().enumerate() {
                overall[o] = overall[o].max(*w);
                assert!(
                    *w < 1e-12,
                    "{} a = {a} t0 = {t0} dt = {dt} block {block} {step:?}: order {o} differs by {w:e} \
                     (relative to its scale)",
                    cycle.name
                );
            }
        }
    }
    let overall = overall.map(|w| format!("{w:.1e}"));
    eprintln!("worst |eval_grid − eval| / scale for orders 0–6: {overall:?}");
}

/// Fewer orders than the tables hold, one order only, an irregular grid passed with a step, a grid that
/// starts far from the cycle, and a reference map: all agree with `eval`.
#[test]
fn grid_evaluation_edge_cases() {
    let nedc = Cycle::builtin("nedc").unwrap();
    let s = Smoother::new(&nedc, 5.0).unwrap();
    let times = grid_times(0.0, 0.1, 3_000);
    for orders in [7, 3, 1, 2, 5] {
        let worst = grid_error(&s, &times, Some(0.1), orders, 1000);
        assert!(
            worst.iter().all(|&w| w < 1e-12),
            "{orders} orders: {worst:?}"
        );
    }
    let mut rng = StdRng::seed_from_u64(21);
    let mut irregular: Vec<f64> = (0..3_000).map(|_| rng.gen_range(0.0..300.0)).collect();
    irregular.sort_by(f64::total_cmp);
    let worst = grid_error(&s, &irregular, Some(0.1), 5, 3_000);
    assert!(worst.iter().all(|&w| w < 1e-12), "irregular: {worst:?}");
    let far = grid_times(-500.0, 0.25, 400);
    let worst = grid_error(&s, &far, Some(0.25), 4, 100);
    assert!(worst.iter().all(|&w| w < 1e-12), "far: {worst:?}");
    let map = invsim_model_api::ReferenceMap {
        offset: 1.5e5,
        scale: 2e4,
    };
    let mapped = s.clone().with_reference(map);
    let worst = grid_error(&mapped, &times, Some(0.1), 4, 1000);
    assert!(worst.iter().all(|&w| w < 1e-12), "mapped: {worst:?}");
    // A table too long for the cache (a/dt = 5·10⁶): sample by sample.
    let fine = grid_times(14.999, 1e-6, 2_000);
    let worst = grid_error(&s, &fine, Some(1e-6), 4, 2_000);
    assert!(worst.iter().all(|&w| w < 1e-12), "fine: {worst:?}");
}

/// More corner phases than the cache holds (a random cycle, every corner its own phase): tables up to the
/// budget, the rest sample by sample, tables of earlier blocks dropped — the values stay those of `eval`.
#[test]
fn grid_evaluation_beyond_the_table_budget() {
    let mut rng = StdRng::seed_from_u64(77);
    let mut time = vec![0.0];
    let mut speed = vec![0.0];
    for _ in 0..200 {
        time.push(time[time.len() - 1] + rng.gen_range(0.1..0.9));
        speed.push(rng.gen_range(0.0..30.0));
    }
    let cycle = Cycle {
        tolerance: invsim_runtime::cycle::Tolerance::EPA,
        name: "random".into(),
        time,
        speed,
        grade: None,
        columns: Vec::new(),
    };
    let s = Smoother::new(&cycle, 2.0).unwrap();
    let times = grid_times(-2.5, 0.0005, 230_000);
    for block in [times.len(), 4096] {
        let worst = grid_error(&s, &times, Some(0.0005), 3, block);
        assert!(worst.iter().all(|&w| w < 1e-12), "block {block}: {worst:?}");
    }
}

/// A smoother is shared by threads (parameter sweeps): its table cache is behind a lock, and evaluations
/// from two threads at once give the values of one.
#[test]
fn grid_evaluation_from_two_threads() {
    fn shareable<T: Send + Sync + Clone>() {}
    shareable::<Smoother>();
    let nedc = Cycle::builtin("nedc").unwrap();
    let s = Smoother::new(&nedc, 5.0).unwrap();
    let times = grid_times(0.0, 0.01, 20_000);
    let run = |t0: f64| {
        let shifted: Vec<f64> = times.iter().map(|t| t + t0).collect();
        let mut cols = vec![vec![0.0; shifted.len()]; 4];
        for k0 in (0..shifted.len()).step_by(1000) {
            let k1 = (k0 + 1000).min(shifted.len());
            let mut views: Vec<&mut [f64]> = cols.iter_mut().map(|c| &mut c[k0..k1]).collect();
            s.eval_grid(&shifted[k0..k1], Some(0.01), &mut views);
        }
        cols
    };
    let alone: Vec<_> = [0.0, 0.004].map(run).into();
    let together: Vec<_> = std::thread::scope(|scope| {
        let handles = [0.0, 0.004].map(|t0| scope.spawn(move || run(t0)));
        handles.map(|h| h.join().unwrap()).into()
    });
    assert!(alone == together);
    let copy = s.clone();
    let mut one = vec![vec![0.0; 1000]; 4];
    let mut views: Vec<&mut [f64]> = one.iter_mut().map(|c| c.as_mut_slice()).collect();
    copy.eval_grid(&times[..1000], Some(0.01), &mut views);
    assert!(one.iter().zip(&alone[0]).all(|(c, a)| c[..] == a[..1000]));
}
