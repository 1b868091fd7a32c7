//! The acceptance models of `shared/models/` give the results their README states. The directory is reference
//! material that only CI and developers have; without it these tests say so and pass vacuously.

use invsim_inversion::{derive_file, Derivation, Error, Solution};
use std::path::PathBuf;

fn shared_model(name: &str) -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/models");
    if !dir.is_dir() {
        eprintln!("skipping: ../shared not found ({})", dir.display());
        return None;
    }
    Some(dir.join(format!("{name}.toml")))
}

/// `expr` (in the contract's language) equals `e` identically (canonical form, expansion or probing).
fn same(d: &Derivation, e: invsim_expr::Id, expr: &str) -> bool {
    let mut pool = d.pool().clone();
    let want = pool.parse(expr).unwrap();
    let diff = pool.sub(e, want);
    invsim_expr::zero_test(&mut pool, diff, &d.model.nominal()).is_zero()
}

#[test]
fn motor_pendulum() {
    let Some(p) = shared_model("motor_pendulum") else {
        return;
    };
    let d = derive_file(&p).unwrap();
    assert_eq!((d.relative_degree, d.n()), (3, 3));
    assert!(
        same(&d, d.beta, "K/(J*L)"),
        "beta = {}",
        d.pool().display(d.beta)
    );
    let Solution::Closed(i_m) = d.psi_inv[2] else {
        panic!("i_m must be in closed form")
    };
    assert!(
        same(&d, i_m, "(J*xi3 + m*g0*l*sin(xi1) + b*xi2)/K"),
        "i_m = {}",
        d.pool().display(i_m)
    );
    assert!(d.zero_dynamics.is_empty());
}

#[test]
fn internal_dynamics() {
    let Some(p) = shared_model("internal_dynamics") else {
        return;
    };
    let d = derive_file(&p).unwrap();
    assert_eq!((d.relative_degree, d.n()), (2, 3));
    assert!(same(&d, d.beta, "1"));
    assert!(
        same(&d, d.alpha, "-sin(xi1) - xi2 + eta1"),
        "alpha = {}",
        d.pool().display(d.alpha)
    );
    assert_eq!(d.pool().display(d.psi[2]), "x3");
    assert!(
        same(
            &d,
            d.zero_dynamics[0],
            "-k*eta1 + xi1*(yr + sin(xi1) + xi2 - eta1)"
        ),
        "zero dynamics = {}",
        d.pool().display(d.zero_dynamics[0])
    );
}

#[test]
fn singular_decoupling() {
    let Some(p) = shared_model("singular_decoupling") else {
        return;
    };
    let d = derive_file(&p).unwrap();
    assert_eq!(d.relative_degree, 2);
    assert!(same(&d, d.beta, "xi1"));
    assert!(
        d.singular.iter().any(|s| s.contains("xi1 = 0")),
        "{:?}",
        d.singular
    );
    assert!(
        d.warnings.iter().any(|w| w.contains("xi1 = 0")),
        "{:?}",
        d.warnings
    );
    let json = d.to_json();
    assert!(json["singular"][0].as_str().unwrap().contains("xi1 = 0"));
}

#[test]
fn bad_no_relative_degree() {
    let Some(p) = shared_model("bad_no_relative_degree") else {
        return;
    };
    let err = derive_file(&p).unwrap_err();
    assert!(matches!(err, Error::Derive(_)));
    assert!(
        err.to_string()
            .contains("does not depend on the input `u` through any number of derivatives"),
        "{err}"
    );
}

#[test]
fn bad_nonaffine() {
    let Some(p) = shared_model("bad_nonaffine") else {
        return;
    };
    // Since contract §5 a valid non-affine model (the shared README): r = 2, y^(r) = u² − ξ1, u = √(yr + ξ1),
    // decoupling 2u.
    let d = derive_file(&p).unwrap();
    assert!(!d.affine);
    assert_eq!(d.relative_degree, 2);
    let show = |e| d.pool().display(e);
    assert_eq!(show(d.alpha), "u^2 - xi1");
    assert_eq!(show(d.beta_x), "2*u");
    assert_eq!(
        d.input_solution.map(show).as_deref(),
        Some("sqrt(xi1 + yr)")
    );
    let json = d.to_json();
    assert_eq!(json["affine"], false);
    assert_eq!(json["input_solution"], "sqrt(xi1 + yr)");
    assert!(json.get("alpha").is_none() && json["lie_derivatives"].as_array().unwrap().len() == 2);
}

#[test]
fn bad_unknown_symbol() {
    let Some(p) = shared_model("bad_unknown_symbol") else {
        return;
    };
    let err = derive_file(&p).unwrap_err().to_string();
    assert!(err.contains("`c9`"), "{err}");
    assert!(err.contains("bad_unknown_symbol.toml:8:23:"), "{err}");
}
