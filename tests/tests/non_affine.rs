//! Models whose right-hand side is not affine in the input (contract §5), solved for u by isolation and by
//! Newton's method, each checked against the original equations at every sample of a run: with h = v and
//! r = 1, dv/dt = rhs_v(x, u) must equal y_d' (the smoother's exact derivative), and the internal state's
//! integration must follow rhs_η(x, u) (central differences of its samples).

use invsim_inversion::{Derivation, Interpreter, Model};
use invsim_model_api::InverseModel;
use invsim_runtime::{simulate, Cycle, SimulationOptions};
use std::path::Path;

/// u enters through sinh: isolated as u = 1000·asinh(…) (written with log and sqrt).
const ISOLATED: &str = r#"
name = "isolated"
[parameters]
m = 1000.0
c = 0.5
k = 2000.0
[states]
v = { rhs = "(k*sinh(F/1000) - c*v^2)/m" }
[input]
name = "F"
[output]
name = "v"
h = "v"
"#;

/// u + 1e-6·u³ cannot be isolated: Newton's method; an energy integrator as internal state.
const NEWTON: &str = r#"
name = "newton"
[parameters]
m = 1000.0
c = 0.5
[states]
v = { rhs = "(F + 1e-6*F^3 - c*v^2)/m" }
E = { rhs = "(F + 1e-6*F^3)*v/3.6e6 + 0.01*F^2/3.6e6", initial = 0.0 }
[input]
name = "F"
[output]
name = "v"
h = "v"
"#;

fn derive(text: &str) -> Derivation {
    Derivation::new(Model::from_str(Path::new("m.toml"), text).unwrap()).unwrap()
}

/// The worst residual of dv/dt = rhs_v(x, u) against y_d', relative to 1 + |y_d'|, and of the internal
/// states' central differences against their rhs, relative to their peak rate.
fn residuals(d: &Derivation) -> (f64, f64) {
    let interp = Interpreter::new(d).unwrap();
    let cycle = Cycle::builtin("udds").unwrap();
    let dt = 0.05;
    let opts = SimulationOptions {
        dt,
        verify: true,
        engine: "interpreted".into(),
        ..SimulationOptions::default()
    };
    let res = simulate(&interp, &cycle, &opts).unwrap();
    assert!(res.summary.max_abs_tracking_error.unwrap() < 1e-3);
    let n = d.n();
    let cols: Vec<&[f64]> = d
        .model
        .states
        .iter()
        .map(|s| res.column(&s.name).unwrap())
        .collect();
    let (u, yd1) = (res.input(), res.yd(1).unwrap());
    let mut dx = vec![0.0; n];
    let (mut worst_v, mut worst_eta, mut peak) = (0.0f64, 0.0f64, 0.0f64);
    let mut rates = Vec::new();
    for k in 0..res.len() {
        let x: Vec<f64> = cols.iter().map(|c| c[k]).collect();
        interp.rhs(&x, &[], u[k], &mut dx);
        worst_v = worst_v.max((dx[0] - yd1[k]).abs() / (1.0 + yd1[k].abs()));
        if n > 1 {
            peak = peak.max(dx[1].abs());
            rates.push(dx[1]);
        }
    }
    if n > 1 {
        for k in 1..res.len() - 1 {
            let fd = (cols[1][k + 1] - cols[1][k - 1]) / (2.0 * dt);
            worst_eta = worst_eta.max((fd - rates[k]).abs() / peak);
        }
    }
    (worst_v, worst_eta)
}

#[test]
fn an_isolated_input_satisfies_the_original_equations() {
    let d = derive(ISOLATED);
    assert!(!d.affine);
    let json = d.to_json();
    assert_eq!(json["affine"], false);
    assert!(
        json["input_solution"].is_string(),
        "{}",
        json["input_solution"]
    );
    let (v, _) = residuals(&d);
    assert!(v < 1e-9, "dv/dt residual {v:e}");
}

#[test]
fn an_input_solved_by_newton_satisfies_the_original_equations() {
    let d = derive(NEWTON);
    assert!(!d.affine && d.input_solution.is_none());
    let json = d.to_json();
    assert!(json["input_solution"].is_null());
    // The zero dynamics contain the input (evaluated at the Newton solution).
    assert!(json["zero_dynamics"][0].as_str().unwrap().contains('F'));
    let (v, eta) = residuals(&d);
    assert!(v < 1e-9, "dv/dt residual {v:e}");
    // Central differences at dt = 0.05 s: O(dt²) of the rate's second derivative.
    assert!(eta < 1e-3, "dE/dt residual {eta:e}");
}

