//! `cargo xtask gen MODEL [--out DIR]`: write the generated Rust module `<name>.rs` and the Markdown derivation
//! `<name>.md` of one model file into DIR (default: `target/invsim-gen/` under the workspace root).
//!
//! A model that cannot be loaded or inverted fails with exactly the message `invsim derive` prints for it
//! (`invsim: error: …`, exit status 2).

use crate::{ensure_file_contents, Check, Failure};
use std::path::{Path, PathBuf};

/// The default output directory, relative to the workspace root.
pub const DEFAULT_OUT: &str = "target/invsim-gen";

/// The files [`run`] wrote (or found up to date).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    pub rust: PathBuf,
    pub markdown: PathBuf,
}

/// Generate `model` into `out` (or the default directory under `root`).
pub fn run(root: &Path, model: &Path, out: Option<&Path>) -> Result<Written, Failure> {
    let (rust, markdown) = invsim_codegen::generate_file(model).map_err(|e| match e {
        invsim_codegen::Error::Model(_) => Failure::user(e.to_string()),
        _ => Failure::io(e.to_string()),
    })?;
    // The module name is the file name (`pub mod <name>` is on the first line after the docs).
    let name = module_of(&rust).unwrap_or_else(|| {
        model
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "model".to_string())
    });
    let dir = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| root.join(DEFAULT_OUT));
    let written = Written {
        rust: dir.join(format!("{name}.rs")),
        markdown: dir.join(format!("{name}.md")),
    };
    ensure_file_contents(&written.rust, &rust, Check::Write)?;
    ensure_file_contents(&written.markdown, &markdown, Check::Write)?;
    Ok(written)
}

/// The name in the first `pub mod <name> {` line.
fn module_of(rust: &str) -> Option<String> {
    rust.lines().find_map(|l| {
        l.strip_prefix("pub mod ")
            .and_then(|r| r.strip_suffix(" {"))
            .map(str::to_string)
    })
}
