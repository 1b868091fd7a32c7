//! Developer tasks for the invsim workspace, run as `cargo xtask <task>` (the alias is in
//! `.cargo/config.toml`):
//!
//! * `gen MODEL [--out DIR]` — Rust source and Markdown derivation for one model file ([`gen`]);
//! * `docs [--check]` — the derived-equation documents `docs/models/<name>.md` and `docs/README.md` ([`docs`]);
//! * `golden [--bless]` — the golden copy of the generated si_engine source ([`golden`]);
//! * `figures [--check]` — the SVG figures under `docs/figures/` ([`figures`]).
//!
//! The tasks are a library so that the workspace's tests check exactly what the tasks write.

pub mod docs;
pub mod figures;
pub mod gen;
pub mod golden;

use std::path::{Path, PathBuf};

/// A task that failed: the message for stderr and the process exit status.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct Failure {
    pub message: String,
    pub code: u8,
}

impl Failure {
    /// A problem with the user's input (a bad model file, stale files under `--check`): exit status 2 for
    /// inputs, as `invsim` uses it.
    pub fn user(message: impl Into<String>) -> Failure {
        Failure {
            message: message.into(),
            code: 2,
        }
    }
    /// A check that found differences: exit status 1.
    pub fn check(message: impl Into<String>) -> Failure {
        Failure {
            message: message.into(),
            code: 1,
        }
    }
    /// An I/O problem: exit status 1.
    pub fn io(message: impl Into<String>) -> Failure {
        Failure {
            message: message.into(),
            code: 1,
        }
    }
}

/// The workspace root (the directory above `xtask/`).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

/// The model files `models/*.toml` under `root`, as paths relative to `root`, sorted.
pub fn model_files(root: &Path) -> Result<Vec<PathBuf>, Failure> {
    let dir = root.join("models");
    let entries = std::fs::read_dir(&dir)
        .map_err(|e| Failure::io(format!("cannot read {}: {e}", dir.display())))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .filter_map(|p| p.file_name().map(|f| Path::new("models").join(f)))
        .collect();
    files.sort();
    Ok(files)
}

/// Load and derive `root/rel`, recording the file under its repository-relative path `rel` so that everything
/// rendered from it is the same wherever the repository lives.
pub fn derive_relative(root: &Path, rel: &Path) -> Result<invsim_inversion::Derivation, Failure> {
    let path = root.join(rel);
    let bytes = std::fs::read(&path)
        .map_err(|e| Failure::io(format!("cannot read {}: {e}", path.display())))?;
    let model = invsim_inversion::Model::from_bytes(rel, &bytes)
        .map_err(|e| Failure::user(e.to_string()))?;
    invsim_inversion::Derivation::new(model).map_err(|e| Failure::user(e.to_string()))
}

/// Write `text` to `path` (creating directories) unless it already holds exactly that; returns whether it
/// wrote.
pub fn write_if_changed(path: &Path, text: &str) -> Result<bool, Failure> {
    if std::fs::read(path).is_ok_and(|old| old == text.as_bytes()) {
        return Ok(false);
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)
            .map_err(|e| Failure::io(format!("cannot create {}: {e}", dir.display())))?;
    }
    std::fs::write(path, text)
        .map_err(|e| Failure::io(format!("cannot write {}: {e}", path.display())))?;
    Ok(true)
}
