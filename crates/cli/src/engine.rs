//! Choosing the engine that evaluates a model: compiled code for a built-in model whose file matches, else the
//! interpreter tape built from the model file.

use crate::{EngineChoice, Failure};
use invsim_inversion::Interpreter;
use invsim_model_api::InverseModel;
use std::path::Path;

/// A loaded model behind the runtime's trait, with the name of the engine that runs it.
pub enum LoadedModel {
    Interpreted(Box<Interpreter>),
}

impl LoadedModel {
    pub fn engine_name(&self) -> &'static str {
        match self {
            LoadedModel::Interpreted(_) => "interpreted",
        }
    }
    pub fn as_model(&self) -> &dyn InverseModel {
        match self {
            LoadedModel::Interpreted(m) => m.as_ref(),
        }
    }
    pub fn set_param(&mut self, name: &str, value: f64) -> Result<(), invsim_model_api::ModelError> {
        match self {
            LoadedModel::Interpreted(m) => m.set_param(name, value),
        }
    }
}

/// Load `path` with the requested engine.
pub fn load(path: &Path, choice: EngineChoice) -> Result<LoadedModel, Failure> {
    let d = invsim_inversion::derive_file(path).map_err(|e| Failure::user(e.to_string()))?;
    if choice == EngineChoice::Compiled {
        return Err(Failure::user(format!(
            "no compiled code for `{}`: the built-in models are not yet compiled into this build; use --engine interpreted",
            path.display()
        )));
    }
    let interp = Interpreter::new(&d).map_err(|e| Failure::user(e.to_string()))?;
    Ok(LoadedModel::Interpreted(Box::new(interp)))
}
