//! Smooth lookup maps (contract §6): values and every partial derivative up to order 4 against quadrature of
//! the convolution and against finite differences, inside, near the edges and outside the grid for each
//! extrapolation rule; exact reproduction of linear / bilinear data; plain linear interpolation; bad data.

use crate::common::{convolve_1d, convolve_2d, linear_1d, linear_2d};
use invsim_kernel::map::{Extrapolate, Interp, Map, MapError, MapSettings};

const RULES: [Extrapolate; 3] = [Extrapolate::Linear, Extrapolate::Clamp, Extrapolate::Error];

fn settings(smooth: f64, extrapolate: Extrapolate) -> MapSettings {
    MapSettings {
        smooth,
        extrapolate,
        interp: Interp::Smooth,
    }
}

/// The contract's example: a volumetric-efficiency map over speed (rad/s) × manifold pressure (Pa).
fn eta_grid() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let x = vec![100.0, 200.0, 400.0, 600.0];
    let y = vec![2.0e4, 5.0e4, 1.0e5];
    let v = vec![
        0.70, 0.75, 0.80, 0.78, 0.83, 0.86, 0.82, 0.88, 0.90, 0.80, 0.86, 0.89,
    ];
    (x, y, v)
}

/// A 1-D curve with uneven spacing and a sharp peak.
fn curve() -> (Vec<f64>, Vec<f64>) {
    (
        vec![0.0, 1.0, 1.5, 3.0, 3.4, 6.0],
        vec![2.0, 3.0, -1.0, 0.5, 4.0, 1.0],
    )
}

/// Points inside, at grid points, within h of the edges, and well outside (h = smooth · min spacing).
fn points_1d(x: &[f64], h: f64) -> Vec<f64> {
    let (lo, hi) = (x[0], x[x.len() - 1]);
    let mut p = vec![
        lo - 3.0 * h,
        lo - 0.7 * h,
        lo,
        lo + 0.3 * h,
        hi - 0.4 * h,
        hi,
        hi + 0.5 * h,
    ];
    p.extend([hi + 4.0 * h, 0.5 * (x[1] + x[2]), x[1], x[2] + 0.1 * h]);
    p
}

fn close(got: f64, want: f64, scale: f64, tol: f64) -> bool {
    (got - want).abs() <= tol * scale
}

#[test]
fn one_d_matches_quadrature_of_the_convolution_up_to_order_4() {
    let (x, v) = curve();
    for smooth in [0.5, 1.7] {
        let h = smooth * 0.4;
        for rule in RULES {
            let map = Map::new_1d(x.clone(), v.clone(), settings(smooth, rule)).unwrap();
            for a in points_1d(&x, h) {
                let mut out = [0.0; 5];
                map.eval(&[a], [4, 0], &mut out);
                for (p, &got) in out.iter().enumerate() {
                    let want = convolve_1d(&x, &v, rule, h, p, a);
                    let scale = 10.0 / h.powi(p as i32);
                    assert!(
                        close(got, want, scale, 1e-11),
                        "smooth {smooth}, {rule:?}, a = {a}, order {p}: {got} vs quadrature {want}"
                    );
                }
            }
        }
    }
}

#[test]
fn two_d_matches_quadrature_of_the_convolution_up_to_order_4() {
    let (x, y, v) = eta_grid();
    let h = [0.5 * 100.0, 0.5 * 3.0e4];
    let points = [
        [300.0, 7.0e4],  // inside
        [200.0, 5.0e4],  // on a grid node
        [120.0, 9.0e4],  // near two edges
        [60.0, 1.2e5],   // outside, corner region, within h
        [-100.0, 7.0e4], // far outside in a
        [700.0, 1.0e4],  // outside in both, corner region
    ];
    for rule in RULES {
        let map = Map::new_2d(x.clone(), y.clone(), v.clone(), settings(0.5, rule)).unwrap();
        for ab in points {
            let mut out = [0.0; 25];
            map.eval(&ab, [4, 4], &mut out);
            let quadrature = convolve_2d(&x, &y, &v, rule, h, ab);
            for p in 0..=4 {
                for q in 0..=(4 - p) {
                    let got = out[p * 5 + q];
                    let want = quadrature[p][q];
                    let scale = 1.0 / (h[0].powi(p as i32) * h[1].powi(q as i32));
                    assert!(
                        close(got, want, scale, 1e-10),
                        "{rule:?}, {ab:?}, d{p}{q}: {got} vs quadrature {want}"
                    );
                }
            }
        }
    }
}

