//! Whether the zero dynamics are affine in η (`Derivation::zero_dynamics_affine`, the interpreter's
//! `ModelInfo::zero_dynamics_affine`): a manifold whose filling is linear in its pressure, one whose flow reads
//! a root of it, and a model without internal dynamics.

use invsim_inversion::{Derivation, Model};
use std::path::Path;

/// A car with an intake manifold: v' = (u − c v)/m, p' = k (y_i − s_i p) v − `outflow`; y = v, so η = p
/// with dη/dt = k (y_i − s_i η) ξ − outflow(η).
fn manifold(outflow: &str) -> Derivation {
    let text = format!(
        "[parameters]\nc = {{ value = 10.0 }}\nm = {{ value = 1000.0 }}\nk = {{ value = 0.5 }}\n\
         y_i = {{ value = 2.0 }}\ns_i = {{ value = 0.9 }}\nd = {{ value = 0.1 }}\n\
         [states]\nv = {{ rhs = \"(u - c*v)/m\" }}\np = {{ rhs = \"k*(y_i - s_i*p)*v - {outflow}\" }}\n\
         [input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"v\"\n"
    );
    let model =
        Model::from_str(Path::new("manifold.toml"), &text).unwrap_or_else(|e| panic!("{e}"));
    Derivation::new(model).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_filling_linear_in_the_pressure_is_affine() {
    let d = manifold("d*exp(v)");
    assert_eq!(d.eta.len(), 1);
    assert!(d.zero_dynamics_affine.is_some());
    assert!(invsim_inversion::model_info(&d).zero_dynamics_affine);
}

#[test]
fn a_flow_through_a_root_of_the_pressure_is_not() {
    let d = manifold("d*sqrt(p)");
    assert!(d.zero_dynamics_affine.is_none());
    assert!(!invsim_inversion::model_info(&d).zero_dynamics_affine);
    // A product of the pressure with itself, likewise.
    assert!(manifold("d*p*p").zero_dynamics_affine.is_none());
}

#[test]
fn a_model_without_internal_dynamics_says_no() {
    let text = "[states]\nv = { rhs = \"-v + u\" }\n[input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"v\"\n";
    let model = Model::from_str(Path::new("v.toml"), text).unwrap_or_else(|e| panic!("{e}"));
    let d = Derivation::new(model).unwrap_or_else(|e| panic!("{e}"));
    assert!(d.eta.is_empty());
    assert!(d.zero_dynamics_affine.is_none());
}
