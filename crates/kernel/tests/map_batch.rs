//! The batched map evaluation (`Map::partials2_batch`): the same numbers as `Map::partials2` point by point
//! at many random points inside, at the edges and outside the grid for each extrapolation rule, 1-D and 2-D,
//! on the fixed-width path and on the point-by-point one; against quadrature of the convolution and finite
//! differences; NaN arguments and the `error` rule's report. And the interpreter's one-partial call of a 1-D
//! map against `Map::eval`, bit for bit.

use crate::common::{convolve_1d, convolve_2d, Lcg};
use invsim_kernel::map::{take_violation, Extrapolate, Interp, Map, MapSettings};

const RULES: [Extrapolate; 3] = [Extrapolate::Linear, Extrapolate::Clamp, Extrapolate::Error];

fn settings(smooth: f64, extrapolate: Extrapolate, interp: Interp) -> MapSettings {
    MapSettings {
        smooth,
        extrapolate,
        interp,
    }
}

/// Points along a grid: uniform over the grid widened by 30 % on each side, the grid points themselves,
/// points within the kernel's half-width `h` of each grid point (the window's edges included) and far out.
fn points(g: &[f64], h: f64, rng: &mut Lcg, random: usize) -> Vec<f64> {
    let (lo, hi) = (g[0], g[g.len() - 1]);
    let span = hi - lo;
    let mut p: Vec<f64> = (0..random)
        .map(|_| lo - 0.3 * span + 1.6 * span * rng.next())
        .collect();
    for &x in g {
        p.extend([x, x - h, x + h, x - 0.5 * h, x + 0.999 * h, x + 1e-9 * h]);
    }
    p.extend([lo - 10.0 * span, hi + 10.0 * span]);
    p
}

/// A 1-D curve with uneven spacing (min 0.4) and a sharp peak.
fn curve() -> (Vec<f64>, Vec<f64>) {
    (
        vec![0.0, 1.0, 1.5, 3.0, 3.4, 6.0],
        vec![2.0, 3.0, -1.0, 0.5, 4.0, 1.0],
    )
}

/// si_engine_maps-like eta_vol grid, uneven in x (min spacing 50), with a two-point axis variant.
fn grid_2d(two_point_y: bool) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let x = vec![50.0, 100.0, 200.0, 300.0, 400.0, 500.0, 600.0, 700.0];
    let y = if two_point_y {
        vec![2.0e4, 1.0e5]
    } else {
        vec![2.0e4, 4.0e4, 6.0e4, 8.0e4, 1.0e5]
    };
    let v = x
        .iter()
        .enumerate()
        .flat_map(|(i, &w)| {
            y.iter().enumerate().map(move |(j, &p)| {
                (0.96 - 8000.0 / p) * (0.9 + 1e-4 * w) + 0.03 * ((i * 7 + j * 3) % 5) as f64
            })
        })
        .collect();
    (x, y, v)
}

fn min_spacing(g: &[f64]) -> f64 {
    g.windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min)
}

