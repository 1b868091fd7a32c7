//! Provenance of a run: what produced a summary — invsim's version and git revision, the model file and its
//! SHA-256, the cycle (a built-in's name, or a file's path and SHA-256), every override of the model
//! (`--set`, `--signal`, `--map`, `--initial`: `{kind, name, value}`, a file as `{path, sha256}`) and every option. The summary JSON is the
//! run's provenance record (the CSV carries none: a leading comment line is not skipped by pandas' or polars'
//! default CSV readers). The command line fills it in ([`crate::Summary::provenance`]).

use std::fmt::Write as _;

use serde::Serialize;

/// A file a run read, with the SHA-256 of its bytes (lower-case hex).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FileRecord {
    pub path: String,
    pub sha256: String,
}

/// The cycle of a run: a built-in (`file` absent) or a file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CycleRecord {
    /// The built-in's name or the name the file's cycle was given.
    pub name: String,
    pub builtin: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<FileRecord>,
}

/// One override of the model's data: `kind` `set` (a parameter, `value` a number), `signal` (a number, or a
/// file as `{path, sha256}`), `map` (a file) or `initial` (a number).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Override {
    pub kind: String,
    pub name: String,
    pub value: serde_json::Value,
}

/// What produced a summary (JSON `provenance`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Provenance {
    /// invsim's version (the package version).
    pub invsim_version: String,
    /// The git revision the binary was built from, where known.
    pub git_revision: Option<String>,
    /// `simulate` or `forward`.
    pub command: String,
    pub model_file: FileRecord,
    pub cycle: CycleRecord,
    /// In command-line order.
    pub overrides: Vec<Override>,
    /// Every option of the command as run (defaults included), by its command-line name.
    pub options: serde_json::Map<String, serde_json::Value>,
}

impl Provenance {
    /// Summary text: the version, the files with their hashes, the overrides and the options.
    pub fn write_text(&self, s: &mut String) {
        let _ = write!(s, "invsim: {}", self.invsim_version);
        if let Some(rev) = &self.git_revision {
            let _ = write!(s, " (rev {rev})");
        }
        s.push('\n');
        let f = &self.model_file;
        let _ = writeln!(s, "model file: {} (sha256 {})", f.path, f.sha256);
        if let Some(f) = &self.cycle.file {
            let _ = writeln!(s, "cycle file: {} (sha256 {})", f.path, f.sha256);
        }
        if !self.overrides.is_empty() {
            let list: Vec<String> = self
                .overrides
                .iter()
                .map(|o| format!("--{} {}={}", o.kind, o.name, plain(&o.value)))
                .collect();
            let _ = writeln!(s, "overrides: {}", list.join(" "));
        }
        let options: Vec<String> = self
            .options
            .iter()
            .map(|(k, v)| format!("{k}={}", plain(v)))
            .collect();
        let _ = writeln!(s, "options: {}", options.join(", "));
    }
}

/// A JSON value as a user writes it on a command line (strings without quotes, `null` as `none`, a file
/// `{path, sha256}` as `PATH (sha256 …)`).
fn plain(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Null => "none".to_string(),
        serde_json::Value::Object(o) => match (o.get("path"), o.get("sha256")) {
            (Some(serde_json::Value::String(p)), Some(serde_json::Value::String(h))) => {
                format!("{p} (sha256 {h})")
            }
            _ => v.to_string(),
        },
        other => other.to_string(),
    }
}
