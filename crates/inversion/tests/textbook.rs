//! Known-answer tests of relative degree and normal form from the textbooks (Khalil, *Nonlinear Systems*,
//! 3rd ed., §13.2; Isidori, *Nonlinear Control Systems*, 3rd ed., §4.1), for r = n and r < n, plus the paper's
//! si_engine model (Fröberg & Nielsen 2004, eq. 22–32) with the steady-state check values of
//! `shared/reference/si_engine.md`.

use invsim_expr::Symbol;
use invsim_inversion::{Derivation, Interpreter, Model, Solution};
use invsim_model_api::InverseModel;
use std::collections::HashMap;
use std::path::Path;

fn derive(text: &str) -> Derivation {
    let model = Model::from_str(Path::new("test.toml"), text).unwrap_or_else(|e| panic!("{e}"));
    Derivation::new(model).unwrap_or_else(|e| panic!("{e}"))
}

/// Evaluate an expression of the derivation at named values (parameters at their nominal values).
fn eval(d: &Derivation, e: invsim_expr::Id, vals: &[(&str, f64)]) -> f64 {
    let mut env: HashMap<Symbol, f64> = d.model.nominal();
    for (name, v) in vals {
        let s = d
            .pool()
            .find_symbol(name)
            .unwrap_or_else(|| panic!("no symbol {name}"));
        env.insert(s, *v);
    }
    d.pool().eval(e, &env).unwrap()
}

fn closed(d: &Derivation, i: usize) -> invsim_expr::Id {
    match d.psi_inv[i] {
        Solution::Closed(e) => e,
        Solution::Numeric => panic!("state {i} not in closed form"),
    }
}

const VAN_DER_POL: &str = r#"
[parameters]
eps = 0.5
[states]
x1 = { rhs = "x2" }
x2 = { rhs = "-x1 + eps*(1 - x1^2)*x2 + u" }
[input]
name = "u"
[output]
name = "y"
h = "OUTPUT"
"#;

#[test]
fn van_der_pol_position_output_has_full_relative_degree() {
    // Khalil Example 13.6 (controlled Van der Pol), y = x1: y'' = −x1 + ε(1 − x1²)x2 + u, r = n = 2.
    let d = derive(&VAN_DER_POL.replace("OUTPUT", "x1"));
    assert_eq!(d.relative_degree, 2);
    assert!(d.eta.is_empty() && d.zero_dynamics.is_empty());
    assert_eq!(d.pool().display(d.beta), "1");
    for (x1, x2) in [(0.3, -1.2), (2.0, 0.7)] {
        let want = -x1 + 0.5 * (1.0 - x1 * x1) * x2;
        let got = eval(&d, d.alpha, &[("xi1", x1), ("xi2", x2)]);
        assert!((got - want).abs() < 1e-14, "{got} vs {want}");
    }
}

#[test]
fn van_der_pol_velocity_output_has_relative_degree_one() {
    // Same system, y = x2: L_g h = 1, r = 1 < n; η = x1 with L_g η = 0, zero dynamics η' = x2 = ξ1.
    let d = derive(&VAN_DER_POL.replace("OUTPUT", "x2"));
    assert_eq!(d.relative_degree, 1);
    assert_eq!(d.eta_states, vec![0]);
    assert_eq!(d.pool().display(d.zero_dynamics[0]), "xi1");
    assert_eq!(d.pool().display(closed(&d, 0)), "eta1");
}

#[test]
fn output_through_a_square_root_is_isolated_with_a_domain_condition() {
    // y = x1 + x2²: L_g h = 2 x2, r = 1; ψ⁻¹ needs x2 = √(ξ1 − η1) (positive root) and β = 2√(ξ1 − η1).
    let d = derive(&VAN_DER_POL.replace("OUTPUT", "x1 + x2^2"));
    assert_eq!(d.relative_degree, 1);
    let x2 = closed(&d, 1);
    assert!((eval(&d, x2, &[("xi1", 5.0), ("eta1", 1.0)]) - 2.0).abs() < 1e-15);
    assert!((eval(&d, d.beta, &[("xi1", 5.0), ("eta1", 1.0)]) - 4.0).abs() < 1e-14);
    assert!(
        !d.domain.is_empty(),
        "the root needs xi1 - eta1 >= 0: {:?}",
        d.domain
    );
}

