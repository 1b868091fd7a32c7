//! Choosing the engine that evaluates a model: compiled code for a built-in model whose file matches, else the
//! interpreter tape built from the model file.
//!
//! A model file matches a built-in model when the SHA-256 of its bytes equals that of a file in `models/` the
//! binary was built with (`invsim_models::by_hash`): then the code generated from exactly that file runs.

use std::path::Path;

use clap::ValueEnum;
use invsim_inversion::{Derivation, Interpreter};
use invsim_model_api::InverseModel;
use invsim_runtime::Cycle;

use crate::error::Failure;

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum EngineChoice {
    /// Compiled code when the model file matches a built-in model, else the interpreter.
    Auto,
    /// Compiled code; an error if the model is not built in.
    Compiled,
    /// The interpreter tape.
    Interpreted,
}

/// A loaded model behind the runtime's trait, with the name of the engine that runs it.
pub enum LoadedModel {
    Interpreted(Box<Interpreter>),
    /// Generated code for a built-in model (`invsim-models`).
    Compiled(Box<dyn InverseModel>),
}

impl LoadedModel {
    pub fn engine_name(&self) -> &'static str {
        match self {
            LoadedModel::Interpreted(_) => "interpreted",
            LoadedModel::Compiled(_) => "compiled",
        }
    }
    pub fn as_model(&self) -> &dyn InverseModel {
        match self {
            LoadedModel::Interpreted(m) => m.as_ref(),
            LoadedModel::Compiled(m) => m.as_ref(),
        }
    }
    /// Replace a lookup map's grid and values (`--map NAME=FILE.csv`).
    pub fn set_map(
        &mut self,
        name: &str,
        data: (&[f64], Option<&[f64]>, &[f64]),
    ) -> Result<(), invsim_model_api::ModelError> {
        match self {
            LoadedModel::Interpreted(m) => m.set_map(name, data),
            LoadedModel::Compiled(m) => m.set_map(name, data),
        }
    }
    pub fn set_param(
        &mut self,
        name: &str,
        value: f64,
    ) -> Result<(), invsim_model_api::ModelError> {
        match self {
            LoadedModel::Interpreted(m) => m.set_param(name, value),
            LoadedModel::Compiled(m) => m.set_param(name, value),
        }
    }
}

fn interpreted(d: &Derivation) -> Result<LoadedModel, Failure> {
    let interp = Interpreter::new(d).map_err(|e| Failure::user(e.to_string()))?;
    Ok(LoadedModel::Interpreted(Box::new(interp)))
}

/// Bytes of a model file read to compare it with the built-in models; a larger file is none of them (the
/// reader's own limits then apply).
const MAX_COMPARED_BYTES: u64 = 1 << 20;

/// The model file's bytes, if it can be read and is at most [`MAX_COMPARED_BYTES`] long. A command asks twice
/// (does the file have modes, which engine runs it); the last answer is kept.
fn file_bytes(path: &Path) -> Option<std::sync::Arc<[u8]>> {
    use std::sync::{Arc, Mutex};
    type Last = Option<(std::path::PathBuf, Option<Arc<[u8]>>)>;
    static LAST: Mutex<Last> = Mutex::new(None);
    let mut last = LAST.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, b)) = last.as_ref().filter(|(p, _)| p == path) {
        return b.clone();
    }
    let b = read_bounded(path).map(Arc::from);
    *last = Some((path.to_path_buf(), b.clone()));
    b
}

/// The compiled model built from a file with exactly the bytes of `path` (no hash computed).
fn builtin_of(path: &Path) -> Option<Box<dyn invsim_model_api::InverseModel>> {
    file_bytes(path).and_then(|b| invsim_models::by_source(&b))
}

/// The file's bytes, read through the cap into a buffer sized by the file's length where it has one (one
/// `read` for a model file instead of a dozen doubling ones).
fn read_bounded(path: &Path) -> Option<Vec<u8>> {
    use std::io::Read;
    let file = std::fs::File::open(path).ok()?;
    let hint = file
        .metadata()
        .map_or(0, |m| m.len())
        .min(MAX_COMPARED_BYTES);
    // One byte more than the length, so that the read that finds the end needs no growth.
    let mut bytes = Vec::with_capacity(hint as usize + 1);
    file.take(MAX_COMPARED_BYTES + 1)
        .read_to_end(&mut bytes)
        .ok()?;
    (bytes.len() as u64 <= MAX_COMPARED_BYTES).then_some(bytes)
}

/// Is the file byte-for-byte a built-in ordinary model? Then it has no modes and reads without errors, which
/// the commands need not read the file to know (models with modes have a registry of their own).
pub fn is_builtin_single(path: &Path) -> bool {
    builtin_of(path).is_some()
}

