//! A map's grid-value weights (`Map::weights`): Σ weight · value equals the map's partial derivative of every
//! order up to 2 per argument, at points inside, at and outside the grid, 1-D and 2-D, smooth and plain,
//! under `linear` and `clamp` extrapolation; the weights are local (only grid values near the point).

use crate::common::Lcg;
use invsim_kernel::map::{Extrapolate, Interp, Map, MapSettings};

/// Uneven grids (the smooth map's kernel window then spans different numbers of corners) and values without
/// structure.
fn maps(rule: Extrapolate, interp: Interp) -> [Map; 2] {
    let s = MapSettings {
        smooth: 0.8,
        extrapolate: rule,
        interp,
    };
    let x = vec![0.0, 1.0, 1.5, 3.0, 3.4, 6.0];
    let y = vec![-2.0, 0.5, 1.0, 4.0];
    let v: Vec<f64> = (0..24)
        .map(|k| ((k * 37) % 11) as f64 * 0.3 - 1.1)
        .collect();
    [
        Map::new_1d(x.clone(), v[..6].to_vec(), s).expect("valid"),
        Map::new_2d(x, y, v, s).expect("valid"),
    ]
}

/// Points drawn uniformly from a range 3 units wider than each grid on both sides.
fn points(n: usize) -> Vec<[f64; 2]> {
    let mut rng = Lcg(7);
    (0..n)
        .map(|_| [-3.0 + 12.0 * rng.next(), -5.0 + 12.0 * rng.next()])
        .collect()
}

#[test]
fn weights_give_every_partial_derivative() {
    let mut w = Vec::new();
    let mut checked = 0;
    for rule in [Extrapolate::Linear, Extrapolate::Clamp] {
        for interp in [Interp::Smooth, Interp::Linear] {
            for map in maps(rule, interp) {
                let two_d = map.arity() == 2;
                let scale = map.values().iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                for p in points(300) {
                    let args = &p[..map.arity()];
                    for i in 0..=2 {
                        for j in 0..=(if two_d { 2 } else { 0 }) {
                            map.weights(args, [i, j], &mut w);
                            let got: f64 = w.iter().map(|&(k, c)| c * map.values()[k]).sum();
                            let want = map.partial(args, [i, j]);
                            // The derivatives scale with the spacing's inverse powers (at most 1/(0.4·0.8)²).
                            let tol = 1e-12 * scale * 10f64.powi((i + j) as i32);
                            assert!(
                                (got - want).abs() <= tol,
                                "{rule:?} {interp:?} {}-D at {args:?}, orders [{i}, {j}]: {got} vs {want}",
                                map.arity()
                            );
                            let mut seen: Vec<usize> = w.iter().map(|e| e.0).collect();
                            seen.sort_unstable();
                            seen.dedup();
                            assert_eq!(seen.len(), w.len(), "each index once");
                            checked += 1;
                        }
                    }
                }
            }
        }
    }
    assert_eq!(checked, 2 * 2 * 300 * (3 + 9));
}

/// Plain interpolation inside the grid: the two (four) corner values of the point's cell, with the
/// interpolation weights; a smooth map's weights reach no further than its kernel's half-width plus a cell.
#[test]
fn weights_are_local() {
    let [one, two] = maps(Extrapolate::Linear, Interp::Linear);
    let mut w = Vec::new();
    one.weights(&[1.25], [0, 0], &mut w);
    assert_eq!(w, [(1, 0.5), (2, 0.5)]);
    one.weights(&[1.25], [1, 0], &mut w);
    assert_eq!(w, [(1, -2.0), (2, 2.0)]);
    two.weights(&[3.1, 0.75], [0, 0], &mut w);
    let nonzero: Vec<usize> = w.iter().filter(|e| e.1 != 0.0).map(|e| e.0).collect();
    assert_eq!(nonzero, [3 * 4 + 1, 3 * 4 + 2, 4 * 4 + 1, 4 * 4 + 2]);
    assert!((w.iter().map(|e| e.1).sum::<f64>() - 1.0).abs() < 1e-15);
    let [smooth, _] = maps(Extrapolate::Linear, Interp::Smooth);
    // h = 0.8 · 0.4 = 0.32 around a = 3.2: corners 3.0 and 3.4 are within it, 1.5 and 6.0 are not.
    smooth.weights(&[3.2], [0, 0], &mut w);
    let idx: Vec<usize> = w.iter().map(|e| e.0).collect();
    assert_eq!(idx, [2, 3, 4, 5]);
    one.weights(&[f64::NAN], [0, 0], &mut w);
    assert!(w.len() == 6 && w.iter().all(|e| e.1.is_nan()));
}
