//! The provenance of a run for its summary: invsim's version and git revision, the model file's path and
//! SHA-256, the cycle (a built-in's name, or a file's path and SHA-256), the `--set` overrides and every
//! option of the command by its command-line name (defaults included). The summary JSON is the run's record;
//! two runs that differ in anything but the output paths have different summaries.

use std::io::Read;
use std::path::Path;

use invsim_model_api::ModelInfo;
use invsim_runtime::{Cycle, CycleRecord, FileRecord, Override, Provenance};
use serde::Serialize;
use sha2::{Digest, Sha256};

use crate::error::Failure;

/// The git revision the binary was built from (`build.rs`), `None` outside a git checkout.
fn git_revision() -> Option<String> {
    let rev = env!("INVSIM_GIT_REVISION");
    (rev != "unknown").then(|| rev.to_string())
}

/// SHA-256 of the file at `path`, lower-case hex, read in pieces.
fn sha256_file(path: &Path) -> Result<String, Failure> {
    let cannot = |e: std::io::Error| Failure::io(format!("cannot read {}: {e}", path.display()));
    let mut file = std::fs::File::open(path).map_err(cannot)?;
    let mut hasher = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = file.read(&mut buf).map_err(cannot)?;
        if n == 0 {
            break;
        }
        hasher.update(&buf[..n]);
    }
    Ok(hasher
        .finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect())
}

/// `args` as a JSON object keyed by command-line option name, without the model, the cycle and the overrides
/// (recorded on their own).
pub fn options_of(args: &impl Serialize) -> serde_json::Map<String, serde_json::Value> {
    match serde_json::to_value(args) {
        Ok(serde_json::Value::Object(map)) => map
            .into_iter()
            .filter(|(k, _)| !["model", "cycle", "set"].contains(&k.as_str()))
            .collect(),
        _ => serde_json::Map::new(),
    }
}

/// `--set NAME=VALUE` as overrides (already checked by the run; a value that is not a number stays text).
fn overrides(sets: &[String]) -> Vec<Override> {
    sets.iter()
        .filter_map(|s| s.split_once('='))
        .map(|(name, value)| Override {
            kind: "set".to_string(),
            name: name.trim().to_string(),
            value: value
                .trim()
                .parse::<f64>()
                .ok()
                .and_then(|v| serde_json::Number::from_f64(v).map(serde_json::Value::Number))
                .unwrap_or_else(|| serde_json::Value::String(value.trim().to_string())),
        })
        .collect()
}

/// What the run of `command` read and how it was asked for.
pub struct RunRecord<'a> {
    pub command: &'static str,
    pub model: &'a Path,
    pub info: &'a ModelInfo,
    pub cycle_spec: &'a str,
    pub cycle: &'a Cycle,
    pub sets: &'a [String],
    pub options: serde_json::Map<String, serde_json::Value>,
}

/// The provenance of a run.
pub fn record(run: RunRecord<'_>) -> Result<Provenance, Failure> {
    let model_sha = match &run.info.source_hash {
        Some(h) => h.clone(),
        None => sha256_file(run.model)?,
    };
    let builtin = Cycle::builtin(run.cycle_spec).is_some();
    let file = if builtin {
        None
    } else {
        Some(FileRecord {
            path: run.cycle_spec.to_string(),
            sha256: sha256_file(Path::new(run.cycle_spec))?,
        })
    };
    Ok(Provenance {
        invsim_version: env!("CARGO_PKG_VERSION").to_string(),
        git_revision: git_revision(),
        command: run.command.to_string(),
        model_file: FileRecord {
            path: run.model.display().to_string(),
            sha256: model_sha,
        },
        cycle: CycleRecord {
            name: run.cycle.name.clone(),
            builtin,
            file,
        },
        overrides: overrides(run.sets),
        options: run.options,
    })
}