/// `partials2_batch` against `partials2` at every point: within `1e-14 · max|v| / (hx^p hy^q)` (the map's
/// scale for that partial), and `partials2_fresh` and `eval` bit for bit equal to `partials2`; returns how many
/// entries of the batch were bit for bit equal and how many were compared.
fn compare(map: &Map, a: &[f64], b: &[f64], h: [f64; 2]) -> (usize, usize) {
    let n = a.len();
    let two_d = map.arity() == 2;
    let width = if two_d { 9 } else { 3 };
    let mut out = vec![f64::NAN; width * n];
    map.partials2_batch(a, b, &mut out);
    take_violation();
    // The values alone: entry 0 of the batch, bit for bit.
    let mut values = vec![f64::NAN; n];
    map.values_batch(a, b, &mut values);
    take_violation();
    for (i, v) in values.iter().enumerate() {
        assert_eq!(v.to_bits(), out[i].to_bits(), "values_batch at point {i}");
    }
    let vmax = map.values().iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let (mut same, mut total) = (0, 0);
    for i in 0..n {
        let args: Vec<f64> = if two_d { vec![a[i], b[i]] } else { vec![a[i]] };
        // Fresh point by point (another memo key: the memo holds only what a fresh evaluation gives).
        let want = map.partials2(&args);
        take_violation();
        // Without the memo: the same bits, every entry.
        let fresh = map.partials2_fresh(&args);
        take_violation();
        assert_eq!(
            fresh.map(f64::to_bits),
            want.map(f64::to_bits),
            "partials2_fresh at {args:?}"
        );
        // `eval` keeps the basis of variable length (`small.rs`): the same bits as the fixed-width path
        // `partials2` takes at one point.
        let mut by_eval = [f64::NAN; 9];
        map.eval(
            &args,
            if two_d { [2, 2] } else { [2, 0] },
            &mut by_eval[..width],
        );
        take_violation();
        assert_eq!(
            by_eval[..width]
                .iter()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>(),
            want[..width]
                .iter()
                .map(|v| v.to_bits())
                .collect::<Vec<_>>(),
            "eval against partials2 at {args:?}"
        );
        for k in 0..width {
            let (p, q) = if two_d { (k / 3, k % 3) } else { (k, 0) };
            let scale = vmax / (h[0].powi(p as i32) * h[1].powi(q as i32));
            let got = out[k * n + i];
            assert!(
                (got - want[k]).abs() <= 1e-14 * scale,
                "{:?} at {args:?}, entry {k}: batch {got} vs point {}",
                map.settings(),
                want[k]
            );
            same += usize::from(got.to_bits() == want[k].to_bits());
            total += 1;
        }
    }
    (same, total)
}

#[test]
fn one_d_batch_equals_point_by_point() {
    let (x, v) = curve();
    let mut rng = Lcg(7);
    let (mut same, mut total) = (0, 0);
    for rule in RULES {
        for (smooth, interp) in [
            (0.5, Interp::Smooth),
            (0.3, Interp::Smooth),
            (1.7, Interp::Smooth),
            (0.5, Interp::Linear),
        ] {
            let map = Map::new_1d(x.clone(), v.clone(), settings(smooth, rule, interp)).unwrap();
            let h = smooth * min_spacing(&x);
            let a = points(&x, h, &mut rng, 3000);
            let (s, t) = compare(&map, &a, &[], [h, 1.0]);
            same += s;
            total += t;
        }
    }
    // The fixed-width path adds exact zeros where the point-by-point path skips a term: the same bits.
    assert_eq!(same, total, "bit for bit");
}

#[test]
fn two_d_batch_equals_point_by_point() {
    let mut rng = Lcg(11);
    let (mut same, mut total) = (0, 0);
    for two_point_y in [false, true] {
        let (x, y, v) = grid_2d(two_point_y);
        for rule in RULES {
            for (smooth, interp) in [
                (0.5, Interp::Smooth),
                (0.25, Interp::Smooth),
                (0.9, Interp::Smooth),
                (0.5, Interp::Linear),
            ] {
                let s = settings(smooth, rule, interp);
                let map = Map::new_2d(x.clone(), y.clone(), v.clone(), s).unwrap();
                let h = [smooth * min_spacing(&x), smooth * min_spacing(&y)];
                let mut a = points(&x, h[0], &mut rng, 400);
                let mut b = points(&y, h[1], &mut rng, 400);
                // Every pairing of the special points, then random pairs.
                let (na, nb) = (a.len(), b.len());
                let (mut pa, mut pb) = (Vec::new(), Vec::new());
                for &ai in &a[400..na] {
                    for &bj in &b[400..nb] {
                        pa.push(ai);
                        pb.push(bj);
                    }
                }
                a.truncate(400.min(na));
                b.truncate(400.min(nb));
                pa.extend(&a);
                pb.extend(&b);
                let (s, t) = compare(&map, &pa, &pb, h);
                same += s;
                total += t;
            }
        }
    }
    assert_eq!(same, total, "bit for bit");
}

