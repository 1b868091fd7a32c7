//! `si_engine_maps` (a volumetric-efficiency map inside the dynamics, a BSFC map for an output) on the NEDC:
//! the inverse satisfies the model's equations at every sample (1e-8 relative), the replay tracks, a constant
//! eta_vol map gives si_engine's results (with s_i = that constant, y_i = 0) within 1e-9, and the compiled and
//! the interpreted model agree (1e-12 relative on every closed-form function at the run's points); the block
//! inverse (`invert_batch`, Newton from sample to sample) is the point-by-point inverse bit for bit, and the
//! NEDC run's numbers are those of the code before it (a checksum of their bits).

use invsim_inversion::{Derivation, Interpreter, Model};
use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, SimulationOptions, SimulationResult};
use std::path::PathBuf;

fn compiled(name: &str) -> Box<dyn InverseModel> {
    invsim_models::builtin(name).expect("built-in model")
}

fn run(model: &dyn InverseModel, verify: bool) -> SimulationResult {
    let cycle = Cycle::builtin("nedc").expect("built-in cycle");
    let opts = SimulationOptions::builder()
        .verify(verify)
        .keep_series(true)
        .build()
        .expect("options");
    simulate(model, &cycle, &opts).expect("the run succeeds")
}

fn col<'a>(r: &'a SimulationResult, name: &str) -> &'a [f64] {
    r.column(name).unwrap_or_else(|| panic!("column {name}"))
}

#[test]
fn the_inverse_satisfies_the_model_equations_at_every_sample() {
    let m = compiled("si_engine_maps");
    let r = run(m.as_ref(), true);
    let (v, p, u) = (col(&r, "v"), col(&r, "p_i"), col(&r, "m_at"));
    let (y0, y1, y2) = (col(&r, "yd_0"), col(&r, "yd_1"), col(&r, "yd_2"));
    let mut dx = [0.0; 2];
    for k in 0..v.len() {
        let x = [v[k], p[k]];
        // y = h(x), y' = L_f h = dv/dt of the original equations, y'' = α + β u.
        assert!(
            (m.h(&x, &[]) - y0[k]).abs() <= 1e-8 * y0[k].abs().max(1.0),
            "h at sample {k}"
        );
        m.rhs(&x, &[], u[k], &mut dx);
        assert!(
            (dx[0] - y1[k]).abs() <= 1e-8 * y1[k].abs().max(1.0),
            "dv/dt at {k}: {} vs {}",
            dx[0],
            y1[k]
        );
        let xi = [y0[k], y1[k]];
        let (a, b) = (m.alpha(&xi, &[], &[]), m.beta(&xi, &[], &[]));
        let scale = a.abs() + (b * u[k]).abs() + y2[k].abs();
        // Relative to the terms, at least 1 m/s² (at standstill α and βu cancel to rounding of O(1) terms).
        assert!(
            (a + b * u[k] - y2[k]).abs() <= 1e-8 * scale.max(1.0),
            "y'' at {k}: {a} + {b}·{}",
            u[k]
        );
    }
    let err = r
        .summary
        .max_abs_tracking_error
        .expect("--verify gives the tracking error");
    assert!(err < 1e-3, "replay tracking error {err} m/s");
}

#[test]
fn a_constant_eta_vol_map_is_si_engine_with_the_constant_charge_slope() {
    let c = 0.85;
    let mut maps = compiled("si_engine_maps");
    let x: Vec<f64> = vec![0.0, 400.0, 800.0];
    let y: Vec<f64> = vec![0.0, 1.0e5];
    maps.set_map("eta_vol", (&x, Some(&y), &[c; 6]))
        .expect("eta_vol is a 2-D map");
    let mut si = compiled("si_engine");
    si.set_param("s_i", c).unwrap();
    si.set_param("y_i", 0.0).unwrap();
    let (a, b) = (run(maps.as_ref(), false), run(si.as_ref(), false));
    for name in ["m_at", "v", "p_i", "fuel", "T_e"] {
        let (ca, cb) = (col(&a, name), col(&b, name));
        let scale = cb.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for (k, (p, q)) in ca.iter().zip(cb).enumerate() {
            assert!(
                (p - q).abs() <= 1e-9 * scale,
                "{name} at sample {k}: {p} vs {q}"
            );
        }
    }
    let (fa, fb) = (
        a.summary.totals.integrals["fuel"],
        b.summary.totals.integrals["fuel"],
    );
    assert!((fa - fb).abs() <= 1e-9 * fb, "{fa} vs {fb}");
}

