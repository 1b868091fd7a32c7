//! `cargo xtask golden [--bless]`: the golden copy of the generated `si_engine` source,
//! `crates/codegen/tests/golden/si_engine.rs`. Without `--bless` it only compares (the test `golden` does the
//! same); with `--bless` it writes the current output. Changes to generated code are thus always reviewed as
//! a diff of this file, never taken silently.

use crate::{derive_relative, write_if_changed, Failure};
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

/// Compare with (or with `bless`, overwrite) the golden file; returns the golden file's path.
pub fn run(root: &Path, bless: bool) -> Result<PathBuf, Failure> {
    let text = render(root)?;
    let path = root.join(GOLDEN);
    if bless {
        write_if_changed(&path, &text)?;
        return Ok(path);
    }
    match std::fs::read_to_string(&path) {
        Ok(old) if old == text => Ok(path),
        Ok(_) => Err(Failure::check(format!(
            "{GOLDEN} differs from the generated source of {MODEL}: review the change, then run `cargo xtask golden --bless`"
        ))),
        Err(e) => Err(Failure::check(format!("cannot read {GOLDEN} ({e}): run `cargo xtask golden --bless`"))),
    }
}