#[test]
fn linear_system_zero_dynamics_sit_at_the_transfer_function_zero() {
    // Controllable canonical form of (s + 1)/(s³ + 2s² + 3s + 4), y = x1 + x2: r = 3 − 1 = 2 and the zero
    // dynamics η' = ξ1 − η have their eigenvalue at the zero s = −1 (Isidori §4.1, linear case).
    let d = derive(
        r#"
[states]
x1 = { rhs = "x2" }
x2 = { rhs = "x3" }
x3 = { rhs = "-4*x1 - 3*x2 - 2*x3 + u" }
[input]
name = "u"
[output]
name = "y"
h = "x1 + x2"
"#,
    );
    assert_eq!(d.relative_degree, 2);
    assert_eq!(d.eta_states, vec![0]);
    assert_eq!(d.pool().display(d.zero_dynamics[0]), "-eta1 + xi1");
    assert_eq!(d.pool().display(d.beta), "1");
    // α = L_f² h = x3 + (−4x1 − 3x2 − 2x3) in coordinates x1 = η, x2 = ξ1 − η, x3 = ξ2 − ξ1 + η.
    let (xi1, xi2, eta) = (0.7, -0.4, 1.3);
    let (x1, x2, x3) = (eta, xi1 - eta, xi2 - xi1 + eta);
    let want = x3 - 4.0 * x1 - 3.0 * x2 - 2.0 * x3;
    let got = eval(&d, d.alpha, &[("xi1", xi1), ("xi2", xi2), ("eta1", eta)]);
    assert!((got - want).abs() < 1e-14);
}

#[test]
fn khalil_example_with_input_in_the_internal_state() {
    // Khalil Example 13.8: x1' = −x1 + (2 + x3²)/(1 + x3²) u, x2' = x3, x3' = x1 x3 + u, y = x2.
    // y'' = x1 x3 + u: r = 2, α = η ξ2, β = 1; with y ≡ 0 the zero dynamics are η' = −η (stable).
    let d = derive(
        r#"
[states]
x1 = { rhs = "-x1 + (2 + x3^2)/(1 + x3^2)*u" }
x2 = { rhs = "x3" }
x3 = { rhs = "x1*x3 + u" }
[input]
name = "u"
[output]
name = "y"
h = "x2"
"#,
    );
    assert_eq!(d.relative_degree, 2);
    assert_eq!(d.eta_states, vec![0]);
    assert_eq!(d.pool().display(d.alpha), "eta1*xi2");
    let q0 = eval(
        &d,
        d.zero_dynamics[0],
        &[("xi1", 0.0), ("xi2", 0.0), ("eta1", 0.8), ("yr", 0.0)],
    );
    assert!((q0 + 0.8).abs() < 1e-15);
    // Away from y ≡ 0: η' = −η + (2 + ξ2²)/(1 + ξ2²)(yr − η ξ2).
    let (xi2, eta, yr) = (0.5, 0.3, 1.1);
    let want = -eta + (2.0 + xi2 * xi2) / (1.0 + xi2 * xi2) * (yr - eta * xi2);
    let got = eval(
        &d,
        d.zero_dynamics[0],
        &[("xi1", 9.0), ("xi2", xi2), ("eta1", eta), ("yr", yr)],
    );
    assert!((got - want).abs() < 1e-14);
    assert!(d.warnings.iter().any(|w| w.contains("L_g η ≠ 0")));
}

#[test]
fn relative_degree_three_through_a_sine_with_a_singular_set() {
    // x1' = sin x2, x2' = x3, x3' = u, y = x1: L_f h = sin x2, L_f² h = x3 cos x2, L_g L_f² h = cos x2:
    // r = 3 = n, ψ⁻¹ inverts the sine on its principal branch, β = cos x2 changes sign (singular set).
    let d = derive(
        r#"
[states]
x1 = { rhs = "sin(x2)" }
x2 = { rhs = "x3" }
x3 = { rhs = "u" }
[input]
name = "u"
[output]
name = "y"
h = "x1"
"#,
    );
    assert_eq!(d.relative_degree, 3);
    let (xi2, xi3) = (0.6, 0.25);
    let x2 = eval(
        &d,
        closed(&d, 1),
        &[("xi1", 0.0), ("xi2", xi2), ("xi3", xi3)],
    );
    assert!((x2 - xi2.asin()).abs() < 1e-15);
    let x3 = eval(
        &d,
        closed(&d, 2),
        &[("xi1", 0.0), ("xi2", xi2), ("xi3", xi3)],
    );
    assert!((x3 - xi3 / xi2.asin().cos()).abs() < 1e-14);
    // β = cos(x2) = cos(asin ξ2) > 0 on the principal branch: it vanishes only on its boundary |ξ2| = 1,
    // which the domain conditions state.
    let beta = eval(&d, d.beta, &[("xi1", 0.0), ("xi2", xi2), ("xi3", xi3)]);
    assert!((beta - xi2.asin().cos()).abs() < 1e-15);
    assert!(d.domain.iter().any(|c| c.contains("< 1")), "{:?}", d.domain);
}

