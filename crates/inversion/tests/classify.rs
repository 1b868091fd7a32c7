//! Classification of the zero dynamics at the nominal point (`Derivation::classify`) and its fields in the JSON,
//! text and Markdown renderings: minimum phase, non-minimum phase, mixed, none (r = n) and unknown.

use invsim_inversion::{derive_file, Derivation, Model, ZeroDynamicsClass};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn repo_model(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../models")
        .join(name)
}

fn derive_text(text: &str) -> Derivation {
    let model = Model::from_str(Path::new("test.toml"), text).expect("model loads");
    Derivation::new(model).expect("model derives")
}

fn eigenvalues(json: &Value) -> Vec<[f64; 2]> {
    json["zero_dynamics_eigenvalues"]
        .as_array()
        .expect("zero_dynamics_eigenvalues is an array")
        .iter()
        .map(|e| {
            let pair = e.as_array().expect("[re, im]");
            [pair[0].as_f64().unwrap(), pair[1].as_f64().unwrap()]
        })
        .collect()
}

#[test]
fn driveline_is_minimum_phase_with_a_lightly_damped_pair() {
    let d = derive_file(&repo_model("driveline.toml")).unwrap();
    let json = d.to_json();
    assert_eq!(json["zero_dynamics_class"], "minimum_phase");
    assert_eq!(json["zero_dynamics_nominal"]["output"], 13.9);
    let eigs = eigenvalues(&json);
    assert_eq!(eigs.len(), 3);
    // The body on the tyre/suspension compliance: ω_n = sqrt(k_t/m), ζ ω_n = c_t/(2m) (+ air drag); the shaft
    // torsion decays at k_s/c_s.
    let (k_t, m, k_s, c_s): (f64, f64, f64, f64) = (2.4e5, 1500.0, 6000.0, 20.0);
    let pair = eigs.iter().find(|e| e[1] > 0.0).expect("complex pair");
    let omega_n = (pair[0] * pair[0] + pair[1] * pair[1]).sqrt();
    assert!((omega_n - (k_t / m).sqrt()).abs() < 0.01, "{pair:?}");
    let zeta = -pair[0] / omega_n;
    assert!(zeta > 0.04 && zeta < 0.06, "damping ratio {zeta}");
    assert!(
        eigs.iter()
            .any(|e| (e[0] + k_s / c_s).abs() < 1e-4 && e[1] == 0.0),
        "{eigs:?}"
    );
    let text = d.to_text();
    assert!(text.contains("class: minimum_phase at y = 13.9"), "{text}");
    assert!(d.to_markdown().contains("**minimum_phase at y = 13.9"));
}

#[test]
fn diesel_gasflow_is_non_minimum_phase_at_its_nominal_boost() {
    let d = derive_file(&repo_model("diesel_gasflow.toml")).unwrap();
    let c = d.classify();
    assert_eq!(c.class, ZeroDynamicsClass::NonMinimumPhase);
    assert_eq!(c.output, 1.56e5);
    assert_eq!(c.eigenvalues.len(), 1);
    assert!(
        c.eigenvalues[0][0] > 10.0 && c.eigenvalues[0][0] < 100.0,
        "{:?}",
        c.eigenvalues
    );
    // The equilibrium exhaust pressure lies slightly above the boost pressure.
    assert!(c.eta[0] > 1.56e5 && c.eta[0] < 1.8e5, "{:?}", c.eta);
    let json = d.to_json();
    assert_eq!(json["zero_dynamics_class"], "non_minimum_phase");
    assert_eq!(json["reference"]["offset"], 1.3e5);
    assert_eq!(json["reference"]["scale"], 4000.0);
    assert!(d
        .to_text()
        .contains("reference from a drive cycle: y_d = 130000 + 4000"));
}

#[test]
fn full_relative_degree_has_no_zero_dynamics() {
    let d = derive_file(&repo_model("si_engine.toml")).unwrap();
    let json = d.to_json();
    assert_eq!(json["zero_dynamics_class"], "none");
    assert_eq!(eigenvalues(&json), Vec::<[f64; 2]>::new());
    assert_eq!(json["reference"]["offset"], 0.0);
    assert_eq!(json["reference"]["scale"], 1.0);
}

const HEADER: &str = "[input]\nname = \"u\"\n";