/// Richardson-extrapolated central difference of `f` at `a` with step `d`.
fn central(f: impl Fn(f64) -> f64, a: f64, d: f64) -> f64 {
    let c = |d: f64| (f(a + d) - f(a - d)) / (2.0 * d);
    (4.0 * c(0.5 * d) - c(d)) / 3.0
}

#[test]
fn one_d_derivatives_match_finite_differences() {
    let (x, v) = curve();
    let h = 0.5 * 0.4;
    for rule in RULES {
        let map = Map::new_1d(x.clone(), v.clone(), settings(0.5, rule)).unwrap();
        for a in points_1d(&x, h) {
            for p in 1..=4 {
                let got = map.partial(&[a], [p, 0]);
                let fd = central(|s| map.partial(&[s], [p - 1, 0]), a, 1e-3 * h);
                let scale = 10.0 / h.powi(p as i32);
                assert!(
                    close(got, fd, scale, 1e-7),
                    "{rule:?}, a = {a}, order {p}: {got} vs {fd}"
                );
            }
        }
    }
}

#[test]
fn two_d_partials_match_finite_differences() {
    let (x, y, v) = eta_grid();
    let h = [50.0, 1.5e4];
    let points = [
        [300.0, 7.0e4],
        [180.0, 4.0e4],
        [90.0, 2.1e4],
        [650.0, 1.1e5],
        [20.0, 0.0],
    ];
    for rule in RULES {
        let map = Map::new_2d(x.clone(), y.clone(), v.clone(), settings(0.5, rule)).unwrap();
        for ab in points {
            for p in 0..=4 {
                for q in 0..=(4 - p) {
                    if p + q == 0 {
                        continue;
                    }
                    let got = map.partial(&ab, [p, q]);
                    // difference along a if p > 0, else along b
                    let fd = if p > 0 {
                        central(|s| map.partial(&[s, ab[1]], [p - 1, q]), ab[0], 1e-3 * h[0])
                    } else {
                        central(|s| map.partial(&[ab[0], s], [p, q - 1]), ab[1], 1e-3 * h[1])
                    };
                    let scale = 1.0 / (h[0].powi(p as i32) * h[1].powi(q as i32));
                    assert!(
                        close(got, fd, scale, 1e-7),
                        "{rule:?}, {ab:?}, d{p}{q}: {got} vs {fd}"
                    );
                }
            }
        }
    }
}

#[test]
fn linear_data_are_reproduced_exactly_away_from_the_edges() {
    let x = vec![-1.0, 0.5, 1.0, 2.5, 4.0];
    let line = |a: f64| 0.3 - 1.7 * a;
    let v: Vec<f64> = x.iter().map(|&a| line(a)).collect();
    for rule in RULES {
        let map = Map::new_1d(x.clone(), v.clone(), settings(0.8, rule)).unwrap();
        let h = 0.8 * 0.5;
        // Under linear (and error) the continuation is the same line, so everywhere; under clamp inside [x0+h, xn−h].
        let span: Vec<f64> = match rule {
            Extrapolate::Clamp => (0..50)
                .map(|k| -1.0 + h + k as f64 * (5.0 - 2.0 * h) / 49.0)
                .collect(),
            _ => (0..50).map(|k| -9.0 + k as f64 * 0.4).collect(),
        };
        for a in span {
            let mut out = [0.0; 4];
            map.eval(&[a], [3, 0], &mut out);
            assert!(
                (out[0] - line(a)).abs() < 1e-14 * (1.0 + line(a).abs()),
                "{rule:?} {a}"
            );
            assert!(
                (out[1] + 1.7).abs() < 1e-13,
                "{rule:?} {a}: slope {}",
                out[1]
            );
            assert!(
                out[2].abs() < 1e-12 && out[3].abs() < 1e-10,
                "{rule:?} {a}: {out:?}"
            );
        }
    }
}

#[test]
fn bilinear_data_are_reproduced_exactly_away_from_the_edges() {
    let x = vec![0.0, 1.0, 3.0, 4.0];
    let y = vec![10.0, 12.0, 13.0];
    let f = |a: f64, b: f64| 2.0 + 0.5 * a - 0.25 * b + 0.125 * a * b;
    let v: Vec<f64> = x
        .iter()
        .flat_map(|&a| y.iter().map(move |&b| f(a, b)))
        .collect();
    let map = Map::new_2d(x, y, v, settings(0.5, Extrapolate::Linear)).unwrap();
    for (a, b) in [
        (0.7, 11.1),
        (2.0, 12.0),
        (-3.0, 20.0),
        (9.0, 5.0),
        (3.9, 12.9),
    ] {
        let mut out = [0.0; 9];
        map.eval(&[a, b], [2, 2], &mut out);
        let want = [
            f(a, b),
            -0.25 + 0.125 * a,
            0.0,
            0.5 + 0.125 * b,
            0.125,
            0.0,
            0.0,
            0.0,
            0.0,
        ];
        for (k, (&g, &w)) in out.iter().zip(&want).enumerate() {
            assert!(
                (g - w).abs() < 1e-12 * (1.0 + w.abs()),
                "({a}, {b}) entry {k}: {g} vs {w}"
            );
        }
    }
}

