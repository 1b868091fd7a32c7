//! The build-script API: what `Builder::compile` writes, when it rewrites, and how it fails.

use std::path::{Path, PathBuf};

fn models_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("invsim-codegen-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn writes_once_and_only_when_the_contents_change() {
    let out = scratch("builder");
    let model = models_dir().join("si_engine.toml");
    let first = invsim_codegen::Builder::new()
        .model(&model)
        .out_dir(&out)
        .cargo_metadata(false)
        .compile()
        .expect("si_engine compiles");
    assert_eq!(first.len(), 1);
    let g = &first[0];
    assert_eq!(
        (g.name.as_str(), g.module.as_str()),
        ("si_engine", "si_engine")
    );
    assert!(g.written);
    assert_eq!(g.path, out.join("si_engine.rs"));
    let text = std::fs::read_to_string(&g.path).expect("written");
    assert!(text.starts_with(&invsim_codegen::header("si_engine.toml", &g.source_hash)));
    assert!(syn::parse_file(&text).is_ok(), "the file is Rust");

    let again = invsim_codegen::Builder::new()
        .model(&model)
        .out_dir(&out)
        .cargo_metadata(false)
        .compile()
        .expect("si_engine compiles");
    assert!(!again[0].written, "unchanged contents are not rewritten");

    std::fs::write(&g.path, "stale").expect("overwrite");
    let third = invsim_codegen::Builder::new()
        .model(&model)
        .out_dir(&out)
        .cargo_metadata(false)
        .compile()
        .expect("si_engine compiles");
    assert!(third[0].written);
    assert_eq!(std::fs::read_to_string(&g.path).expect("rewritten"), text);

    let registry = invsim_codegen::registry(&third).expect("registry");
    assert!(registry.contains("\"si_engine\" => Some(Box::new(si_engine::Model::default()))"));
    assert!(registry.contains(&g.source_hash));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_bad_model_fails_with_the_derive_message() {
    let out = scratch("bad");
    let bad = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../xtask/tests/bad_model.toml");
    let err = invsim_codegen::Builder::new()
        .model(&bad)
        .out_dir(&out)
        .cargo_metadata(false)
        .compile()
        .expect_err("not invertible");
    let expected = invsim_inversion::derive_file(&bad).expect_err("not invertible");
    assert_eq!(err.to_string(), expected.to_string());
    assert!(!out.join("bad_model.rs").exists());
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn two_models_with_one_module_name_are_refused() {
    let out = scratch("dup");
    let model = models_dir().join("si_engine.toml");
    let err = invsim_codegen::Builder::new()
        .models([&model, &model])
        .out_dir(&out)
        .cargo_metadata(false)
        .compile()
        .expect_err("duplicate");
    assert!(
        matches!(err, invsim_codegen::Error::DuplicateModule { .. }),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn generation_is_deterministic() {
    let (a, ma) =
        invsim_codegen::generate_file(&models_dir().join("si_engine.toml")).expect("generates");
    let (b, mb) =
        invsim_codegen::generate_file(&models_dir().join("si_engine.toml")).expect("generates");
    assert_eq!(a, b);
    assert_eq!(ma, mb);
}
