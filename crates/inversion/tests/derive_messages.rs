//! Nonsense that used to derive silently is refused with a located, typed error: constant subexpressions that
//! are not finite at the parameters' values (a literal `1/0`, β = 1/m with m = −0.0, `sqrt(-1)`, `log(0)`),
//! and nonzero number literals that underflow to 0 (`1e-400`) in parameter values and expressions.

use invsim_inversion::{Derivation, DeriveError, Model, ModelErrorKind};
use std::path::Path;

const TEMPLATE: &str =
    "[parameters]\nm = M\n[states]\nx1 = { rhs = \"x2\" }\nx2 = { rhs = \"RHS\" }\n\
                        [input]\nname = \"u\"\n[output]\nname = \"y\"\nh = \"x1\"\n";

fn text(m: &str, rhs: &str) -> String {
    TEMPLATE.replace("M", m).replace("RHS", rhs)
}

fn derive(text: &str) -> Result<Derivation, String> {
    let model = Model::from_str(Path::new("m.toml"), text).map_err(|e| e.to_string())?;
    Derivation::new(model).map_err(|e| e.to_string())
}

#[test]
fn constant_parts_that_are_not_finite_are_refused_naming_them() {
    for (m, rhs, shown) in [
        ("2.0", "1/0*x1 + u/m", "1/0"),
        ("-0.0", "-x1 + u/m", "1/m"),
        ("0.0", "-x1 + u/m", "1/m"),
        ("2.0", "sqrt(-1)*x1 + u", "sqrt(-1)"),
        ("0", "log(m)*x1 + u", "log(m)"),
        ("-1", "(-x1 + u)/sqrt(m)", "sqrt(m)"),
    ] {
        // The reader refuses it where the part is written in the rhs of x2 (line 5, from column 15).
        let e = Model::from_str(Path::new("m.toml"), &text(m, rhs)).expect_err("not finite");
        assert_eq!(e.kind, ModelErrorKind::NonFinite, "{rhs}");
        let msg = e.to_string();
        let column = 15 + rhs.find(shown).unwrap_or(0);
        assert!(
            msg.starts_with(&format!("m.toml:5:{column}:")) && msg.contains("state `x2`"),
            "{msg}"
        );
        assert!(msg.contains(shown), "{rhs}: {msg}");
    }
}

#[test]
fn the_derivation_refuses_a_model_built_with_non_finite_constants() {
    // A model whose parameter is changed after reading (as a program may do) is still refused by the
    // derivation, which runs the same check without positions.
    let mut model = Model::from_str(Path::new("m.toml"), &text("2.0", "-x1 + u/m")).expect("loads");
    model.parameters[0].value = -0.0;
    match Derivation::new(model) {
        Err(e @ DeriveError::NotFinite { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains("m.toml") && msg.contains("1/m"), "{msg}");
        }
        Err(e) => panic!("unexpected error {e}"),
        Ok(d) => panic!("derived, β = {}", d.pool().display(d.beta)),
    }
}

#[test]
fn finite_models_still_derive() {
    for (m, rhs) in [
        ("2.0", "-x1 + u/m"),
        ("1e-300", "-x1/m + u"),
        ("4", "sqrt(m)*x1 + u"),
    ] {
        assert!(derive(&text(m, rhs)).is_ok(), "{rhs}");
    }
}

#[test]
fn underflowing_literals_are_errors_with_their_position() {
    for (m, rhs, at) in [
        ("1e-400", "-x1 + u", "m.toml:2:5:"),
        ("-2.5E-999", "-x1 + u", "m.toml:2:5:"),
        ("2.0", "-1e-400*x1 + u", "m.toml:5:16:"),
        ("2.0", "-x1 + 3.0e-500 + u", "m.toml:5:21:"),
    ] {
        let e = Model::from_str(Path::new("m.toml"), &text(m, rhs)).expect_err("underflow");
        assert_eq!(e.kind, ModelErrorKind::NonFinite);
        let msg = e.to_string();
        assert!(msg.starts_with(at) && msg.contains("read as 0"), "{msg}");
    }
    // Zero written as zero, and tiny representable values, are fine.
    for (m, rhs) in [
        ("0e-400", "-x1 + u"),
        ("5e-324", "-x1 + u"),
        ("2.0", "-x1 + 0.0e-999 + u"),
    ] {
        assert!(
            Model::from_str(Path::new("m.toml"), &text(m, rhs)).is_ok(),
            "{m} {rhs}"
        );
    }
}
