//! Developer tasks for the invsim workspace, run as `cargo xtask <task>` (the alias is in
//! `.cargo/config.toml`):
//!
//! * `gen MODEL [--out DIR]` — Rust source and Markdown derivation for one model file ([`gen`]);
//! * `docs [--check]` — the derived-equation documents `docs/models/<name>.md` and `docs/README.md` ([`docs`]);
//! * `golden [--bless]` — the golden copy of the generated si_engine source ([`golden`]);
//! * `figures [--check]` — the SVG figures under `docs/figures/` ([`figures`]);
//! * `vehicles [--check]` — the FASTSim vehicle library `models/vehicles/` ([`vehicles`]);
//! * `test [--no-python]` — every test, the Rust ones beside the Python package's ([`test`]).
//!
//! The tasks are a library so that the workspace's tests check exactly what the tasks write. Every file a task
//! generates goes through [`ensure_file_contents`], which writes it only if it changed or, in check mode, fails
//! naming the stale file and the command that regenerates it.

pub mod docs;
pub mod figures;
pub mod gen;
pub mod golden;
pub mod test;
pub mod vehicles;

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

/// The single-mode model files `models/*.toml` under `root`, as paths relative to `root`, sorted.
pub fn model_files(root: &Path) -> Result<Vec<PathBuf>, Failure> {
    Ok(all_model_files(root)?
        .into_iter()
        .filter(|p| !has_modes(&root.join(p)))
        .collect())
}

/// The model files with operating modes (`[modes.…]` tables) `models/*.toml` under `root`, as paths
/// relative to `root`, sorted.
pub fn modal_model_files(root: &Path) -> Result<Vec<PathBuf>, Failure> {
    Ok(all_model_files(root)?
        .into_iter()
        .filter(|p| has_modes(&root.join(p)))
        .collect())
}

fn has_modes(path: &Path) -> bool {
    std::fs::read_to_string(path).is_ok_and(|t| t.lines().any(|l| l.starts_with("[modes.")))
}

fn all_model_files(root: &Path) -> Result<Vec<PathBuf>, Failure> {
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

/// Load `root/rel`, a model with operating modes, and derive every mode, recording the file under `rel`.
pub fn derive_modal_relative(
    root: &Path,
    rel: &Path,
) -> Result<invsim_codegen::ModalDerivation, Failure> {
    let path = root.join(rel);
    match invsim_inversion::ModelFile::from_path(&path) {
        Ok(invsim_inversion::ModelFile::Modal(mut m)) => {
            // Recorded under the relative path, as `derive_relative` does.
            for mode in &mut m.modes {
                mode.model.file = rel.to_path_buf();
            }
            invsim_codegen::ModalDerivation::new(*m).map_err(|e| Failure::user(e.to_string()))
        }
        Ok(invsim_inversion::ModelFile::Single(_)) => Err(Failure::user(format!(
            "{}: expected a model with operating modes",
            rel.display()
        ))),
        Err(e) => Err(Failure::user(e.to_string())),
    }
}

/// Load and derive `root/rel`, recording the file under its repository-relative path `rel` so that everything
/// rendered from it is the same wherever the repository lives.
pub fn derive_relative(root: &Path, rel: &Path) -> Result<invsim_inversion::Derivation, Failure> {
    let path = root.join(rel);
    let bytes = std::fs::read(&path)
        .map_err(|e| Failure::io(format!("cannot read {}: {e}", path.display())))?;
    // Read under the real path (a map's CSV is found next to the model file), then record the relative one.
    let mut model = invsim_inversion::Model::from_bytes(&path, &bytes)
        .map_err(|e| Failure::user(e.to_string()))?;
    model.file = rel.to_path_buf();
    invsim_inversion::Derivation::new(model).map_err(|e| Failure::user(e.to_string()))
}

/// What [`ensure_file_contents`] does with a generated file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Check<'a> {
    /// Write the file (creating its directory) unless it already holds exactly the contents.
    Write,
    /// Write nothing: the file must hold exactly the contents; otherwise it is stale, and the error names it
    /// and `command`, the command that regenerates it.
    Exact { command: &'a str },
    /// Write nothing: the file must exist (a figure: rendered from floating-point runs whose last digits may
    /// differ between platforms, a picture rather than a golden file); otherwise the error names it and
    /// `command`.
    Exists { command: &'a str },
}

/// Make sure the generated file `path` holds `contents` (rust-analyzer's `ensure_file_contents`): with
/// [`Check::Write`] write it if it differs (returns whether it wrote); with [`Check::Exact`] or
/// [`Check::Exists`] write nothing and fail, naming the file (relative to the workspace root) and the command
/// that regenerates it, when it is stale or missing. Every task that generates files goes through here.
pub fn ensure_file_contents(
    path: &Path,
    contents: &str,
    check: Check<'_>,
) -> Result<bool, Failure> {
    let old = std::fs::read(path).ok();
    let command = match check {
        Check::Write => return write_file(path, contents, old.as_deref()),
        Check::Exact { command } | Check::Exists { command } => command,
    };
    let shown = shown_path(path);
    match old {
        None => Err(Failure::check(format!(
            "{} is missing: run `{command}`",
            shown.display()
        ))),
        Some(old) if matches!(check, Check::Exact { .. }) && old != contents.as_bytes() => Err(
            Failure::check(format!("{} is stale: run `{command}`", shown.display())),
        ),
        Some(_) => Ok(false),
    }
}

/// Write `contents` to `path` unless `old` (what it holds now) is the same; returns whether it wrote.
fn write_file(path: &Path, contents: &str, old: Option<&[u8]>) -> Result<bool, Failure> {
    if old == Some(contents.as_bytes()) {
        return Ok(false);
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)
            .map_err(|e| Failure::io(format!("cannot create {}: {e}", dir.display())))?;
    }
    std::fs::write(path, contents)
        .map_err(|e| Failure::io(format!("cannot write {}: {e}", path.display())))?;
    Ok(true)
}

/// `path` relative to the workspace root when it lies under it (both taken lexically, `..` resolved), else
/// as given.
pub fn shown_path(path: &Path) -> PathBuf {
    let (path_n, root_n) = (normalize(path), normalize(&workspace_root()));
    path_n
        .strip_prefix(&root_n)
        .map(Path::to_path_buf)
        .unwrap_or_else(|_| path.to_path_buf())
}

/// `path` with `.` and `name/..` components removed, without touching the file system.
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir if out.file_name().is_some() => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}