/// ψ⁻¹ through a lookup map (Newton's method for the actuator state) and a y^(r) not affine in the input,
/// isolated (`nonaffine_map_isolated`, a battery-like square root) or by Newton's method
/// (`nonaffine_map_newton`, u + b·u³): the inverse satisfies the original equations, dv/dt = y_d' and the
/// actuator state's central differences follow its rhs(x, u).
#[test]
fn a_numeric_psi_inv_with_a_non_affine_input_satisfies_the_original_equations() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (name, isolated) in [
        ("nonaffine_map_isolated", true),
        ("nonaffine_map_newton", false),
    ] {
        let file = root.join(format!("models/{name}.toml"));
        let d = invsim_inversion::derive_file(&file).unwrap();
        assert!(!d.psi_inv_closed() && !d.yr_affine, "{name}");
        assert_eq!(d.input_solution_x.is_some(), isolated, "{name}");
        let (v, p) = residuals(&d);
        assert!(v < 1e-9, "{name}: dv/dt residual {v:e}");
        assert!(p < 1e-3, "{name}: dp/dt residual {p:e}");
    }
}

#[test]
fn an_affine_model_keeps_alpha_and_beta() {
    let d = invsim_inversion::derive_file(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/si_engine.toml"),
    )
    .unwrap();
    let json = d.to_json();
    assert_eq!(json["affine"], true);
    assert!(
        json["alpha"].is_string() && json["beta"].is_string() && json.get("yr_equation").is_none()
    );
}

/// The worst relative difference of two runs' input and named columns (relative to each column's peak).
fn run_difference(
    a: &invsim_runtime::SimulationResult,
    b: &invsim_runtime::SimulationResult,
    names: &[String],
) -> f64 {
    let mut cols = vec![(a.input(), b.input())];
    for s in names {
        cols.push((a.column(s).unwrap(), b.column(s).unwrap()));
    }
    let mut worst = 0.0f64;
    for (x, y) in cols {
        assert_eq!(x.len(), y.len());
        let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
        for (p, q) in x.iter().zip(y) {
            worst = worst.max((p - q).abs() / peak);
        }
    }
    worst
}

/// Generated code of a numeric ψ⁻¹ with a y^(r) not affine in the input (compiled by this crate's build
/// script from `tests/models/nonaffine_map_*.toml`) runs as the interpreter does on UDDS: Newton's method for x, then the input (isolated, or Newton's method from the previous
/// sample's), the internal state integrated with the zero dynamics at that input; u, x and the outputs
/// agree within 1e-12 relative.
#[test]
fn compiled_numeric_psi_inv_with_a_non_affine_input_equals_the_interpreter() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cycle = Cycle::builtin("udds").unwrap();
    for name in ["nonaffine_map_isolated", "nonaffine_map_newton"] {
        let d = invsim_inversion::derive_file(&root.join(format!("models/{name}.toml"))).unwrap();
        let interp = Interpreter::new(&d).unwrap();
        let compiled = invsim_tests::extra::builtin(name).expect("compiled");
        let mut names: Vec<String> = d.model.states.iter().map(|s| s.name.clone()).collect();
        names.extend(d.model.outputs.iter().map(|o| o.name.clone()));
        let opts = |engine: &str| SimulationOptions {
            dt: 0.1,
            engine: engine.into(),
            ..SimulationOptions::default()
        };
        let a = simulate(&interp, &cycle, &opts("interpreted")).unwrap();
        let b = simulate(compiled.as_ref(), &cycle, &opts("compiled")).unwrap();
        assert_eq!(b.summary.engine, "compiled", "{name}");
        let worst = run_difference(&a, &b, &names);
        eprintln!("{name}: compiled vs interpreted {worst:e}");
        assert!(worst < 1e-12, "{name}: compiled vs interpreted {worst:e}");
        // The run reaches the input's non-linear range (|u| > 0.5).
        let peak = a.input().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(peak > 0.5, "{name}: |u| at most {peak}");
        // A replaced map (`--map`) reaches φ and the input solution in both engines: a stronger actuator
        // needs a smaller input.
        let (mut interp, mut compiled) = (interp, compiled);
        let grid = [-2.0, -1.0, 0.0, 1.0, 2.0];
        let values = [-12000.0, -5600.0, 0.0, 5600.0, 12000.0];
        for m in [&mut interp as &mut dyn InverseModel, compiled.as_mut()] {
            m.set_map("force", (&grid, None, &values)).unwrap();
        }
        let c = simulate(&interp, &cycle, &opts("interpreted")).unwrap();
        let d = simulate(compiled.as_ref(), &cycle, &opts("compiled")).unwrap();
        let worst = run_difference(&c, &d, &names);
        assert!(
            worst < 1e-12,
            "{name} with --map: compiled vs interpreted {worst:e}"
        );
        let strong = c.input().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(
            strong < 0.8 * peak,
            "{name}: |u| {strong} with the stronger map, {peak} without"
        );
    }
}

