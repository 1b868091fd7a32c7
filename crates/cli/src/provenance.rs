//! The provenance of a run for its summary: invsim's version and git revision, the model file's path and
//! SHA-256, the cycle (a built-in's name, or a file's path and SHA-256), the overrides of the model's data
//! (`--set`, `--signal`, `--map`, `--initial`; a file given to `--signal` or `--map` with its SHA-256) and every
//! other option of the command by its command-line name (defaults included). The summary JSON is the run's record;
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

/// Options that override the model's data, recorded as overrides (`kind` is the option's name).
const OVERRIDE_OPTIONS: [&str; 3] = ["signal", "map", "initial"];

/// `args` as a JSON object keyed by command-line option name, without the model, the cycle and `--set`
/// (recorded on their own); `--signal`, `--map` and `--initial` stay in it until [`record`] turns them into
/// overrides.
pub fn options_of(args: &impl Serialize) -> serde_json::Map<String, serde_json::Value> {
    match serde_json::to_value(args) {
        Ok(serde_json::Value::Object(map)) => map
            .into_iter()
            .filter(|(k, _)| !["model", "cycle", "set"].contains(&k.as_str()))
            .collect(),
        _ => serde_json::Map::new(),
    }
}

/// `--signal`, `--map` and `--initial` values (`NAME=VALUE` strings) taken out of `options` as overrides: a
/// number stays a number; anything else is a file, recorded as `{path, sha256}` so that two runs with
/// different contents under one path are told apart.
fn data_overrides(
    options: &mut serde_json::Map<String, serde_json::Value>,
) -> Result<Vec<Override>, Failure> {
    let mut out = Vec::new();
    for kind in OVERRIDE_OPTIONS {
        let Some(serde_json::Value::Array(items)) = options.remove(kind) else {
            continue;
        };
        for item in items.iter().filter_map(|v| v.as_str()) {
            let Some((name, value)) = item.split_once('=') else {
                continue;
            };
            let value = value.trim();
            let value = match value
                .parse::<f64>()
                .ok()
                .and_then(serde_json::Number::from_f64)
            {
                Some(n) => serde_json::Value::Number(n),
                None => {
                    serde_json::json!({ "path": value, "sha256": sha256_file(Path::new(value))? })
                }
            };
            out.push(Override {
                kind: kind.to_string(),
                name: name.trim().to_string(),
                value,
            });
        }
    }
    Ok(out)
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
pub fn record(mut run: RunRecord<'_>) -> Result<Provenance, Failure> {
    let data = data_overrides(&mut run.options)?;
    let model_sha = match &run.info.source_hash {
        Some(h) => h.clone(),
        None => sha256_file(run.model)?,
    };
    let builtin = crate::cycle_spec::is_builtin(run.cycle_spec);
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
        overrides: overrides(run.sets).into_iter().chain(data).collect(),
        options: run.options,
    })
}