/// Load `path` with the requested engine. A file whose SHA-256 matches a built-in model runs its compiled code
/// (with `auto` or `compiled`) without being derived: it is byte-for-byte the file the code was generated from,
/// so its derivation succeeds and the compiled model carries everything the run needs (its `ModelInfo` and
/// every function). Any other file is read and derived first, so a bad file gives the same error whichever
/// engine was asked for.
pub fn load(path: &Path, choice: EngineChoice) -> Result<LoadedModel, Failure> {
    if choice != EngineChoice::Interpreted {
        if let Some(m) = builtin_of(path) {
            return Ok(LoadedModel::Compiled(m));
        }
    }
    let d = invsim_inversion::derive_file(path).map_err(|e| Failure::user(e.to_string()))?;
    let hash = &d.model.source_hash;
    match choice {
        EngineChoice::Interpreted => interpreted(&d),
        EngineChoice::Auto => match invsim_models::by_hash(hash) {
            Some(m) => Ok(LoadedModel::Compiled(m)),
            None => interpreted(&d),
        },
        EngineChoice::Compiled => invsim_models::by_hash(hash).map(LoadedModel::Compiled).ok_or_else(|| {
            Failure::user(format!(
                "no compiled code for `{}`: the file (sha256 {hash}) matches none of the built-in models this \
                 binary was built with ({}; a built-in model must be byte-for-byte the file in models/); use \
                 --engine interpreted, or --engine auto to fall back to the interpreter",
                path.display(),
                invsim_models::names().join(", ")
            ))
        }),
    }
}

/// Parse `NAME=VALUE`.
pub fn parse_set(s: &str) -> Result<(String, f64), Failure> {
    let (name, value) = s.split_once('=').ok_or_else(|| {
        Failure::user(format!(
            "--set `{s}`: expected NAME=VALUE, e.g. --set m=1500"
        ))
    })?;
    let v: f64 = value
        .trim()
        .parse()
        .map_err(|_| Failure::user(format!("--set `{s}`: `{}` is not a number", value.trim())))?;
    if !v.is_finite() {
        return Err(Failure::user(format!(
            "--set `{s}`: the value must be finite"
        )));
    }
    let mantissa = value.trim().split(['e', 'E']).next().unwrap_or("");
    if v == 0.0 && mantissa.bytes().any(|b| (b'1'..=b'9').contains(&b)) {
        return Err(Failure::user(format!(
            "--set `{s}`: `{}` is out of range: it underflows to 0 (below 5e-324, the smallest number)",
            value.trim()
        )));
    }
    Ok((name.trim().to_string(), v))
}

/// The input files of a run, for the check of its outputs: the model file and the cycle file (unless the cycle
/// is a built-in).
pub fn run_inputs<'a>(model: &'a Path, cycle: &'a str) -> Vec<(&'static str, &'a Path)> {
    let mut inputs = vec![("model file", model)];
    if !crate::cycle_spec::is_builtin(cycle) {
        inputs.push(("cycle file", Path::new(cycle)));
    }
    inputs
}

/// The cycle (read through the size cap) and the model of a run, with the `--set` overrides applied.
fn load_run(
    model: &Path,
    engine: EngineChoice,
    (cycle, max_cycle_bytes): (&str, u64),
    sets: &[String],
) -> Result<(Cycle, LoadedModel), Failure> {
    let sets: Vec<(String, f64)> = sets
        .iter()
        .map(|s| parse_set(s))
        .collect::<Result<_, _>>()?;
    let cycle =
        Cycle::load_with_limit(cycle, max_cycle_bytes).map_err(|e| Failure::user(e.to_string()))?;
    let mut model = load(model, engine)?;
    for (name, value) in &sets {
        model
            .set_param(name, *value)
            .map_err(|e| Failure::user(format!("--set {name}: {e}")))?;
    }
    Ok((cycle, model))
}

/// What `simulate` and `forward` ask for before a run: the input files, the engine, the overrides and the three
/// outputs.
pub struct RunRequest<'a> {
    pub model: &'a Path,
    pub engine: EngineChoice,
    pub cycle: &'a str,
    pub max_cycle_bytes: u64,
    pub set: &'a [String],
    pub out: Option<&'a Path>,
    pub summary_json: Option<&'a Path>,
    pub plot: &'a crate::plotting::PlotArgs,
    pub data: &'a crate::data_args::DataArgs,
}

/// The parsed `--signal` and `--initial` values of a run, for its options.
pub struct RunData {
    pub signals: Vec<invsim_runtime::SignalInput>,
    pub initial: Vec<(String, f64)>,
}

/// The common start of `simulate` and `forward`: the outputs checked against the inputs and each other
/// ([`crate::outputs::Outputs::plan`]), the cycle and the model loaded with the overrides (`--set`, `--map`),
/// the plot options checked against the model, `--signal` and `--initial` parsed — all before the run.
pub fn prepare_run(
    req: &RunRequest<'_>,
) -> Result<(crate::outputs::Outputs, Cycle, LoadedModel, RunData), Failure> {
    let outputs = crate::outputs::Outputs::plan(
        &run_inputs(req.model, req.cycle),
        &[
            ("--out", req.out),
            ("--summary-json", req.summary_json),
            ("--plot", req.plot.plot.as_deref()),
        ],
    )?;
    let (cycle, mut model) = load_run(
        req.model,
        req.engine,
        (req.cycle, req.max_cycle_bytes),
        req.set,
    )?;
    crate::plotting::check(req.plot, model.as_model().info())?;
    crate::map_args::apply(&req.data.map, |name, data| model.set_map(name, data))?;
    let data = RunData {
        signals: crate::signal_args::parse_signals(&req.data.signal)?,
        initial: crate::initial_args::parse_initial(&req.data.initial)?,
    };
    Ok((outputs, cycle, model, data))
}