#[test]
fn shared_internal_dynamics_model_is_minimum_phase() {
    // shared/models/internal_dynamics.toml: q = −k η + ξ1 (yr + sin ξ1 + ξ2 − η), ∂q/∂η = −k − ξ1 = −2 at ξ1 = 0.
    let d = derive_text(&format!(
        "[parameters]\nk = 2.0\n[states]\nx1 = {{ f = \"x2\", g = \"0\" }}\nx2 = {{ f = \"-sin(x1) - x2 + x3\", g = \"1\" }}\n\
         x3 = {{ f = \"-k*x3\", g = \"x1\" }}\n{HEADER}[output]\nname = \"y\"\nh = \"x1\"\n"
    ));
    let c = d.classify();
    assert_eq!(c.class, ZeroDynamicsClass::MinimumPhase);
    assert_eq!(c.output, 0.0);
    assert!(
        (c.eigenvalues[0][0] + 2.0).abs() < 1e-8,
        "{:?}",
        c.eigenvalues
    );
    // At the nominal output 3 (given in the file) −k − ξ1 = −5.
    let d = derive_text(&format!(
        "[parameters]\nk = 2.0\n[states]\nx1 = {{ f = \"x2\", g = \"0\" }}\nx2 = {{ f = \"-sin(x1) - x2 + x3\", g = \"1\" }}\n\
         x3 = {{ f = \"-k*x3\", g = \"x1\" }}\n{HEADER}[output]\nname = \"y\"\nh = \"x1\"\nnominal = 3.0\n"
    ));
    assert!((d.classify().eigenvalues[0][0] + 5.0).abs() < 1e-7);
}

/// (s − 0.5)(s + 2)/(…): one unstable and one stable zero.
const MIXED: &str =
    "[states]\nx1 = { rhs = \"-3*x1 + x2 + x3 + u\" }\nx2 = { rhs = \"0.5*x2 - 2*x1\" }\n\
                     x3 = { rhs = \"-2*x3 + x1\" }\n";

#[test]
fn linear_models_are_classified_by_their_zeros() {
    let d = derive_text(&format!(
        "{MIXED}{HEADER}[output]\nname = \"y\"\nh = \"x1\"\n"
    ));
    let json = d.to_json();
    assert_eq!(json["zero_dynamics_class"], "mixed");
    let eigs = eigenvalues(&json);
    assert!(
        (eigs[0][0] - 0.5).abs() < 1e-8 && (eigs[1][0] + 2.0).abs() < 1e-8,
        "{eigs:?}"
    );
    // (s − b)/((s + p1)(s + p2)) with b = 0.5: non-minimum phase.
    let d = derive_text(&format!(
        "[states]\nx1 = {{ rhs = \"-3*x1 + x2 + u\" }}\nx2 = {{ rhs = \"0.5*x2 - 2.5*x1\" }}\n{HEADER}[output]\nname = \"y\"\nh = \"x1\"\n"
    ));
    assert_eq!(d.to_json()["zero_dynamics_class"], "non_minimum_phase");
}

#[test]
fn no_equilibrium_or_an_imaginary_axis_eigenvalue_is_unknown() {
    // η' = 1 + η² has no equilibrium.
    let d = derive_text(&format!(
        "[states]\nx1 = {{ rhs = \"u\" }}\nx2 = {{ rhs = \"1 + x2^2\" }}\n{HEADER}[output]\nname = \"y\"\nh = \"x1\"\n"
    ));
    let c = d.classify();
    assert_eq!(c.class, ZeroDynamicsClass::Unknown);
    assert!(
        c.note
            .as_deref()
            .is_some_and(|n| n.contains("no equilibrium")),
        "{:?}",
        c.note
    );
    let json = d.to_json();
    assert_eq!(json["zero_dynamics_class"], "unknown");
    assert!(json["zero_dynamics_nominal"]["note"]
        .as_str()
        .unwrap()
        .contains("nominal"));
    // η' = x1 − 0·η: a pure integrator (eigenvalue 0) is not decided by the linearisation.
    let d = derive_text(&format!(
        "[states]\nx1 = {{ rhs = \"u\" }}\nx2 = {{ rhs = \"x1\" }}\n{HEADER}[output]\nname = \"y\"\nh = \"x1\"\n"
    ));
    let c = d.classify();
    assert_eq!(c.class, ZeroDynamicsClass::Unknown);
    assert!(
        c.note
            .as_deref()
            .is_some_and(|n| n.contains("imaginary axis")),
        "{:?}",
        c.note
    );
}

#[test]
fn nominal_defaults_to_the_reference_offset() {
    let d = derive_text(&format!(
        "[states]\nx1 = {{ rhs = \"-x1 + x2 + u\" }}\nx2 = {{ rhs = \"-x2 + x1^2\" }}\n{HEADER}[output]\nname = \"y\"\nh = \"x1\"\n\
         reference_offset = 2.0\nreference_scale = 0.5\n"
    ));
    let c = d.classify();
    assert_eq!(c.output, 2.0);
    assert!(
        (c.eta[0] - 4.0).abs() < 1e-9,
        "equilibrium η = ξ1² = 4: {:?}",
        c.eta
    );
    assert_eq!(c.class, ZeroDynamicsClass::MinimumPhase);
    assert_eq!(d.model.output.reference_scale, 0.5);
}
