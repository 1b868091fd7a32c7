//! What a run runs: a model without modes (any [`InverseModel`]) or a model with operating modes (a
//! [`ModalPlant`], one single-input model per mode). A sweep makes one per worker and sets each variant's
//! parameters on it.

use invsim_model_api::InverseModel;

use crate::modes::ModalPlant;

/// A model without modes or with modes.
pub enum Plant {
    Single(Box<dyn InverseModel>),
    Modal(ModalPlant),
}

impl Plant {
    /// The model's name.
    pub fn name(&self) -> &str {
        match self {
            Plant::Single(m) => &m.info().name,
            Plant::Modal(p) => p.name(),
        }
    }

    /// The description of the model (of its first mode, for a model with modes: parameters, states and
    /// `[outputs]` are every mode's).
    pub fn info(&self) -> &invsim_model_api::ModelInfo {
        match self {
            Plant::Single(m) => m.info(),
            Plant::Modal(p) => p.first().info(),
        }
    }

    /// The model's lookup maps (of every mode, each once, for a model with modes).
    pub fn maps(&self) -> Vec<&invsim_model_api::map::Map> {
        match self {
            Plant::Single(m) => m.maps().iter().collect(),
            Plant::Modal(p) => p.maps(),
        }
    }

    /// The declared parameters ([`Plant::not_settable`] says which cannot be set on their own).
    pub fn parameters(&self) -> Vec<String> {
        match self {
            Plant::Single(m) => m.info().parameters.clone(),
            Plant::Modal(p) => p.parameters(),
        }
    }

    /// Why parameter `name` cannot be set on its own (one the gearbox sets per gear), if it cannot.
    pub fn not_settable(&self, name: &str) -> Option<String> {
        match self {
            Plant::Modal(p) if p.is_gear_parameter(name) => {
                let gears = p.gear_parameters().gears;
                Some(format!(
                    "`{name}` is set per gear by the model's [gearbox]; change its values there or set \
                     one gear's, {name}[1] … {name}[{gears}]"
                ))
            }
            _ => None,
        }
    }

    /// The per-gear names of the parameters the gearbox sets per gear (`i_g[1]` … `i_g[5]`), which a sweep
    /// and `--set` take beside the parameters; none for a model without a gearbox.
    pub fn per_gear_names(&self) -> Vec<String> {
        match self {
            Plant::Single(_) => Vec::new(),
            Plant::Modal(p) => p.gear_parameters().per_gear_names(),
        }
    }

    /// Set parameter `name` (in every mode of a model with modes).
    pub fn set_param(&mut self, name: &str, value: f64) -> Result<(), String> {
        match self {
            Plant::Single(m) => m.set_param(name, value).map_err(|e| e.to_string()),
            Plant::Modal(p) => p.set_param(name, value).map_err(|e| e.to_string()),
        }
    }

    /// The accumulated outputs' names, sorted (the summary's `integrals`).
    pub fn integrals(&self) -> Vec<String> {
        let info = match self {
            Plant::Single(m) => m.info(),
            Plant::Modal(p) => p.first().info(),
        };
        let mut names: Vec<String> = info
            .outputs
            .iter()
            .filter(|o| o.accumulate)
            .map(|o| o.name.clone())
            .collect();
        names.sort();
        names
    }

    /// The modes' names (empty for a model without modes).
    pub fn mode_names(&self) -> Vec<String> {
        match self {
            Plant::Single(_) => Vec::new(),
            Plant::Modal(p) => p.mode_names(),
        }
    }
}
