//! Choosing the engine that evaluates a model: compiled code for a built-in model whose file matches, else the
//! interpreter tape built from the model file.
//!
//! A model file matches a built-in model when the SHA-256 of its bytes equals that of a file in `models/` the
//! binary was built with (`invsim_models::by_hash`): then the code generated from exactly that file runs.

use crate::{EngineChoice, Failure};
use invsim_inversion::{Derivation, Interpreter};
use invsim_model_api::InverseModel;
use std::path::Path;

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