/// Generated code (compiled by this crate's build script from `tests/models/nonaffine_*.toml`, and
/// `models/bev.toml` from `invsim-models`) runs as the interpreter does: Newton's method for the input from
/// the previous sample's, the isolated input in closed form.
#[test]
fn compiled_code_equals_the_interpreter_along_a_run() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cases: [(&str, std::path::PathBuf, Box<dyn InverseModel>); 3] = [
        (
            "nonaffine_isolated",
            root.join("models/nonaffine_isolated.toml"),
            invsim_tests::extra::builtin("nonaffine_isolated").expect("compiled"),
        ),
        (
            "nonaffine_newton",
            root.join("models/nonaffine_newton.toml"),
            invsim_tests::extra::builtin("nonaffine_newton").expect("compiled"),
        ),
        (
            "bev",
            root.join("../models/bev.toml"),
            invsim_models::builtin("bev").expect("compiled"),
        ),
    ];
    let cycle = Cycle::builtin("udds").unwrap();
    for (name, file, compiled) in cases {
        let d = invsim_inversion::derive_file(&file).unwrap();
        let interp = Interpreter::new(&d).unwrap();
        let opts = |engine: &str| SimulationOptions {
            dt: 0.1,
            engine: engine.into(),
            ..SimulationOptions::default()
        };
        let a = simulate(&interp, &cycle, &opts("interpreted")).unwrap();
        let b = simulate(compiled.as_ref(), &cycle, &opts("compiled")).unwrap();
        let states: Vec<String> = d.model.states.iter().map(|s| s.name.clone()).collect();
        let worst = run_difference(&a, &b, &states);
        eprintln!("{name}: compiled vs interpreted, worst relative difference {worst:e}");
        assert!(worst < 1e-10, "{name}: compiled vs interpreted {worst:e}");
        // Newton from the previous sample's input and from the middle of the bounds reach the same root.
        if name == "nonaffine_newton" {
            let (xi, eta, mut x) = ([10.0], [0.1], [0.0, 0.0]);
            let from_middle = compiled.invert(&xi, &eta, &[], 0.5, &mut x).unwrap();
            let warm = compiled
                .invert_from(&xi, &eta, &[], 0.5, &mut x, from_middle + 7.0)
                .unwrap();
            let warm_interp = interp
                .invert_from(&xi, &eta, &[], 0.5, &mut x, from_middle + 7.0)
                .unwrap();
            assert!((warm - from_middle).abs() < 1e-9 * from_middle.abs());
            assert!((warm - warm_interp).abs() < 1e-12 * warm.abs());
        }
    }
}

/// φ(F) = F³/10⁶ − 3F has three roots for |φ| < 2000 (folds at F = ±1000): Newton's root depends on the start.
const FOLDS: &str = r#"
name = "folds"
[parameters]
m = 1000.0
[states]
v = { rhs = "(F^3/1e6 - 3*F)/m" }
[input]
name = "F"
min = -4400.0
max = 2000.0
[output]
name = "v"
h = "v"
"#;

