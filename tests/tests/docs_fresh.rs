//! The committed derived-equation documents (`docs/models/*.md`, `docs/README.md`) are what
//! `cargo xtask docs` renders from `models/*.toml` now.

use std::path::Path;

#[test]
fn derived_equation_docs_are_fresh() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let stale = xtask::docs::stale(&root).unwrap_or_else(|e| panic!("{e}"));
    let messages: Vec<String> = stale
        .iter()
        .map(|p| {
            let shown = p
                .strip_prefix("docs")
                .map(|q| Path::new("docs").join(q))
                .unwrap_or_else(|_| p.clone());
            format!("{} is stale: run `cargo xtask docs`", shown.display())
        })
        .collect();
    assert!(messages.is_empty(), "{}", messages.join("\n"));
}

#[test]
fn every_model_has_a_document_in_the_index() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let index =
        std::fs::read_to_string(root.join("docs/README.md")).expect("docs/README.md exists");
    let modal = invsim_models::MODAL_MODELS.iter().map(|m| m.0);
    for name in invsim_models::names().iter().copied().chain(modal) {
        assert!(
            index.contains(&format!("(models/{name}.md)")),
            "docs/README.md does not link {name}"
        );
        assert!(
            root.join(format!("docs/models/{name}.md")).is_file(),
            "docs/models/{name}.md is missing"
        );
    }
}
