//! Choosing the engine for the modes of a model with operating modes, as `engine` does for a single-mode
//! model: the compiled modes (`invsim_models::modal_by_hash`) when the model file is byte-for-byte a built-in
//! one (same SHA-256), else every mode derived and interpreted. Compiled modes are not derived at run time.

use invsim_inversion::{Derivation, Interpreter, ModalModel, ModeRole};
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

/// What the run needs of a mode beside its model.
pub struct ModeMeta {
    pub name: String,
    pub family: String,
    pub gear: Option<usize>,
    pub role: ModeRole,
    pub free: usize,
    pub fixed: Vec<(usize, String)>,
    /// The states the mode couples (`couple`), with their couplings as written.
    pub coupled: Vec<(usize, String)>,
}

/// Every mode's model, in the model file's order, and the engine that runs them.
pub struct ModeModels {
    pub meta: Vec<ModeMeta>,
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
            .map(meta_of)
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
        meta.push(ModeMeta {
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

fn meta_of(mode: invsim_inversion::Mode) -> ModeMeta {
    ModeMeta {
        name: mode.name,
        family: mode.family,
        gear: mode.gear,
        role: mode.role,
        free: mode.free,
        fixed: mode.fixed,
        coupled: mode.coupled,
    }
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
