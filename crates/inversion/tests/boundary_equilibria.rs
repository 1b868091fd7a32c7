//! Zero dynamics whose equilibrium lies on the boundary of a power's domain (η = 0 in η^1.5, where
//! q(η − h) is not real): the linearisation takes the one-sided derivative into the domain and classifies
//! them, instead of "unknown … ∂q/∂η not finite".

use invsim_inversion::{Derivation, Model, ZeroDynamicsClass};
use std::path::Path;

/// x1' = u, x2' = `rhs` (in x2 and x1), y = x1, nominal output `y0`.
fn classify(rhs: &str, y0: f64) -> invsim_inversion::Classification {
    let text = format!(
        "[states]\nx1 = {{ rhs = \"u\" }}\nx2 = {{ rhs = \"{rhs}\" }}\n[input]\nname = \"u\"\n\
         [output]\nname = \"y\"\nh = \"x1\"\nnominal = {y0}\n"
    );
    let model =
        Model::from_str(Path::new("boundary.toml"), &text).unwrap_or_else(|e| panic!("{e}"));
    Derivation::new(model)
        .unwrap_or_else(|e| panic!("{e}"))
        .classify()
}

#[test]
fn stable_equilibria_at_the_boundary_are_minimum_phase() {
    // q = −η − η^p + y at y = 0: η* = 0, ∂q/∂η(0+) = −1 for p > 1.
    for rhs in [
        "-x2 - x2^1.5 + x1",
        "-x2 - x2^2.5 + x1",
        "-x2 - sqrt(x2)^3 + x1",
        "-2*x2 - x2^1.25",
    ] {
        let c = classify(rhs, 0.0);
        assert_eq!(c.class, ZeroDynamicsClass::MinimumPhase, "{rhs}: {c:?}");
        let want = if rhs.starts_with("-2") { -2.0 } else { -1.0 };
        // The one-sided difference of η^p errs by O(h^(p−1)) with h = 1e-6: 0.03 for p = 1.25, 1e-3 for 1.5.
        assert!((c.eigenvalues[0][0] - want).abs() < 0.05, "{rhs}: {c:?}");
        assert!(c.note.is_none(), "{rhs}: {c:?}");
    }
}

#[test]
fn unstable_equilibria_at_the_boundary_are_non_minimum_phase() {
    for rhs in ["x2 - x2^1.5 + x1", "3*x2 + x2^1.5"] {
        let c = classify(rhs, 0.0);
        assert_eq!(c.class, ZeroDynamicsClass::NonMinimumPhase, "{rhs}: {c:?}");
    }
}

#[test]
fn interior_equilibria_are_unchanged() {
    // y0 = 2: η* > 0 with q defined on both sides; central differences as before.
    let c = classify("-x2 - x2^1.5 + x1", 2.0);
    assert_eq!(c.class, ZeroDynamicsClass::MinimumPhase);
    let eta = c.eta[0];
    let want = -1.0 - 1.5 * eta.sqrt();
    assert!((c.eigenvalues[0][0] - want).abs() < 1e-6, "{c:?}");
}