fn interpreted() -> Interpreter {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine_maps.toml");
    let d = Derivation::new(Model::from_path(&path).expect("model")).expect("derivation");
    Interpreter::new(&d).expect("interpreter")
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(1e-300)
}

#[test]
fn compiled_and_interpreted_agree() {
    let (c, i) = (compiled("si_engine_maps"), interpreted());
    let r = run(c.as_ref(), false);
    let (v, p, u) = (col(&r, "v"), col(&r, "p_i"), col(&r, "m_at"));
    let n_out = c.info().outputs.len();
    let (mut oc, mut oi) = (vec![0.0; n_out], vec![0.0; n_out]);
    // Each quantity relative to its largest magnitude over the run (values that cancel to ~0 at standstill
    // carry the rounding of their O(1) terms).
    let mut scale = vec![0.0_f64; 4 + n_out];
    let mut rows: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    for k in (0..v.len()).step_by(7) {
        let x = [v[k], p[k]];
        let (mut dc, mut di) = ([0.0; 2], [0.0; 2]);
        c.rhs(&x, &[], u[k], &mut dc);
        i.rhs(&x, &[], u[k], &mut di);
        c.outputs(&x, &[], u[k], &mut oc);
        i.outputs(&x, &[], u[k], &mut oi);
        let (mut xc, mut xi_) = ([0.0; 2], [0.0; 2]);
        c.psi(&x, &[], &mut xc, &mut []);
        i.psi(&x, &[], &mut xi_, &mut []);
        let a: Vec<f64> = dc.iter().chain(&xc).chain(&oc).copied().collect();
        let b: Vec<f64> = di.iter().chain(&xi_).chain(&oi).copied().collect();
        for (s, x) in scale.iter_mut().zip(&a) {
            *s = s.max(x.abs());
        }
        rows.push((a, b));
        // Through Newton's method (tolerance 1e-13 on ψ): α and β agree to the solver's accuracy.
        let xi = [xc[0], xc[1]];
        let (ac, ai) = (c.alpha(&xi, &[], &[]), i.alpha(&xi, &[], &[]));
        let (bc, bi) = (c.beta(&xi, &[], &[]), i.beta(&xi, &[], &[]));
        assert!(close(bc, bi, 1e-10), "β at {k}: {bc} vs {bi}");
        assert!(
            (ac - ai).abs() <= 1e-10 * (ac.abs().max(1.0)),
            "α at {k}: {ac} vs {ai}"
        );
    }
    for (k, (a, b)) in rows.iter().enumerate() {
        for (j, ((x, y), s)) in a.iter().zip(b).zip(&scale).enumerate() {
            assert!(
                (x - y).abs() <= 1e-12 * s,
                "point {k}, quantity {j}: {x} vs {y} (scale {s})"
            );
        }
    }
}

