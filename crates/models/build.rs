//! Generates a Rust module for every `models/*.toml` of the repository (one module per mode, in a module of
//! its own, for a model with operating modes), plus a registry of them, into
//! `OUT_DIR` (see `src/lib.rs`). A model that fails to derive fails the build with the message
//! `invsim derive` would print.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("invsim-models: error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR")?);
    let models_dir = manifest.join("../../models");
    // New or removed files change the directory; edited files are watched one by one by the Builder.
    println!("cargo:rerun-if-changed={}", models_dir.display());
    let files = model_files(&models_dir)?;
    let out = PathBuf::from(std::env::var("OUT_DIR")?);
    let generated = invsim_codegen::Builder::new()
        .models(&files)
        .out_dir(&out)
        .compile()?;
    let registry = invsim_codegen::registry(&generated)?;
    std::fs::write(out.join("registry.rs"), registry)?;
    Ok(())
}

/// The `*.toml` files of `dir`, sorted by name.
fn model_files(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    Ok(files)
}