#[test]
fn nonlinear_psi_inverse_that_cannot_be_isolated_is_numeric() {
    // y = x1 + x2·exp(x2): x2 occurs twice and cannot be isolated; ψ⁻¹ falls back to Newton's method and the
    // interpreter still inverts (ψ(ψ⁻¹(ξ, η)) = (ξ, η)).
    let d = derive(
        r#"
[states]
x1 = { rhs = "-x1" }
x2 = { rhs = "-x2 + u" }
[input]
name = "u"
[output]
name = "y"
h = "x1 + x2*exp(x2)"
"#,
    );
    assert_eq!(d.relative_degree, 1);
    assert!(d.psi_inv.contains(&Solution::Numeric));
    let interp = Interpreter::new(&d).unwrap();
    let x_true = [0.4, 0.3];
    let (mut xi, mut eta) = ([0.0], [0.0]);
    interp.psi(&x_true, &[], &mut xi, &mut eta);
    let mut x = [0.0, 0.0];
    interp.psi_inv(&xi, &eta, &[], &mut x).unwrap();
    assert!(
        (x[0] - x_true[0]).abs() < 1e-12 && (x[1] - x_true[1]).abs() < 1e-12,
        "{x:?}"
    );
}

fn si_engine() -> Derivation {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/si_engine.toml");
    let model = Model::from_path(&path).unwrap();
    Derivation::new(model).unwrap()
}

#[test]
fn si_engine_has_the_papers_structure() {
    let d = si_engine();
    assert_eq!(d.relative_degree, 2);
    assert!(d.eta.is_empty());
    // β = c3 c7: a constant (parameters only).
    let coords: Vec<Symbol> = d.xi.clone();
    assert!(
        !d.pool().depends_on_any(d.beta, &coords),
        "beta = {}",
        d.pool().display(d.beta)
    );
    // α (paper eq. 28) is affine in ξ2: ∂²α/∂ξ2² = 0, and depends on ξ1.
    let mut pool = d.pool().clone();
    let a2 = pool.diff(d.alpha, d.xi[1]);
    let a22 = pool.diff(a2, d.xi[1]);
    let nominal = d.model.nominal();
    assert!(invsim_expr::zero_test(&mut pool, a22, &nominal).is_zero());
    assert!(pool.depends_on(d.alpha, d.xi[0]));
    // x1 = ξ1 exactly.
    assert_eq!(d.pool().display(closed(&d, 0)), "xi1");
    // No blow-up: α stays a small DAG.
    let size = d.pool().dag_size(&[d.alpha, d.beta]);
    assert!(size < 200, "alpha and beta have {size} nodes");
}

#[test]
fn si_engine_reproduces_the_steady_state_check_values() {
    // shared/reference/si_engine.md: at constant speed (ξ = (v, 0), y^(2) = 0), p_i = ψ⁻¹ and ṁ_at = −α/β.
    let d = si_engine();
    let interp = Interpreter::new(&d).unwrap();
    for (kmh, p_i, m_at_gs) in [
        (15.0, 25_498.0, 2.115),
        (50.0, 29_315.0, 8.619),
        (70.0, 33_141.0, 14.27),
        (120.0, 47_713.0, 38.82),
    ] {
        let v = kmh / 3.6;
        let mut x = [0.0; 2];
        let u = interp.invert(&[v, 0.0], &[], &[], 0.0, &mut x).unwrap();
        assert!((x[0] - v).abs() < 1e-12);
        assert!(
            ((x[1] - p_i) / p_i).abs() < 0.5e-4,
            "{kmh} km/h: p_i = {} (want {p_i})",
            x[1]
        );
        assert!(
            ((u * 1e3 - m_at_gs) / m_at_gs).abs() < 0.5e-3,
            "{kmh} km/h: m_at = {} g/s (want {m_at_gs})",
            u * 1e3
        );
    }
    // 5.67 l/100 km at 50 km/h: fuel volume flow / speed.
    let v = 50.0 / 3.6;
    let mut x = [0.0; 2];
    let u = interp.invert(&[v, 0.0], &[], &[], 0.0, &mut x).unwrap();
    let mut out = [0.0; 4];
    interp.outputs(&x, &[], u, &mut out);
    let l_per_100km = out[1] / v * 1e5;
    assert!((l_per_100km - 5.67).abs() < 0.005, "{l_per_100km} l/100 km");
}

#[test]
fn si_engine_acceleration_check_values() {
    // At 50 km/h: dv/dt = 1.578 m/s² with p_i = 0.95e5 Pa and −0.224 m/s² with p_i = 0.2e5 Pa.
    let d = si_engine();
    let interp = Interpreter::new(&d).unwrap();
    for (p_i, want) in [(0.95e5, 1.578), (0.2e5, -0.224)] {
        let mut dx = [0.0; 2];
        interp.rhs(&[50.0 / 3.6, p_i], &[], 0.0, &mut dx);
        assert!(
            (dx[0] - want).abs() < 0.0005,
            "dv/dt = {} at p_i = {p_i}",
            dx[0]
        );
    }
}