#[test]
fn clamp_holds_the_edge_values_beyond_the_window() {
    let (x, y, v) = eta_grid();
    let map = Map::new_2d(x, y, v, settings(0.5, Extrapolate::Clamp)).unwrap();
    let mut out = [0.0; 4];
    map.eval(&[10.0, 1.0e3], [1, 1], &mut out);
    assert_eq!(out, [0.70, 0.0, 0.0, 0.0]);
    map.eval(&[1.0e4, 1.0e6], [1, 1], &mut out);
    assert_eq!(out, [0.89, 0.0, 0.0, 0.0]);
}

#[test]
fn plain_linear_interpolation_is_the_interpolant() {
    let (x, y, v) = eta_grid();
    for rule in RULES {
        let s = MapSettings {
            interp: Interp::Linear,
            ..settings(0.5, rule)
        };
        let map = Map::new_2d(x.clone(), y.clone(), v.clone(), s).unwrap();
        for (a, b) in [
            (150.0, 3.0e4),
            (200.0, 5.0e4),
            (50.0, 1.5e5),
            (900.0, 6.0e4),
        ] {
            let want = linear_2d(&x, &y, &v, rule, a, b);
            assert!(
                (map.partial(&[a, b], [0, 0]) - want).abs() < 1e-15,
                "{rule:?} {a} {b}"
            );
        }
        let (cx, cv) = curve();
        let map = Map::new_1d(cx.clone(), cv.clone(), s).unwrap();
        for a in [-1.0, 0.25, 1.2, 3.2, 7.0] {
            let mut out = [0.0; 3];
            map.eval(&[a], [2, 0], &mut out);
            assert!((out[0] - linear_1d(&cx, &cv, rule, a)).abs() < 1e-15);
            assert_eq!(out[2], 0.0);
        }
    }
}

