//! `cargo xtask golden [--bless]`: the golden copy of the generated `si_engine` source,
//! `crates/codegen/tests/golden/si_engine.rs`. Without `--bless` it only compares (the test `golden` does the
//! same); with `--bless` it writes the current output. Changes to generated code are thus always reviewed as
//! a diff of this file, never taken silently.

use crate::{derive_relative, ensure_file_contents, Check, Failure};
use std::path::{Path, PathBuf};

/// The model the golden file is generated from, relative to the root.
pub const MODEL: &str = "models/si_engine.toml";
/// The golden file, relative to the root.
pub const GOLDEN: &str = "crates/codegen/tests/golden/si_engine.rs";

/// The current generated source of [`MODEL`].
pub fn render(root: &Path) -> Result<String, Failure> {
    let rel = Path::new(MODEL);
    let d = derive_relative(root, rel)?;
    let name = rel
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    invsim_codegen::generate(&d, &name).map_err(|e| Failure::io(e.to_string()))
}

/// The command that rewrites the golden file.
pub const BLESS: &str = "cargo xtask golden --bless";

/// Compare with (or with `bless`, overwrite) the golden file; returns the golden file's path.
pub fn run(root: &Path, bless: bool) -> Result<PathBuf, Failure> {
    let text = render(root)?;
    let path = root.join(GOLDEN);
    if bless {
        ensure_file_contents(&path, &text, Check::Write)?;
        return Ok(path);
    }
    ensure_file_contents(&path, &text, Check::Exact { command: BLESS }).map_err(|f| Failure {
        message: format!(
            "{} (the generated source of {MODEL} changed: review the change first)",
            f.message
        ),
        ..f
    })?;
    Ok(path)
}