#[test]
fn the_map_option_replaces_data_in_both_engines_alike() {
    let (mut c, mut i) = (compiled("si_engine_maps"), interpreted());
    let x = [0.0, 300.0, 900.0];
    let y = [0.0, 5.0e4, 1.2e5];
    let values = [0.6, 0.7, 0.8, 0.65, 0.8, 0.9, 0.6, 0.75, 0.85];
    for m in [c.as_mut() as &mut dyn InverseModel, &mut i] {
        m.set_map("eta_vol", (&x, Some(&y), &values)).unwrap();
        assert!(
            m.set_map("eta_vol", (&x, None, &values[..3])).is_err(),
            "arity is kept"
        );
        assert!(m.set_map("nope", (&x, None, &values[..3])).is_err());
    }
    let mut dc = [0.0; 2];
    let mut di = [0.0; 2];
    c.rhs(&[12.0, 4.0e4], &[], 0.01, &mut dc);
    i.rhs(&[12.0, 4.0e4], &[], 0.01, &mut di);
    assert!(close(dc[1], di[1], 1e-12), "{} vs {}", dc[1], di[1]);
}

/// FNV-1a over the bits of `columns`, sample by sample (the checksum of a run's numbers, bit for bit).
fn bits_checksum(columns: &[&[f64]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for k in 0..columns[0].len() {
        for c in columns {
            h = (h ^ c[k].to_bits()).wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

/// The compiled model's block path (`invert_batch`: Newton from sample to sample, ψ and its Jacobian at the
/// previous solution reused) against the point-by-point inverse (`invert`, i.e. `psi_inv` then α and β), bit
/// for bit, along the NEDC and from guesses far from the solution.
#[test]
fn the_block_inverse_is_the_pointwise_inverse_bit_for_bit() {
    let m = compiled("si_engine_maps");
    let r = run(m.as_ref(), false);
    let (y0, y1, y2) = (col(&r, "yd_0"), col(&r, "yd_1"), col(&r, "yd_2"));
    let starts: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 1.0], [30.0, 1.0e5], [5.0, 2.0e4]];
    // Blocks of several lengths, each from its own first guess.
    let mut k0 = 0;
    for (b, len) in [1usize, 2, 7, 64, 255, 256, 1000, 4096]
        .iter()
        .cycle()
        .enumerate()
    {
        if k0 >= y0.len() {
            break;
        }
        let k1 = (k0 + len).min(y0.len());
        let guess = starts[b % starts.len()];
        let (mut xs, mut ps, mut us) = (
            vec![0.0; k1 - k0],
            vec![0.0; k1 - k0],
            vec![f64::NAN; k1 - k0],
        );
        xs[0] = guess[0];
        ps[0] = guess[1];
        {
            let mut x: [&mut [f64]; 2] = [&mut xs, &mut ps];
            m.invert_batch(
                &[&y0[k0..k1], &y1[k0..k1]],
                &[],
                &[],
                &y2[k0..k1],
                &mut x,
                &mut us,
            )
            .expect("the block inverse succeeds");
        }
        let mut x = guess.to_vec();
        for k in k0..k1 {
            let u = m
                .invert(&[y0[k], y1[k]], &[], &[], y2[k], &mut x)
                .expect("the inverse succeeds");
            let i = k - k0;
            assert_eq!(u.to_bits(), us[i].to_bits(), "u at {k}: {u} vs {}", us[i]);
            assert_eq!(x[0].to_bits(), xs[i].to_bits(), "v at {k}");
            assert_eq!(x[1].to_bits(), ps[i].to_bits(), "p_i at {k}");
        }
        k0 = k1;
    }
}

/// A point whose Newton iteration fails stops the block there with that point's index and the error of
/// the point-by-point inverse; the points before it are written.
#[test]
fn the_block_inverse_reports_the_first_failing_point() {
    let m = compiled("si_engine_maps");
    let xi0 = [1.0, 2.0, 3.0, f64::NAN, 5.0];
    let xi1 = [0.1, 0.2, 0.3, 0.4, 0.5];
    let yr = [0.0; 5];
    let (mut v, mut p, mut u) = (
        [10.0, 0.0, 0.0, 0.0, 0.0],
        [5.0e4, 0.0, 0.0, 0.0, 0.0],
        [f64::NAN; 5],
    );
    let err = {
        let mut x: [&mut [f64]; 2] = [&mut v, &mut p];
        m.invert_batch(&[&xi0, &xi1], &[], &[], &yr, &mut x, &mut u)
            .expect_err("NaN has no inverse")
    };
    assert_eq!(err.0, 3);
    let mut x = vec![10.0, 5.0e4];
    for k in 0..3 {
        let uk = m
            .invert(&[xi0[k], xi1[k]], &[], &[], yr[k], &mut x)
            .expect("finite points invert");
        assert_eq!(
            (uk.to_bits(), x[0].to_bits(), x[1].to_bits()),
            (u[k].to_bits(), v[k].to_bits(), p[k].to_bits())
        );
    }
    let scalar = m
        .invert(&[xi0[3], xi1[3]], &[], &[], yr[3], &mut x)
        .expect_err("NaN has no inverse");
    assert_eq!(err.1.to_string(), scalar.to_string());
}

/// The run on the NEDC (dt = 0.1 s) gives the numbers of the code before the block inverse, bit for bit:
/// the checksum of its input and states as `invsim simulate models/si_engine_maps.toml --cycle nedc --out …`
/// of that code wrote them (11 801 samples, FNV-1a over the bits of m_at, v, p_i per sample).
#[test]
fn the_nedc_run_is_bit_for_bit_the_earlier_one() {
    let m = compiled("si_engine_maps");
    let r = run(m.as_ref(), false);
    let columns = [col(&r, "m_at"), col(&r, "v"), col(&r, "p_i")];
    assert_eq!(columns[0].len(), 11_801);
    assert_eq!(bits_checksum(&columns), 0x0d98_9a1c_33c4_ea6f);
}

/// The plot's engine map (`[engine] map = "bsfc(n_e*pi/30, T_e)"`) is the BSFC map itself at the operating
/// point, evaluated through the map the model holds, with either engine; `--map` reaches it.
#[test]
fn the_engine_map_layer_is_the_bsfc_map_at_the_operating_point() {
    use invsim_runtime::plot::MapLayer;
    let interpreted: Box<dyn InverseModel> = Box::new(interpreted());
    for m in [compiled("si_engine_maps"), interpreted] {
        let layer = MapLayer::of(m.as_ref())
            .expect("layer")
            .expect("the model has an engine map");
        assert_eq!(layer.label, "bsfc(n_e*pi/30, T_e) (g/kWh)");
        assert_eq!(layer.range, Some([250.0, 450.0]));
        let bsfc = m
            .maps()
            .iter()
            .find(|k| k.name() == "bsfc")
            .expect("bsfc map");
        for (n, t) in [(1200.0, 40.0), (3000.0, 95.5), (5500.0, 170.0)] {
            let mut want = [0.0];
            bsfc.eval(&[n * std::f64::consts::PI / 30.0, t], [0, 0], &mut want);
            let got = layer.eval(n, t);
            assert!(
                (got - want[0]).abs() <= 1e-12 * want[0].abs(),
                "{n} rpm {t} N m: {got} vs {}",
                want[0]
            );
            assert!(
                want[0] > 200.0 && want[0] < 1000.0,
                "a BSFC in g/kWh: {}",
                want[0]
            );
        }
    }
    // A replaced map reaches the layer: doubled values, doubled map.
    let mut m = compiled("si_engine_maps");
    let before = MapLayer::of(m.as_ref())
        .unwrap()
        .unwrap()
        .eval(3000.0, 95.5);
    let bsfc = m
        .maps()
        .iter()
        .find(|k| k.name() == "bsfc")
        .unwrap()
        .clone();
    let doubled: Vec<f64> = bsfc.values().iter().map(|v| 2.0 * v).collect();
    m.set_map("bsfc", (bsfc.x(), bsfc.y(), &doubled))
        .expect("set_map");
    let after = MapLayer::of(m.as_ref())
        .unwrap()
        .unwrap()
        .eval(3000.0, 95.5);
    assert!(
        (after - 2.0 * before).abs() <= 1e-9 * before,
        "{after} vs 2 × {before}"
    );
}