/// Orders 0–2 of the batch against quadrature of the convolution (independent of the basis functions).
#[test]
fn batch_matches_quadrature_of_the_convolution() {
    let (x, v) = curve();
    let h = 0.5 * 0.4;
    for rule in RULES {
        let map = Map::new_1d(x.clone(), v.clone(), settings(0.5, rule, Interp::Smooth)).unwrap();
        let a = [-1.0, -0.07, 0.0, 0.13, 1.45, 1.5, 2.2, 3.3, 5.9, 6.05, 8.0];
        let mut out = [0.0; 33];
        map.partials2_batch(&a, &[], &mut out);
        take_violation();
        for (i, &ai) in a.iter().enumerate() {
            for p in 0..3 {
                let want = convolve_1d(&x, &v, rule, h, p, ai);
                let got = out[p * a.len() + i];
                assert!(
                    (got - want).abs() <= 1e-11 * 10.0 / h.powi(p as i32),
                    "{rule:?} a = {ai} order {p}: {got} vs quadrature {want}"
                );
            }
        }
    }
    let (x, y, v) = grid_2d(false);
    let h = [25.0, 1.0e4];
    let a = [300.0, 200.0, 120.0, 60.0, -100.0, 720.0, 75.0];
    let b = [7.0e4, 4.0e4, 9.5e4, 1.2e5, 7.0e4, 1.0e4, 2.5e4];
    for rule in RULES {
        let s = settings(0.5, rule, Interp::Smooth);
        let map = Map::new_2d(x.clone(), y.clone(), v.clone(), s).unwrap();
        let mut out = [0.0; 63];
        map.partials2_batch(&a, &b, &mut out);
        take_violation();
        for i in 0..a.len() {
            let quadrature = convolve_2d(&x, &y, &v, rule, h, [a[i], b[i]]);
            for k in 0..9 {
                let (p, q) = (k / 3, k % 3);
                let got = out[k * a.len() + i];
                let scale = 1.0 / (h[0].powi(p as i32) * h[1].powi(q as i32));
                assert!(
                    (got - quadrature[p][q]).abs() <= 1e-10 * scale,
                    "{rule:?} ({}, {}) d{p}{q}: {got} vs quadrature {}",
                    a[i],
                    b[i],
                    quadrature[p][q]
                );
            }
        }
    }
}

/// First and second partials of the batch against central differences of the batch's lower orders.
#[test]
fn batch_partials_match_finite_differences() {
    let (x, y, v) = grid_2d(false);
    let h = [25.0, 1.0e4];
    let map = Map::new_2d(x, y, v, settings(0.5, Extrapolate::Linear, Interp::Smooth)).unwrap();
    let at = |a: f64, b: f64| {
        let mut out = [0.0; 9];
        map.partials2_batch(&[a], &[b], &mut out);
        out
    };
    for (a, b) in [
        (310.0, 6.1e4),
        (105.0, 3.9e4),
        (45.0, 9.0e4),
        (690.0, 1.05e5),
    ] {
        let got = at(a, b);
        for (k, &got_k) in got.iter().enumerate().skip(1) {
            let (p, q) = (k / 3, k % 3);
            // difference along a if p > 0 (entry k − 3), else along b (entry k − 1)
            let (lower, step) = if p > 0 {
                (k - 3, 1e-3 * h[0])
            } else {
                (k - 1, 1e-3 * h[1])
            };
            let f = |s: f64| {
                if p > 0 {
                    at(a + s, b)[lower]
                } else {
                    at(a, b + s)[lower]
                }
            };
            let c = |d: f64| (f(d) - f(-d)) / (2.0 * d);
            let fd = (4.0 * c(0.5 * step) - c(step)) / 3.0;
            let scale = 1.0 / (h[0].powi(p as i32) * h[1].powi(q as i32));
            assert!(
                (got_k - fd).abs() <= 1e-7 * scale,
                "({a}, {b}) d{p}{q}: {got_k} vs {fd}"
            );
        }
    }
}

