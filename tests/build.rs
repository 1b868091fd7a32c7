//! Compiles test models with `invsim-codegen`, so that the tests compare compiled code (not strings) with the
//! interpreter:
//!
//! * `../shared/models/*.toml` (the acceptance models, outside the repository) when that directory exists:
//!   every model that derives is compiled into `shared`, the others (the `bad_*` files) are listed in
//!   `shared::SKIPPED`; the cfg `has_shared` says whether the directory was found;
//! * `tests/models/*.toml`, this crate's own models for paths the built-in models do not reach (Newton's
//!   method for ψ⁻¹, every function of the expression language), into `extra`;
//! * `tests/models/known/*.toml`, the known-answer models whose exact solutions are in `src/known.rs`, into
//!   `known`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("invsim-tests: error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn toml_files(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    Ok(files)
}

/// Compile the models of `dir` that derive into `out/<sub>/`, with a registry that also lists the files that
/// did not derive (`SKIPPED`).
fn compile_dir(dir: &Path, out: &Path, sub: &str) -> Result<(), Box<dyn std::error::Error>> {
    println!("cargo:rerun-if-changed={}", dir.display());
    let out = out.join(sub);
    let mut generated = Vec::new();
    let mut skipped = Vec::new();
    for file in toml_files(dir)? {
        match invsim_codegen::Builder::new()
            .model(&file)
            .out_dir(&out)
            .compile()
        {
            Ok(g) => generated.extend(g),
            Err(invsim_codegen::Error::Model(e)) => {
                let name = file
                    .file_name()
                    .map(|f| f.to_string_lossy().into_owned())
                    .unwrap_or_default();
                skipped.push((name, e.to_string()));
            }
            Err(e) => return Err(e.into()),
        }
    }
    let mut registry = invsim_codegen::registry(&generated)?;
    registry.push_str("\n/// Model files that did not derive (file name, error); not compiled.\n");
    registry.push_str("pub const SKIPPED: &[(&str, &str)] = &[\n");
    for (f, e) in &skipped {
        registry.push_str(&format!("    ({f:?}, {e:?}),\n"));
    }
    registry.push_str("];\n");
    std::fs::write(out.join("registry.rs"), registry)?;
    Ok(())
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    println!("cargo::rustc-check-cfg=cfg(has_shared)");
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR")?);
    let out = PathBuf::from(std::env::var("OUT_DIR")?);
    let shared = manifest.join("../../shared/models");
    if shared.is_dir() {
        compile_dir(&shared, &out, "shared")?;
        println!("cargo:rustc-cfg=has_shared");
    } else {
        // Watch for the directory to appear.
        println!(
            "cargo:rerun-if-changed={}",
            manifest.join("../..").display()
        );
    }
    compile_dir(&manifest.join("models"), &out, "extra")?;
    compile_dir(&manifest.join("models/known"), &out, "known")?;
    Ok(())
}