#[test]
fn wide_kernels_on_uneven_grids_use_every_corner_in_the_window() {
    // 40 close points then wide spacing; smooth = 20 puts all the close points in one window (heap scratch).
    let mut x: Vec<f64> = (0..40).map(|k| k as f64 * 0.01).collect();
    x.extend([1.0, 2.0, 3.0]);
    let v: Vec<f64> = x.iter().map(|&a| (3.0 * a).sin()).collect();
    let h = 20.0 * 0.01;
    let map = Map::new_1d(x.clone(), v.clone(), settings(20.0, Extrapolate::Clamp)).unwrap();
    for a in [0.1, 0.2, 0.45, 0.9, 1.1] {
        let mut out = [0.0; 5];
        map.eval(&[a], [4, 0], &mut out);
        for (p, &got) in out.iter().enumerate() {
            let want = convolve_1d(&x, &v, Extrapolate::Clamp, h, p, a);
            assert!(
                close(got, want, 10.0 / h.powi(p as i32), 1e-10),
                "a = {a}, order {p}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn error_rule_reports_the_argument_outside_the_grid() {
    let (x, y, v) = eta_grid();
    let map = Map::new_2d(x, y, v, settings(0.5, Extrapolate::Error)).unwrap();
    assert_eq!(map.outside(&[100.0, 1.0e5]), None);
    assert_eq!(map.outside(&[99.0, 5.0e4]), Some(0));
    assert_eq!(map.outside(&[300.0, 1.0e5 + 1.0]), Some(1));
    assert_eq!(map.outside(&[300.0, f64::NAN]), Some(1));
    let lin = Map::new_1d(vec![0.0, 1.0], vec![0.0, 1.0], MapSettings::default()).unwrap();
    assert_eq!(lin.outside(&[5.0]), None);
}

#[test]
fn bad_data_are_refused() {
    let s = MapSettings::default();
    let err = |r: Result<Map, MapError>| r.unwrap_err();
    assert!(matches!(
        err(Map::new_1d(vec![1.0], vec![1.0], s)),
        MapError::TooFewPoints { .. }
    ));
    assert!(matches!(
        err(Map::new_1d(vec![0.0, 2.0, 2.0], vec![1.0; 3], s)),
        MapError::NotIncreasing { index: 2, .. }
    ));
    assert!(matches!(
        err(Map::new_1d(vec![0.0, 1.0], vec![1.0, f64::NAN], s)),
        MapError::NonFiniteValue { index: 1, .. }
    ));
    assert!(matches!(
        err(Map::new_2d(vec![0.0, 1.0], vec![0.0, 1.0], vec![1.0; 3], s)),
        MapError::Shape {
            expected: 4,
            got: 3
        }
    ));
    let bad = MapSettings { smooth: 0.0, ..s };
    assert!(matches!(
        err(Map::new_1d(vec![0.0, 1.0], vec![1.0; 2], bad)),
        MapError::Smooth(_)
    ));
    let mut ok = Map::new_1d(vec![0.0, 1.0], vec![1.0; 2], s).unwrap();
    assert!(ok.set_values(vec![1.0]).is_err());
    ok.set_values(vec![2.0, 4.0]).unwrap();
    assert_eq!(ok.partial(&[0.5], [0, 0]), 3.0);
}

#[test]
fn partials_from_the_one_pass_memo_equal_fresh_evaluations() {
    let (x, y, v) = eta_grid();
    let mut map = Map::new_2d(x, y, v, settings(0.5, Extrapolate::Linear)).unwrap();
    let ab = [310.0, 6.1e4];
    let mut full = [0.0; 16];
    map.eval(&ab, [3, 3], &mut full);
    // Orders ≤ 2 come from the memo after the first call, higher ones are evaluated each time.
    for _ in 0..2 {
        for p in 0..=3 {
            for q in 0..=3 {
                assert_eq!(
                    map.partial(&ab, [p, q]).to_bits(),
                    full[p * 4 + q].to_bits(),
                    "d{p}{q}"
                );
            }
        }
    }
    // New data, new memo key.
    let doubled: Vec<f64> = map.values().iter().map(|v| 2.0 * v).collect();
    map.set_values(doubled).unwrap();
    assert_eq!(map.partial(&ab, [0, 0]), 2.0 * full[0]);
    let (cx, cv) = curve();
    let c = Map::new_1d(cx, cv, settings(0.5, Extrapolate::Clamp)).unwrap();
    let mut out = [0.0; 3];
    c.eval(&[1.2], [2, 0], &mut out);
    for (k, &want) in out.iter().enumerate() {
        assert_eq!(c.partial(&[1.2], [k, 0]), want);
        assert_eq!(
            c.partial(&[1.2], [k, 7]),
            want,
            "1-D: the second order is ignored"
        );
    }
}

/// Orders up to 2 per argument take the fast path (fixed arrays, corner terms from one table look-up);
/// higher orders the general one. Both give the same numbers for orders ≤ 2 at points inside, on the grid,
/// near and beyond the edges, for every rule, 1-D and 2-D, with one corner in the window (smooth ≤ 0.5).
#[test]
fn the_fast_path_equals_the_general_path() {
    let (cx, cv) = curve();
    let (x, y, v) = eta_grid();
    for rule in RULES {
        for smooth in [0.5, 0.3] {
            let s = settings(smooth, rule);
            let m1 = Map::new_1d(cx.clone(), cv.clone(), s).unwrap();
            for a in points_1d(&cx, smooth * 0.4) {
                let (mut fast, mut general) = ([0.0; 3], [0.0; 4]);
                m1.eval(&[a], [0, 0], &mut fast);
                m1.eval(&[a], [0, 0], &mut general);
                for n in 0..3 {
                    assert_eq!(
                        fast[n].to_bits(),
                        general[n].to_bits(),
                        "1-D {rule:?} a={a} n={n}"
                    );
                }
            }
            let m2 = Map::new_2d(x.clone(), y.clone(), v.clone(), s).unwrap();
            for a in points_1d(&x, smooth * 100.0) {
                for b in points_1d(&y, smooth * 3.0e4) {
                    let (mut fast, mut general) = ([0.0; 9], [0.0; 16]);
                    m2.eval(&[a, b], [2, 2], &mut fast);
                    m2.eval(&[a, b], [3, 3], &mut general);
                    for p in 0..3 {
                        for q in 0..3 {
                            assert_eq!(
                                fast[p * 3 + q].to_bits(),
                                general[p * 4 + q].to_bits(),
                                "2-D {rule:?} ({a}, {b}) d{p}{q}"
                            );
                        }
                    }
                }
            }
        }
    }
}