/// Along a sequence of points Newton's method starts from the previous point's input, so it stays on the
/// root it started on: from the middle of the bounds (−1200, the left branch F < −1000) without a guess,
/// on the right branch (F > 1000) from a guess there; every root solves φ(F) = m·y^(r).
#[test]
fn newton_follows_the_root_it_starts_near() {
    let d = derive(FOLDS);
    assert!(!d.affine && d.input_solution.is_none());
    let interp = Interpreter::new(&d).unwrap();
    let phi = |f: f64| f * f * f / 1e6 - 3.0 * f;
    // y^(r) from 1.5 down to −1.5 m/s² (φ from 1500 to −1500: three roots throughout).
    let n = 61;
    let yr: Vec<f64> = (0..n)
        .map(|k| 1.5 - 3.0 * k as f64 / (n - 1) as f64)
        .collect();
    let xi_col = vec![10.0; n];
    let xi: [&[f64]; 1] = [&xi_col];
    for (guess, right) in [(f64::NAN, false), (1900.0, true)] {
        let mut x_col = vec![0.0; n];
        let mut u = vec![0.0; n];
        u[0] = guess;
        {
            let mut x: [&mut [f64]; 1] = [&mut x_col];
            invsim_model_api::invert_pointwise(&interp, &xi, &[], &[], &yr, &mut x, &mut u)
                .unwrap();
        }
        for k in 0..n {
            assert!(
                (phi(u[k]) - 1000.0 * yr[k]).abs() < 1e-9 * 2000.0,
                "k = {k}: φ({}) ≠ {}",
                u[k],
                1000.0 * yr[k]
            );
            assert_eq!(
                u[k] > 1000.0,
                right,
                "k = {k}: u = {} left its branch",
                u[k]
            );
            assert!(right || u[k] < -1000.0, "k = {k}: u = {}", u[k]);
        }
        // Continuous: neighbouring roots differ by far less than the branches' gap.
        let jump = u
            .windows(2)
            .map(|p| (p[1] - p[0]).abs())
            .fold(0.0, f64::max);
        assert!(jump < 100.0, "largest step {jump}");
    }
}

/// Thrust k_T·sqrt(P) from a power P ≥ 0: not affine in P, and g = ∂rhs/∂P = k_T/(2 m sqrt(P)) is 1/0 at
/// P = 0, where the method never evaluates it (the rhs is solved for P).
const SQRT_THRUST: &str = r#"
name = "sqrt_thrust"
[parameters]
m = 1200.0
c = 0.4
k_T = 40.0
[states]
v = { rhs = "(k_T*sqrt(P) - c*v^2)/m" }
[input]
name = "P"
min = 0
max = 200000
[output]
name = "v"
h = "v"
"#;

/// A cycle the sqrt thrust can follow (it cannot brake): at rest for 10 s, then 0.2 m/s² up to 20 m/s,
/// held to 200 s.
fn ramp() -> Cycle {
    let mut text = String::from("t,speed_mps\n");
    for t in 0..=200 {
        let v = if t < 10 {
            0.0
        } else {
            (0.2 * (t - 10) as f64).min(20.0)
        };
        text.push_str(&format!("{t},{v}\n"));
    }
    Cycle::from_csv_str("ramp", &text).unwrap()
}

/// The model with thrust k_T·sqrt(P) derives (its g at P = 0 is not checked), and the interpreted run's
/// input is the closed form P = ((m·v' + c·v²)/k_T)² at the smoothed reference's speed and acceleration at
/// every sample.
#[test]
fn a_square_root_thrust_derives_and_runs_as_its_closed_form() {
    let d = derive(SQRT_THRUST);
    assert!(!d.affine);
    let interp = Interpreter::new(&d).unwrap();
    let opts = SimulationOptions {
        dt: 0.1,
        engine: "interpreted".into(),
        ..SimulationOptions::default()
    };
    let res = simulate(&interp, &ramp(), &opts).unwrap();
    let (p, v, yd1) = (res.input(), res.column("v").unwrap(), res.yd(1).unwrap());
    let (m, c, k_t) = (1200.0, 0.4, 40.0);
    let mut worst = 0.0f64;
    for k in 0..res.len() {
        let expected = ((m * yd1[k] + c * v[k] * v[k]) / k_t).powi(2);
        worst = worst.max((p[k] - expected).abs() / (1.0 + expected));
    }
    assert!(worst < 1e-9, "P against its closed form: {worst:e}");
    // Half-way up the ramp (t = 60 s): v = 10 m/s, v' = 0.2 m/s²: P = ((240 + 40)/40)² = 49.
    let k = (60.0 / 0.1) as usize;
    assert!(
        (v[k] - 10.0).abs() < 1e-9 && (p[k] - 49.0).abs() < 1e-6,
        "{} {}",
        v[k],
        p[k]
    );
}

/// Where the reference needs a braking force, no P ≥ 0 gives it: the closed form P = (F/k_T)² would give a
/// positive P with thrust +|F| (the wrong sign); the run stops with the input that cannot be reached.
#[test]
fn a_square_root_thrust_cannot_brake_and_says_so() {
    let d = derive(SQRT_THRUST);
    let interp = Interpreter::new(&d).unwrap();
    let opts = SimulationOptions {
        dt: 0.1,
        engine: "interpreted".into(),
        ..SimulationOptions::default()
    };
    let text = match simulate(&interp, &Cycle::builtin("udds").unwrap(), &opts) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("UDDS brakes harder than the drag, yet the run succeeded"),
    };
    assert!(text.contains("no value of the input reaches"), "{text}");
}