#[test]
fn batch_lengths_nan_and_the_error_rule() {
    let (x, y, v) = grid_2d(false);
    let s = settings(0.5, Extrapolate::Error, Interp::Smooth);
    let map = Map::new_2d(x, y, v, s).unwrap().named("eta_vol");
    // Lengths around the chunk size.
    let mut rng = Lcg(3);
    for n in [0, 1, 31, 32, 33, 65, 100] {
        let a: Vec<f64> = (0..n).map(|_| 60.0 + 600.0 * rng.next()).collect();
        let b: Vec<f64> = (0..n).map(|_| 2.1e4 + 7.0e4 * rng.next()).collect();
        compare(&map, &a, &b, [25.0, 1.0e4]);
    }
    take_violation();
    let a = [300.0, f64::NAN, 800.0, 900.0];
    let b = [5.0e4, 5.0e4, 5.0e4, f64::NAN];
    let mut out = [0.0; 36];
    map.partials2_batch(&a, &b, &mut out);
    for k in 0..9 {
        assert!(out[k * 4].is_finite() && out[k * 4 + 2].is_finite());
        assert!(
            out[k * 4 + 1].is_nan() && out[k * 4 + 3].is_nan(),
            "entry {k}"
        );
    }
    // The first point outside (NaN counts) is the one reported, as point-by-point calls would.
    let violation = take_violation().expect("argument outside the grid");
    assert_eq!((&*violation.map, violation.arg), ("eta_vol", 0));
    assert!(violation.value.is_nan());
    assert_eq!(take_violation(), None);
    // The values alone: the same NaNs and the same report.
    let mut values = [0.0; 4];
    map.values_batch(&a, &b, &mut values);
    assert_eq!(values.map(f64::is_nan), [false, true, false, true]);
    assert_eq!(values[2].to_bits(), out[2].to_bits());
    let violation = take_violation().expect("argument outside the grid");
    assert_eq!((&*violation.map, violation.arg), ("eta_vol", 0));
    map.partials2_batch(&[300.0], &[5.0e4], &mut out);
    assert_eq!(take_violation(), None);
}

/// The interpreter's one-partial call (`partial_unmemoized`, and `partial` through its memo) gives
/// `Map::eval`'s numbers bit for bit for 1-D maps, smooth and plain linear, every rule, orders 0–3.
#[test]
fn one_partial_of_a_1d_map_equals_eval_bit_for_bit() {
    let (x, v) = curve();
    let mut rng = Lcg(5);
    for rule in RULES {
        for (smooth, interp) in [
            (0.5, Interp::Smooth),
            (1.7, Interp::Smooth),
            (0.5, Interp::Linear),
        ] {
            let map = Map::new_1d(x.clone(), v.clone(), settings(smooth, rule, interp)).unwrap();
            let h = smooth * min_spacing(&x);
            for a in points(&x, h, &mut rng, 2000) {
                let mut want = [0.0; 4];
                map.eval(&[a], [3, 0], &mut want);
                for (order, &w) in want.iter().enumerate() {
                    let got = map.partial_unmemoized(&[a, 0.0], [order, 0]);
                    assert_eq!(
                        got.to_bits(),
                        w.to_bits(),
                        "{rule:?} {interp:?} a = {a}, order {order}"
                    );
                    let memo = map.partial(&[a], [order, 0]);
                    assert_eq!(
                        memo.to_bits(),
                        w.to_bits(),
                        "memo: {rule:?} {interp:?} a = {a}"
                    );
                }
            }
            take_violation();
            assert!(map.partial_unmemoized(&[f64::NAN], [1, 0]).is_nan());
            take_violation();
        }
    }
}
