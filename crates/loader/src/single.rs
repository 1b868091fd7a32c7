//! A model without modes: compiled code where the file is byte for byte a built-in model's (no derivation at
//! run time: the code carries everything the run needs), else the file derived and its interpreter tape.
//!
//! A model file matches a built-in model when its bytes equal those of a file in `models/` the program was
//! built with (`invsim_models::by_source`, or by SHA-256 `invsim_models::by_hash`).

use std::path::Path;

use invsim_inversion::{Derivation, Extent, Interpreter, Model};
use invsim_model_api::InverseModel;

use crate::{EngineChoice, LoadError};

/// A loaded model without modes, with the engine that runs it.
pub enum SingleModel {
    Interpreted(Box<Interpreter>),
    /// Generated code for a built-in model (`invsim-models`).
    Compiled(Box<dyn InverseModel>),
}

impl SingleModel {
    /// `"compiled"` or `"interpreted"` (the summary's `engine`).
    pub fn engine_name(&self) -> &'static str {
        match self {
            SingleModel::Interpreted(_) => "interpreted",
            SingleModel::Compiled(_) => "compiled",
        }
    }

    pub fn as_model(&self) -> &dyn InverseModel {
        match self {
            SingleModel::Interpreted(m) => m.as_ref(),
            SingleModel::Compiled(m) => m.as_ref(),
        }
    }

    pub fn as_model_mut(&mut self) -> &mut dyn InverseModel {
        match self {
            SingleModel::Interpreted(m) => m.as_mut(),
            SingleModel::Compiled(m) => m.as_mut(),
        }
    }

    /// A fresh copy at the current parameters and maps (a clone of the interpreter; compiled code made anew
    /// from its file's hash with the parameters copied over).
    pub fn fresh(&self) -> Result<Box<dyn InverseModel>, LoadError> {
        match self {
            SingleModel::Interpreted(m) => Ok(Box::new(m.as_ref().clone())),
            SingleModel::Compiled(m) => {
                let info = m.info();
                let hash = info.source_hash.clone().unwrap_or_default();
                let mut fresh = invsim_models::by_hash(&hash).ok_or_else(|| {
                    LoadError::Setup(format!("no built-in model has the hash {hash}"))
                })?;
                crate::params::copy_parameters(m.as_ref(), fresh.as_mut())?;
                Ok(fresh)
            }
        }
    }
}

/// The compiled model built from a file with exactly the bytes `bytes`.
pub(crate) fn builtin_of(bytes: &[u8]) -> Option<Box<dyn InverseModel>> {
    invsim_models::by_source(bytes)
}

/// `model` (read from `path`) derived as far as `extent` asks, run by the engine `choice` asks for.
pub(crate) fn from_model(
    model: Model,
    path: &Path,
    (choice, extent): (EngineChoice, Extent),
) -> Result<SingleModel, LoadError> {
    let d = Derivation::to(model, extent)?;
    let hash = &d.model.source_hash;
    match (choice, invsim_models::by_hash(hash)) {
        (EngineChoice::Auto | EngineChoice::Compiled, Some(m)) => Ok(SingleModel::Compiled(m)),
        (EngineChoice::Compiled, None) => Err(LoadError::NotBuiltIn {
            file: path.display().to_string(),
            hash: hash.clone(),
            modal: false,
            known: invsim_models::names()
                .iter()
                .map(|s| s.to_string())
                .collect(),
        }),
        _ => interpreted(&d),
    }
}

fn interpreted(d: &Derivation) -> Result<SingleModel, LoadError> {
    let interp = Interpreter::new(d)?;
    Ok(SingleModel::Interpreted(Box::new(interp)))
}
