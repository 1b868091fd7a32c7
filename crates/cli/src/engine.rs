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

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
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

/// Load `path` with the requested engine. The file is always loaded and derived first, so a bad file gives the
/// same error whichever engine was asked for.
pub fn load(path: &Path, choice: EngineChoice) -> Result<LoadedModel, Failure> {
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
    Ok((name.trim().to_string(), v))
}

/// The cycle and the model of a run, with the `--set` overrides applied.
pub fn load_run(
    model: &Path,
    engine: EngineChoice,
    cycle: &str,
    sets: &[String],
) -> Result<(Cycle, LoadedModel), Failure> {
    let sets: Vec<(String, f64)> = sets
        .iter()
        .map(|s| parse_set(s))
        .collect::<Result<_, _>>()?;
    let cycle = Cycle::load(cycle).map_err(|e| Failure::user(e.to_string()))?;
    let mut model = load(model, engine)?;
    for (name, value) in &sets {
        model
            .set_param(name, *value)
            .map_err(|e| Failure::user(format!("--set {name}: {e}")))?;
    }
    Ok((cycle, model))
}
