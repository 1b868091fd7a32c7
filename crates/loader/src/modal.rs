//! A model with modes: the compiled modes (`invsim_models::modal_by_hash`) when the file is byte for byte a
//! built-in one (then it is read without building each mode's model: `ModelFile::modal_headers`), else every
//! mode derived and interpreted; assembled into the runtime's [`ModalPlant`].

use std::path::Path;

use invsim_inversion::{
    coupling_name, Derivation, Interpreter, ModalModel, Mode, ModeHeader, ModeRole, ModelFile,
    Schedule,
};
use invsim_model_api::InverseModel;
use invsim_runtime::modes::{GearSchedule, InputSpec, ModalPlant, ModeMeta, Role, SequenceParams};

use crate::{EngineChoice, LoadError};

/// A loaded model with modes and the engine that runs its modes.
pub struct LoadedModal {
    pub plant: ModalPlant,
    /// `"compiled"` or `"interpreted"`.
    pub engine: &'static str,
}

/// A mode with its derivation (what `derive` prints of a model with modes).
pub struct DerivedMode {
    pub header: ModeHeader,
    pub d: Derivation,
}

/// The derivation of each of `modes`; an error names the mode.
pub fn derive_modes(modes: Vec<Mode>) -> Result<Vec<DerivedMode>, LoadError> {
    modes
        .into_iter()
        .map(|mode| {
            let name = mode.name.clone();
            let at = |e: String| LoadError::Model(format!("mode `{name}`: {e}"));
            let (header, model) = mode.into_parts();
            let d = Derivation::new(model).map_err(|e| at(e.to_string()))?;
            d.check_printable().map_err(|e| at(e.to_string()))?;
            Ok(DerivedMode { header, d })
        })
        .collect()
}

/// The model at `path` with its compiled modes, when the file is byte for byte a built-in model with modes
/// (every mode was checked when that code was generated from these bytes, so only the first mode's model is
/// built); `None` otherwise.
pub(crate) fn read_compiled(path: &Path) -> Result<Option<LoadedModal>, LoadError> {
    let known = |hash: &str| invsim_models::modal_by_hash(hash).is_some();
    let Some((m, headers)) =
        ModelFile::modal_headers(path, &known).map_err(|e| LoadError::Model(e.to_string()))?
    else {
        return Ok(None);
    };
    let models = invsim_models::modal_by_hash(&m.source_hash).filter(|c| c.len() == headers.len());
    match models {
        Some(models) => assemble(&m, headers, models, "compiled").map(Some),
        None => Ok(None),
    }
}

/// Every mode of `m` run by the engine `choice` asks for.
pub(crate) fn from_model(
    mut m: ModalModel,
    choice: EngineChoice,
) -> Result<LoadedModal, LoadError> {
    let compiled = match choice {
        EngineChoice::Interpreted => None,
        _ => invsim_models::modal_by_hash(&m.source_hash).filter(|c| c.len() == m.modes.len()),
    };
    let modes = std::mem::take(&mut m.modes);
    if let Some(models) = compiled {
        let headers = modes.into_iter().map(Mode::into_header).collect();
        return assemble(&m, headers, models, "compiled");
    }
    if choice == EngineChoice::Compiled {
        return Err(LoadError::NotBuiltIn {
            file: m.file.display().to_string(),
            hash: m.source_hash.clone(),
            modal: true,
            known: invsim_models::MODAL_MODELS
                .iter()
                .map(|r| r.0.to_string())
                .collect(),
        });
    }
    let mut headers = Vec::with_capacity(modes.len());
    let mut models: Vec<Box<dyn InverseModel>> = Vec::with_capacity(modes.len());
    for DerivedMode { header, d } in derive_modes(modes)? {
        let i = Interpreter::new(&d).map_err(|e| LoadError::Model(e.to_string()))?;
        models.push(Box::new(i));
        headers.push(header);
    }
    assemble(&m, headers, models, "interpreted")
}

/// The runtime's plant of `m`'s modes (`headers` and their `models`, in order).
fn assemble(
    m: &ModalModel,
    headers: Vec<ModeHeader>,
    models: Vec<Box<dyn InverseModel>>,
    engine: &'static str,
) -> Result<LoadedModal, LoadError> {
    let inputs = m
        .inputs
        .iter()
        .map(|i| InputSpec {
            name: i.name.clone(),
            unit: i.unit.clone(),
            min: i.min,
            max: i.max,
        })
        .collect();
    let s = &m.sequence;
    let sequence = SequenceParams {
        standstill_below: s.standstill_below,
        standstill_above: s.standstill_above,
        brake_band: s.brake_band,
        min_dwell: s.min_dwell,
    };
    let mut b = ModalPlant::builder(m.name.clone(), inputs, sequence);
    if let Some(g) = &m.gearbox {
        let schedule = match &g.schedule {
            Schedule::Speed { up, down } => GearSchedule::Speed {
                up: up.clone(),
                down: down.clone(),
            },
            Schedule::Regulation => GearSchedule::Regulation,
            Schedule::Column(c) => GearSchedule::Column(c.clone()),
        };
        let params = g.parameters.iter().map(|(p, _)| p.clone()).collect();
        b = b.gearbox(g.gears, schedule, params);
    }
    for (h, model) in headers.into_iter().zip(models) {
        let meta = meta_of(m, h, model.as_ref());
        b = b.mode(meta, model);
    }
    let plant = b.build().map_err(|e| LoadError::Model(e.to_string()))?;
    Ok(LoadedModal { plant, engine })
}

/// What the runtime needs of a mode: its fixed inputs and couplings as indices of the model's outputs that
/// hold them (the last output of that name: the mode's own, after the model's `[outputs]`).
fn meta_of(m: &ModalModel, h: ModeHeader, model: &dyn InverseModel) -> ModeMeta {
    let info = model.info();
    let outs = &info.outputs;
    let fixed_outputs = h
        .fixed
        .iter()
        .filter_map(|(j, _)| {
            let name = &m.inputs[*j].name;
            outs.iter().rposition(|o| &o.name == name).map(|o| (*j, o))
        })
        .collect();
    let coupled = h
        .coupled
        .iter()
        .filter_map(|(s, _)| {
            let name = coupling_name(&info.states[*s]);
            outs.iter().rposition(|o| o.name == name).map(|o| (*s, o))
        })
        .collect();
    ModeMeta {
        name: h.name,
        family: h.family,
        role: match h.role {
            ModeRole::Traction => Role::Traction,
            ModeRole::Brake => Role::Brake,
            ModeRole::Standstill => Role::Standstill,
        },
        gear: h.gear,
        free_input: h.free,
        fixed_outputs,
        coupled,
    }
}
