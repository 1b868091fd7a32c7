//! Lookup maps as expression nodes (contract §6): parse/print round trip, derivative maps by the chain rule,
//! the zero test never taking a map (or a derivative map of constant data) for zero, and evaluation by the
//! pool and the tape against the kernel's map.

use invsim_expr::map::{Map, MapSettings};
use invsim_expr::{zero_test, MapDecl, Pool, Tape};
use std::collections::HashMap;
use std::sync::Arc;

fn pool_with_maps(constant: bool) -> Pool {
    let mut pool = Pool::new();
    let x = vec![100.0, 200.0, 400.0, 600.0];
    let y = vec![2.0e4, 5.0e4, 1.0e5];
    let v = if constant {
        vec![0.8; 12]
    } else {
        vec![
            0.70, 0.75, 0.80, 0.78, 0.83, 0.86, 0.82, 0.88, 0.90, 0.80, 0.86, 0.89,
        ]
    };
    let eta = Map::new_2d(x, y, v, MapSettings::default()).unwrap();
    pool.declare_map(MapDecl::new("eta", Arc::new(eta)));
    let c = Map::new_1d(
        vec![0.0, 1.0, 3.0],
        vec![1.0, 2.0, 0.5],
        MapSettings::default(),
    )
    .unwrap();
    pool.declare_map(MapDecl::new("c", Arc::new(c)));
    pool
}

#[test]
fn map_calls_print_and_parse_back() {
    let mut pool = pool_with_maps(false);
    for src in [
        "eta(w*k, p) + c(w)",
        "eta_d10(w, p)*c_d3(2*w)",
        "eta_d02(p, w)^2",
    ] {
        let e = pool.parse(src).unwrap();
        let printed = pool.display(e);
        let again = pool.parse(&printed).unwrap();
        assert_eq!(e, again, "{src} → {printed}");
    }
    let e = pool.parse("eta_d11(w, p)").unwrap();
    assert_eq!(pool.display(e), "eta_d11(w, p)");
    let err = pool.parse("eta(w)").unwrap_err();
    assert!(err.message.contains("takes 2 arguments"), "{}", err.message);
    let err = pool.parse("c + 1").unwrap_err();
    assert!(err.message.contains("must be called"), "{}", err.message);
    assert!(pool.parse("c_d0(w)").is_err());
    assert!(pool.parse("eta_d1(w, p)").is_err());
}

#[test]
fn derivatives_are_derivative_maps() {
    let mut pool = pool_with_maps(false);
    let e = pool.parse("eta(w^2, p*w)").unwrap();
    let w = pool.symbol("w");
    let d = pool.diff(e, w);
    let want = pool
        .parse("2*w*eta_d10(w^2, p*w) + p*eta_d01(w^2, p*w)")
        .unwrap();
    assert_eq!(d, want, "{}", pool.display(d));
    let e = pool.parse("c_d2(3*w)").unwrap();
    let d = pool.diff(e, w);
    assert_eq!(pool.display(d), "3*c_d3(3*w)");
}

#[test]
fn the_zero_test_never_assumes_a_map_zero() {
    // Constant data: every derivative map vanishes numerically, but not as a symbol (the data can be
    // replaced at run time).
    let mut pool = pool_with_maps(true);
    let nominal = HashMap::new();
    for src in [
        "eta_d10(w, p)",
        "eta_d02(w, p) - eta_d20(w, p)",
        "c_d1(w)",
        "eta(w, p) - 0.8",
    ] {
        let e = pool.parse(src).unwrap();
        assert!(!zero_test(&mut pool, e, &nominal).is_zero(), "{src}");
    }
    // A real identity through maps is still recognised.
    let e = pool.parse("eta(w, p)*c(w) - c(w)*eta(w, p)").unwrap();
    assert!(zero_test(&mut pool, e, &nominal).is_zero());
    let e = pool
        .parse("(eta(w, p) + 1)^2 - eta(w, p)^2 - 2*eta(w, p) - 1")
        .unwrap();
    assert!(zero_test(&mut pool, e, &nominal).is_zero());
}

