//! A model with modes: the compiled modes (`invsim_models::modal_by_hash`) when the file is byte for byte a
//! built-in one (then it is read without building each mode's model: `ModelFile::modal_headers`), else every
//! mode derived and interpreted; assembled into the runtime's [`ModalPlant`].

use std::cell::RefCell;
use std::path::Path;

use invsim_inversion::{
    coupling_name, Derivation, Extent, Interpreter, ModalFacts, ModalModel, Mode, ModeHeader,
    ModeRole, ModelFile, Schedule,
};
use invsim_model_api::InverseModel;
use invsim_runtime::modes::{GearSchedule, InputSpec, ModalPlant, ModeMeta, Role, SequenceParams};

use crate::{EngineChoice, LoadError};

/// A loaded model with modes and where fresh copies of its modes' models come from.
pub struct LoadedModal {
    pub plant: ModalPlant,
    source: Source,
}

/// Where a fresh copy of every mode's model comes from.
enum Source {
    /// The compiled modes of the file with this SHA-256.
    Compiled(String),
    /// The interpreters as derived (at the file's parameters).
    Interpreted(Vec<Interpreter>),
}

impl LoadedModal {
    /// `"compiled"` or `"interpreted"`.
    pub fn engine_name(&self) -> &'static str {
        match self.source {
            Source::Compiled(_) => "compiled",
            Source::Interpreted(_) => "interpreted",
        }
    }

    /// A fresh plant with every mode's parameters as they are now in this one (for a run of its own: a
    /// worker of a sweep, a call from another thread). Maps replaced by `set_map` are not carried over.
    pub fn fresh(&self) -> Result<ModalPlant, LoadError> {
        let mut models = match &self.source {
            Source::Compiled(hash) => invsim_models::modal_by_hash(hash).ok_or_else(|| {
                LoadError::Setup(format!("no built-in model has the hash {hash}"))
            })?,
            Source::Interpreted(prototypes) => interpreters(prototypes),
        };
        for (fresh, now) in models.iter_mut().zip(self.plant.models()) {
            crate::params::copy_parameters(now, fresh.as_mut())?;
        }
        self.plant
            .with_models(models)
            .map_err(|e| LoadError::Setup(e.to_string()))
    }
}

/// A copy of each interpreter, boxed for the runtime.
fn interpreters(prototypes: &[Interpreter]) -> Vec<Box<dyn InverseModel>> {
    prototypes
        .iter()
        .map(|i| Box::new(i.clone()) as Box<dyn InverseModel>)
        .collect()
}

/// A mode with its derivation (what `derive` prints of a model with modes).
pub struct DerivedMode {
    pub header: ModeHeader,
    pub d: Derivation,
}

/// The derivation of each of `modes` (`inputs`: the model's input names); an error names the mode. A decided
/// input that enters D^k h below the relative degree is refused where it is written
/// ([`invsim_inversion::check_decided`]).
pub fn derive_modes(
    modes: Vec<Mode>,
    inputs: &[String],
    extent: Extent,
) -> Result<Vec<DerivedMode>, LoadError> {
    modes
        .into_iter()
        .map(|mode| {
            let name = mode.name.clone();
            let at = |e: invsim_inversion::Error| LoadError::Mode {
                mode: name.clone(),
                source: Box::new(e),
            };
            let decided: Vec<(String, Option<(usize, usize)>)> = mode
                .decided
                .iter()
                .zip(&mode.decided_at)
                .map(|(i, at)| (inputs[*i].clone(), *at))
                .collect();
            let (header, model) = mode.into_parts();
            let d = Derivation::to(model, extent).map_err(|e| at(e.into()))?;
            invsim_inversion::check_decided(&name, &decided, &d)
                .map_err(|e| LoadError::Model(Box::new(e.into())))?;
            d.check_printable()
                .map_err(|e| LoadError::Setup(format!("mode `{name}`: {e}")))?;
            Ok(DerivedMode { header, d })
        })
        .collect()
}

