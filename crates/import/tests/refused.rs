//! Vehicle files the importer refuses: plug-in hybrids and unknown powertrain types (with the type named), malformed
//! YAML (with line and column), YAML nested deeper than the cap (at once, with line and column), a file
//! without a total mass.

use crate::common::vehicles_dir;
use invsim_import::{import_fastsim, ImportError};

#[test]
fn plug_in_hybrid_and_unknown_types_are_refused_by_name() {
    for kind in ["PHEV", "FuelCell"] {
        let text = format!("name: x\npt_type:\n  {kind}:\n    res: {{}}\nchassis: {{}}\n");
        match import_fastsim(&text, "x.yaml") {
            Err(ImportError::Powertrain { kind: k, reason }) => {
                assert_eq!(k, kind);
                assert!(
                    reason.contains("Conv") && reason.contains("BEV") && reason.contains("HEV"),
                    "{reason}"
                );
            }
            other => panic!("{kind}: {other:?}"),
        }
    }
}

/// The plug-in hybrid refusal is a finished sentence: what is imported, and what to do for a plug-in hybrid.
#[test]
fn plug_in_hybrid_refusal_says_what_to_do() {
    let text = "name: x\npt_type:\n  PHEV:\n    res: {}\nchassis: {}\n";
    let e = import_fastsim(text, "x.yaml").unwrap_err().to_string();
    assert_eq!(
        e,
        "powertrain type `PHEV` is not supported: plug-in hybrids are not imported (their charge-depleting \
         operation is not modelled); conventional (Conv), battery-electric (BEV) and hybrid (HEV) vehicles \
         are. For a plug-in hybrid, write its model by hand with one mode per operating state (`[modes]`, see \
         docs/modes.md)"
    );
}

#[test]
fn malformed_yaml_gives_line_and_column() {
    let text = "name: x\npt_type:\n  Conv: [1, 2\nchassis: {}\n";
    match import_fastsim(text, "x.yaml") {
        Err(ImportError::Yaml { line, column, .. }) => {
            assert!(line >= 3 && column >= 1, "{line}:{column}")
        }
        other => panic!("{other:?}"),
    }
    let e = import_fastsim("a: b: c\n", "x.yaml").unwrap_err();
    assert!(e.to_string().starts_with("1:"), "{e}");
}

#[test]
fn deep_nesting_is_refused_at_once_with_line_and_column() {
    // 10^5 unclosed `[` (the YAML reader took time quadratic in the depth, then hit its recursion limit):
    // refused at the `[` that opens level 65 (the top-level mapping is the first level).
    let text = format!("name: x\nmass_kilograms: {}\n", "[".repeat(100_000));
    match import_fastsim(&text, "x.yaml") {
        Err(ImportError::Yaml {
            line,
            column,
            message,
        }) => {
            let cap = invsim_import::MAX_YAML_DEPTH;
            assert_eq!((line, column), (2, 16 + cap), "{message}");
            assert!(
                message.contains(&format!("deeper than {cap} levels")),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn missing_mass_is_named() {
    let text = std::fs::read_to_string(vehicles_dir().join("ford_fusion_2012.yaml")).unwrap();
    let text = text.replace(
        "\nmass_kilograms: 1644.2724500334996",
        "\nmass_kilograms: ~",
    );
    let e = import_fastsim(&text, "f.yaml").unwrap_err();
    assert!(e.to_string().contains("`mass_kilograms`"), "{e}");
}