#[test]
fn pool_and_tape_evaluate_the_kernel_map() {
    let mut pool = pool_with_maps(false);
    let e = pool
        .parse("eta_d10(w, p) + 2*eta(w, p)*c_d1(w/200)")
        .unwrap();
    let (w, p) = (pool.symbol("w"), pool.symbol("p"));
    let eta = pool.map_decl(pool.find_map("eta").unwrap()).data.clone();
    let c = pool.map_decl(pool.find_map("c").unwrap()).data.clone();
    let tape = Tape::compile(&pool, &[e], &[w, p]).unwrap();
    for (wv, pv) in [(150.0, 3.0e4), (410.0, 9.0e4), (20.0, 2.0e5)] {
        let want = eta.partial(&[wv, pv], [1, 0])
            + 2.0 * eta.partial(&[wv, pv], [0, 0]) * c.partial(&[wv / 200.0], [1, 0]);
        let values = HashMap::from([(w, wv), (p, pv)]);
        let by_pool = pool.eval(e, &values).unwrap();
        let mut out = [0.0];
        tape.eval(&[wv, pv], &mut out);
        assert!(
            (by_pool - want).abs() <= 1e-15 * want.abs().max(1.0),
            "{by_pool} vs {want}"
        );
        assert!(
            (out[0] - want).abs() <= 1e-15 * want.abs().max(1.0),
            "{} vs {want}",
            out[0]
        );
        let (wc, pc) = ([wv], [pv]);
        let mut col = [0.0];
        tape.eval_batch(&[&wc, &pc], &mut [&mut col]);
        assert_eq!(col[0], out[0]);
    }
}

#[test]
fn latex_marks_the_derivative_orders() {
    let mut pool = pool_with_maps(false);
    let e = pool.parse("eta_d10(w, p)").unwrap();
    let l = pool.latex(e);
    assert!(l.contains("\\mathrm{eta}^{(1,0)}"), "{l}");
}

#[test]
fn the_batch_evaluator_equals_the_point_by_point_tape_bit_for_bit() {
    // Map calls sharing arguments (one `partials2_batch` per block), a map of a map, an order-3 partial (point
    // by point), over 150 points (two full blocks and a short one), inside the grid, at its nodes and outside.
    let mut pool = pool_with_maps(false);
    let src = "eta(w, p) + w*eta_d10(w, p) - eta_d02(w, p)*eta_d11(w, p) + c(eta(w, p)) \
               + c_d2(w/200)*c_d1(w/200) + eta_d30(w, p) + c_d3(w/300)";
    let e = pool.parse(src).unwrap();
    let (w, p) = (pool.symbol("w"), pool.symbol("p"));
    let tape = Tape::compile(&pool, &[e], &[w, p]).unwrap();
    let n = 150;
    let wc: Vec<f64> = (0..n).map(|k| 20.0 + 5.0 * k as f64).collect();
    let pc: Vec<f64> = (0..n).map(|k| 1.0e4 + 800.0 * k as f64).collect();
    let mut col = vec![0.0; n];
    tape.eval_batch(&[&wc, &pc], &mut [&mut col]);
    for k in 0..n {
        let mut out = [0.0];
        tape.eval(&[wc[k], pc[k]], &mut out);
        assert_eq!(
            col[k].to_bits(),
            out[0].to_bits(),
            "point {k}: {} vs {}",
            col[k],
            out[0]
        );
    }
}

#[test]
fn lone_values_of_a_2d_map_in_the_batch_evaluator_equal_the_point_by_point_tape() {
    // Two lone value calls of a 2-D map at different arguments (each a block at a time by `values_batch`) and
    // a 1-D map, over 150 points inside the grid, at its nodes and outside.
    let mut pool = pool_with_maps(false);
    let e = pool.parse("eta(w, p)*w + c(w/200) - eta(2*w, p)").unwrap();
    let (w, p) = (pool.symbol("w"), pool.symbol("p"));
    let tape = Tape::compile(&pool, &[e], &[w, p]).unwrap();
    let n = 150;
    let wc: Vec<f64> = (0..n).map(|k| 20.0 + 5.0 * k as f64).collect();
    let pc: Vec<f64> = (0..n).map(|k| 1.0e4 + 800.0 * k as f64).collect();
    let mut col = vec![0.0; n];
    tape.eval_batch(&[&wc, &pc], &mut [&mut col]);
    for k in 0..n {
        let mut out = [0.0];
        tape.eval(&[wc[k], pc[k]], &mut out);
        assert_eq!(col[k].to_bits(), out[0].to_bits(), "point {k}");
    }
}
