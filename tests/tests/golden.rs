//! The generated source for `models/si_engine.toml` equals the reviewed copy in
//! `crates/codegen/tests/golden/si_engine.rs`; a change to the generator or the model shows up as a diff of
//! that file, accepted explicitly with `cargo xtask golden --bless`.

use std::path::Path;

#[test]
fn generated_si_engine_source_matches_the_golden_file() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let generated = xtask::golden::render(&root).unwrap_or_else(|e| panic!("{e}"));
    let golden = std::fs::read_to_string(root.join(xtask::golden::GOLDEN)).unwrap_or_default();
    if generated != golden {
        let first = generated
            .lines()
            .zip(golden.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(0);
        panic!(
            "{} differs from the generated source of {} (first difference at line {}): review the change, then run \
             `cargo xtask golden --bless`",
            xtask::golden::GOLDEN,
            xtask::golden::MODEL,
            first + 1
        );
    }
}

#[test]
fn golden_file_is_what_the_models_crate_compiles() {
    // The header names the model file and its hash; invsim-models compiles the same file.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let golden = std::fs::read_to_string(root.join(xtask::golden::GOLDEN)).unwrap_or_default();
    let hash = invsim_models::MODELS
        .iter()
        .find(|m| m.0 == "si_engine")
        .map(|m| m.1)
        .unwrap_or("none");
    let header = invsim_codegen::header("si_engine.toml", hash);
    assert!(
        golden.starts_with(&header),
        "golden header is not {header:?}: run `cargo xtask golden --bless`"
    );
}
