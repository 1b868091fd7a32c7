//! Choosing the engine for the modes of a model with operating modes, as `engine` does for a single-mode
//! model: the compiled modes (`invsim_models::modal_by_hash`) when the model file is byte-for-byte a built-in
//! one (same SHA-256), else every mode derived and interpreted. Compiled modes are not derived at run time,
//! and a file compiled code matches is read without building each mode's model (`read_compiled`).

use std::path::Path;

use invsim_inversion::{Derivation, Interpreter, ModalModel, ModeHeader, ModeRole, ModelFile};
use invsim_model_api::InverseModel;

use crate::engine::EngineChoice;
use crate::error::Failure;

/// A mode with its derivation.
pub struct DerivedMode {
    pub name: String,
    pub family: String,
    pub gear: Option<usize>,
    pub role: ModeRole,
    pub free: usize,
    pub fixed: Vec<(usize, String)>,
    /// The states the mode couples (`couple`), with their couplings as written.
    pub coupled: Vec<(usize, String)>,
    pub d: Derivation,
}

/// The derivation of each of `modes`.
pub fn derive_list(modes: Vec<invsim_inversion::Mode>) -> Result<Vec<DerivedMode>, Failure> {
    let mut out = Vec::new();
    for mode in modes {
        let invsim_inversion::Mode {
            name,
            family,
            gear,
            role,
            free,
            fixed,
            coupled,
            model,
        } = mode;
        let d = Derivation::new(model).map_err(|e| Failure::user(format!("mode `{name}`: {e}")))?;
        d.check_printable()
            .map_err(|e| Failure::user(format!("mode `{name}`: {e}")))?;
        out.push(DerivedMode {
            name,
            family,
            gear,
            role,
            free,
            fixed,
            coupled,
            d,
        });
    }
    Ok(out)
}

/// Every mode's model, in the model file's order, and the engine that runs them.
pub struct ModeModels {
    /// What the run needs of each mode beside its model.
    pub meta: Vec<ModeHeader>,
    pub models: Vec<Box<dyn InverseModel>>,
    pub engine: &'static str,
}

/// The modes of `m` (taken out of it) with the requested engine.
pub fn load_modes(m: &mut ModalModel, choice: EngineChoice) -> Result<ModeModels, Failure> {
    let compiled = match choice {
        EngineChoice::Interpreted => None,
        _ => invsim_models::modal_by_hash(&m.source_hash).filter(|c| c.len() == m.modes.len()),
    };
    if let Some(models) = compiled {
        let meta = std::mem::take(&mut m.modes)
            .into_iter()
            .map(invsim_inversion::Mode::into_header)
            .collect();
        return Ok(ModeModels {
            meta,
            models,
            engine: "compiled",
        });
    }
    if choice == EngineChoice::Compiled {
        return Err(no_compiled(m));
    }
    let ds = derive_list(std::mem::take(&mut m.modes))?;
    let mut meta = Vec::with_capacity(ds.len());
    let mut models: Vec<Box<dyn InverseModel>> = Vec::with_capacity(ds.len());
    for d in ds {
        let i = Interpreter::new(&d.d).map_err(|e| Failure::user(e.to_string()))?;
        models.push(Box::new(i));
        meta.push(ModeHeader {
            name: d.name,
            family: d.family,
            gear: d.gear,
            role: d.role,
            free: d.free,
            fixed: d.fixed,
            coupled: d.coupled,
        });
    }
    Ok(ModeModels {
        meta,
        models,
        engine: "interpreted",
    })
}

/// A model with modes as read for a run.
pub enum ModalRead {
    /// Every mode's model built: compiled code replaces them where it matches, else they are derived and
    /// interpreted ([`load_modes`]).
    Full(ModalModel),
    /// The file is byte for byte one compiled code was made from: the model without its modes, and the
    /// compiled modes.
    Compiled(ModalModel, ModeModels),
}

impl ModalRead {
    /// The model (without its modes in [`ModalRead::Compiled`]).
    pub fn model(&self) -> &ModalModel {
        match self {
            ModalRead::Full(m) | ModalRead::Compiled(m, _) => m,
        }
    }
}

/// The model at `path` with its compiled modes when `choice` allows compiled code and the file is byte for
/// byte a built-in model with modes (every mode was checked when that code was generated from these
/// bytes, so only the first mode's model is built); `None` otherwise, for [`ModelFile::from_path`] to read.
pub fn read_compiled(
    path: &Path,
    choice: EngineChoice,
) -> Result<Option<(ModalModel, ModeModels)>, Failure> {
    if choice == EngineChoice::Interpreted {
        return Ok(None);
    }
    let known = |hash: &str| invsim_models::modal_by_hash(hash).is_some();
    let Some((m, meta)) =
        ModelFile::modal_headers(path, &known).map_err(|e| Failure::user(e.to_string()))?
    else {
        return Ok(None);
    };
    let models = invsim_models::modal_by_hash(&m.source_hash).filter(|c| c.len() == meta.len());
    Ok(models.map(|models| {
        let loaded = ModeModels {
            meta,
            models,
            engine: "compiled",
        };
        (m, loaded)
    }))
}

fn no_compiled(m: &ModalModel) -> Failure {
    let names: Vec<&str> = invsim_models::MODAL_MODELS.iter().map(|r| r.0).collect();
    Failure::user(format!(
        "no compiled code for `{}`: the file (sha256 {}) matches none of the built-in models with modes this \
         binary was built with ({}; a built-in model must be byte-for-byte the file in models/); use \
         --engine interpreted, or --engine auto to fall back to the interpreter",
        m.file.display(),
        m.source_hash,
        names.join(", ")
    ))
}