/// The derivation of a model with modes as JSON (what `invsim derive --format json` prints):
/// `{"name", "inputs", "modes": [{"name", "family", "gear", "role", "free_input", "fixed_inputs",
/// "derivation", "couples"?}]}`.
pub fn modal_derive_json(m: &ModalModel, modes: &[DerivedMode]) -> serde_json::Value {
    use serde_json::{json, Map, Value};
    let modes: Vec<Value> = modes
        .iter()
        .map(|mode| {
            let (d, h) = (&mode.d, &mode.header);
            let fixed: Map<String, Value> = h
                .fixed
                .iter()
                .map(|(i, e)| (m.inputs[*i].name.clone(), Value::String(e.clone())))
                .collect();
            let mut o = json!({
                "name": h.name, "family": h.family, "gear": h.gear,
                "role": h.role.as_str(), "free_input": m.inputs[h.free].name,
                "fixed_inputs": fixed, "derivation": d.to_json(),
            });
            if !h.decided.is_empty() {
                // The inputs a strategy decides: signals of the mode's derivation, in y^(r) only.
                let decided: Vec<&str> = h
                    .decided
                    .iter()
                    .map(|i| m.inputs[*i].name.as_str())
                    .collect();
                o["decided_inputs"] = decided.into();
            }
            if !h.coupled.is_empty() {
                // The states the mode couples (`couple`), with their couplings as written.
                let couples: Map<String, Value> = h
                    .coupled
                    .iter()
                    .map(|(s, e)| (d.model.states[*s].name.clone(), e.clone().into()))
                    .collect();
                o["couples"] = couples.into();
            }
            o
        })
        .collect();
    let inputs: Vec<&str> = m.inputs.iter().map(|i| i.name.as_str()).collect();
    json!({ "name": m.name, "inputs": inputs, "modes": modes })
}

/// The model with its compiled modes, when the file's bytes are byte for byte a built-in model with modes
/// (every mode was checked when that code was generated from these bytes): read without building any mode's
/// equations, the model's name, description, parameters and states taken from the compiled code
/// (`ModelFile::modal_headers_hashed`; the file found by comparing its bytes, its SHA-256 the compiled
/// code's); `None` otherwise.
pub(crate) fn read_compiled(file: &Path, bytes: &[u8]) -> Result<Option<LoadedModal>, LoadError> {
    let (Some(hash), Ok(text)) = (
        invsim_models::modal_hash_of_source(bytes),
        std::str::from_utf8(bytes),
    ) else {
        return Ok(None);
    };
    let found: RefCell<Option<Vec<Box<dyn InverseModel>>>> = RefCell::new(None);
    let known = |hash: &str| {
        let models = invsim_models::modal_by_hash(hash)?;
        let facts = ModalFacts::from_info(models.first()?.info());
        *found.borrow_mut() = Some(models);
        Some(Some(facts))
    };
    let Some((m, headers)) = ModelFile::modal_headers_hashed(file, text, hash.into(), &known)?
    else {
        return Ok(None);
    };
    match found.take().filter(|c| c.len() == headers.len()) {
        Some(models) => {
            let source = Source::Compiled(m.source_hash.clone());
            assemble(&m, headers, models, source).map(Some)
        }
        None => Ok(None),
    }
}

/// Every mode of `m` run by the engine `choice` asks for (an interpreted mode derived as far as `extent` asks).
pub(crate) fn from_model(
    mut m: ModalModel,
    choice: EngineChoice,
    extent: Extent,
) -> Result<LoadedModal, LoadError> {
    let compiled = match choice {
        EngineChoice::Interpreted => None,
        _ => invsim_models::modal_by_hash(&m.source_hash).filter(|c| c.len() == m.modes.len()),
    };
    let modes = std::mem::take(&mut m.modes);
    if let Some(models) = compiled {
        let headers = modes.into_iter().map(Mode::into_header).collect();
        let source = Source::Compiled(m.source_hash.clone());
        return assemble(&m, headers, models, source);
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
    let mut prototypes = Vec::with_capacity(modes.len());
    let names: Vec<String> = m.inputs.iter().map(|i| i.name.clone()).collect();
    for DerivedMode { header, d } in derive_modes(modes, &names, extent)? {
        prototypes.push(Interpreter::new(&d)?);
        headers.push(header);
    }
    let models = interpreters(&prototypes);
    assemble(&m, headers, models, Source::Interpreted(prototypes))
}

/// The runtime's plant of `m`'s modes (`headers` and their `models`, in order).
fn assemble(
    m: &ModalModel,
    headers: Vec<ModeHeader>,
    models: Vec<Box<dyn InverseModel>>,
    source: Source,
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
    if let Some(h) = &m.hybrid {
        b = b.hybrid(h.clone());
    }
    for (h, model) in headers.into_iter().zip(models) {
        let meta = meta_of(m, h, model.as_ref());
        b = b.mode(meta, model);
    }
    let plant = b.build().map_err(|e| LoadError::Setup(e.to_string()))?;
    Ok(LoadedModal { plant, source })
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
        own_parameters: h.parameters,
    }
}
