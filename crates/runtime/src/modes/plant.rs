//! A model with modes that owns its modes' models: what a loader builds once from a model file and every run
//! of it (simulate, forward, each variant of a sweep) borrows as a [`ModalSpec`].
//!
//! The gearbox's schedule is kept as the model file says it and resolved per cycle
//! ([`ModalPlant::gear_source`]): the regulation's prescription exists only for its cycles, a gear column only
//! in a cycle file.

use std::path::Path;

use invsim_model_api::{InverseModel, ModelError};

use super::gears::{column_table, regulation_table, GearSource};
use super::{InputSpec, ModalError, ModalSpec, ModeSpec, Role, SequenceParams};
use crate::cycle::Cycle;

/// How the gearbox chooses the gear, as the model file writes it.
#[derive(Debug, Clone, PartialEq)]
pub enum GearSchedule {
    /// No gearbox: gear 1 throughout.
    None,
    /// Up above `up[k-1]`, down below `down[k-1]` (m/s of the smoothed cycle).
    Speed { up: Vec<f64>, down: Vec<f64> },
    /// The regulation's gear prescription of the cycle (ECE-15, EUDC, NEDC).
    Regulation,
    /// A gear column of the cycle file.
    Column(String),
}

/// A mode as the run needs it, without its model (see [`ModeSpec`], whose fields these are).
#[derive(Debug, Clone, PartialEq)]
pub struct ModeMeta {
    pub name: String,
    pub family: String,
    pub role: Role,
    pub gear: Option<usize>,
    pub free_input: usize,
    pub fixed_outputs: Vec<(usize, usize)>,
    pub coupled: Vec<(usize, usize)>,
    /// The parameters the mode sets itself (`parameters = { … }` in its table), by name.
    pub own_parameters: Vec<String>,
}

/// A model with modes with its modes' models (see the module docs); built by [`ModalPlant::builder`].
pub struct ModalPlant {
    name: String,
    inputs: Vec<InputSpec>,
    modes: Vec<(ModeMeta, Box<dyn InverseModel>)>,
    gears: usize,
    schedule: GearSchedule,
    /// Parameters the gearbox sets per gear (not settable as a whole).
    gear_parameters: Vec<String>,
    sequence: SequenceParams,
    n_outputs: usize,
    /// `[hybrid]`: what an energy-management strategy weighs (none without the table).
    hybrid: Option<Box<invsim_model_api::HybridSpec>>,
}

/// Builds a [`ModalPlant`]; [`ModalPlantBuilder::build`] checks it once.
pub struct ModalPlantBuilder {
    plant: ModalPlant,
}

impl ModalPlant {
    /// A plant named `name` with the declared `inputs` and the mode sequence's options.
    pub fn builder(
        name: impl Into<String>,
        inputs: Vec<InputSpec>,
        sequence: SequenceParams,
    ) -> ModalPlantBuilder {
        ModalPlantBuilder {
            plant: ModalPlant {
                name: name.into(),
                inputs,
                modes: Vec::new(),
                gears: 1,
                schedule: GearSchedule::None,
                gear_parameters: Vec::new(),
                sequence,
                n_outputs: 0,
                hybrid: None,
            },
        }
    }

    /// The model's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The declared inputs.
    pub fn inputs(&self) -> &[InputSpec] {
        &self.inputs
    }

    /// Every mode's model, in the model file's order.
    pub fn models(&self) -> impl Iterator<Item = &dyn InverseModel> {
        self.modes.iter().map(|(_, m)| m.as_ref())
    }

    /// The first mode's model (its description holds the model's parameters, states and `[outputs]`, which
    /// every mode shares).
    pub fn first(&self) -> &dyn InverseModel {
        self.modes[0].1.as_ref()
    }

    /// The modes' names, in order.
    pub fn mode_names(&self) -> Vec<String> {
        self.modes.iter().map(|(m, _)| m.name.clone()).collect()
    }

    /// The declared parameters (every mode's; those the gearbox sets per gear cannot be set on their own).
    pub fn parameters(&self) -> Vec<String> {
        self.first().info().parameters.clone()
    }

    /// Is `name` a parameter the gearbox sets per gear?
    pub fn is_gear_parameter(&self, name: &str) -> bool {
        self.gear_parameters.iter().any(|p| p == name)
    }

    /// The parameters the gearbox sets per gear, and its number of gears.
    pub fn gear_parameters(&self) -> crate::gradient::GearParameters<'_> {
        crate::gradient::GearParameters {
            names: &self.gear_parameters,
            gears: self.gears,
        }
    }

    /// Set a parameter the gearbox sets per gear in the modes of `gear` (1 … gears) only.
    pub fn set_gear_param(
        &mut self,
        name: &str,
        gear: usize,
        value: f64,
    ) -> Result<(), ModalError> {
        if !self.is_gear_parameter(name) || !(1..=self.gears).contains(&gear) {
            return Err(ModalError::Setup(format!(
                "`{name}` in gear {gear}: not a parameter the [gearbox] sets in one of its {} gears",
                self.gears
            )));
        }
        for (_, m) in self
            .modes
            .iter_mut()
            .filter(|(meta, _)| meta.gear == Some(gear))
        {
            m.set_param(name, value)
                .map_err(|e| ModalError::Setup(e.to_string()))?;
        }
        Ok(())
    }

    /// Set the parameter of derivative c of `wrt` to `value` in every mode that takes it (`wrt.columns`): the
    /// change whose effect that derivative is (finite differences of a gradient).
    pub fn set_as_moved(
        &mut self,
        wrt: &crate::gradient::ModalWrt,
        c: usize,
        value: f64,
    ) -> Result<(), ModalError> {
        let Some(name) = self.parameters().get(wrt.params[c].param).cloned() else {
            return Err(ModalError::Setup(format!(
                "`{}` is a grid value of a map, not a parameter: replace the map (`set_map`) to move it",
                wrt.params[c].name
            )));
        };
        for ((_, m), columns) in self.modes.iter_mut().zip(&wrt.columns) {
            if columns[c].is_some() {
                m.set_param(&name, value)
                    .map_err(|e| ModalError::Setup(e.to_string()))?;
            }
        }
        Ok(())
    }

    /// The modes' metadata, in order.
    pub fn metas(&self) -> impl Iterator<Item = &ModeMeta> {
        self.modes.iter().map(|(meta, _)| meta)
    }

    /// Set a parameter in every mode, or a gearbox parameter in one gear's modes by its per-gear name
    /// `NAME[g]` (`i_g[3]`, as `--gradient` names it); a gearbox parameter named whole is refused.
    pub fn set_param(&mut self, name: &str, value: f64) -> Result<(), ModalError> {
        if let Some((base, gear)) = per_gear(name).filter(|(b, _)| self.is_gear_parameter(b)) {
            return self.set_gear_param(base, gear, value);
        }
        if self.is_gear_parameter(name) {
            return Err(ModalError::Setup(format!(
                "`{name}` is set per gear by the model's [gearbox]; change its values there or set one \
                 gear's, {name}[1] … {name}[{}]",
                self.gears
            )));
        }
        for (_, m) in &mut self.modes {
            m.set_param(name, value)
                .map_err(|e| ModalError::Setup(e.to_string()))?;
        }
        Ok(())
    }

    /// Every mode's maps, in the modes' order (a mode that never calls a map has none).
    pub fn mode_maps(&self) -> impl Iterator<Item = &[invsim_model_api::map::Map]> {
        self.modes.iter().map(|(_, m)| m.maps())
    }

    /// The maps of the modes, each once (the first mode's that has it: `set_map` replaces it in all).
    pub fn maps(&self) -> Vec<&invsim_model_api::map::Map> {
        let mut out: Vec<&invsim_model_api::map::Map> = Vec::new();
        for m in self.mode_maps().flatten() {
            if !out.iter().any(|o| o.name() == m.name()) {
                out.push(m);
            }
        }
        out
    }

    /// Replace a lookup map in every mode whose equations use it (modes are derived apart, so a mode that
    /// never calls the map has none); a name no mode knows is refused with the first mode's list of maps.
    pub fn set_map(
        &mut self,
        name: &str,
        data: (&[f64], Option<&[f64]>, &[f64]),
    ) -> Result<(), ModelError> {
        let mut unknown = None;
        let mut applied = false;
        for (_, m) in &mut self.modes {
            match m.set_map(name, data) {
                Ok(()) => applied = true,
                Err(e @ ModelError::UnknownMap { .. }) => {
                    unknown.get_or_insert(e);
                }
                Err(e) => return Err(e),
            }
        }
        match unknown {
            Some(e) if !applied => Err(e),
            _ => Ok(()),
        }
    }

    /// The gear schedule resolved for `cycle` (`file`: the cycle file it was read from, `None` for a
    /// built-in cycle). The message says what is missing; the caller names the model file.
    pub fn gear_source(&self, cycle: &Cycle, file: Option<&Path>) -> Result<GearSource, String> {
        Ok(match &self.schedule {
            GearSchedule::None => GearSource::Fixed,
            GearSchedule::Speed { up, down } => GearSource::Speed {
                up: up.clone(),
                down: down.clone(),
            },
            GearSchedule::Regulation => GearSource::Table(regulation_table(&cycle.name).ok_or_else(|| {
                format!(
                    "the regulation's gear prescription exists for the built-in ece, eudc and nedc, not for `{}`",
                    cycle.name
                )
            })?),
            GearSchedule::Column(c) => {
                let Some(file) = file else {
                    return Err(format!(
                        "the gearbox takes the gear from the cycle file's column `{c}`, but `{}` is a built-in cycle",
                        cycle.name
                    ));
                };
                GearSource::Table(
                    column_table(file, c).map_err(|e| format!("{}: {e}", file.display()))?,
                )
            }
        })
    }

    /// The same plant with other models of its modes (fresh copies, in the same order).
    pub fn with_models(
        &self,
        models: Vec<Box<dyn InverseModel>>,
    ) -> Result<ModalPlant, ModalError> {
        if models.len() != self.modes.len() {
            return Err(ModalError::Setup(format!(
                "{} models for the {} modes of `{}`",
                models.len(),
                self.modes.len(),
                self.name
            )));
        }
        let modes = self
            .modes
            .iter()
            .zip(models)
            .map(|((meta, _), m)| (meta.clone(), m))
            .collect();
        Ok(ModalPlant {
            name: self.name.clone(),
            inputs: self.inputs.clone(),
            modes,
            gears: self.gears,
            schedule: self.schedule.clone(),
            gear_parameters: self.gear_parameters.clone(),
            sequence: self.sequence.clone(),
            n_outputs: self.n_outputs,
            hybrid: self.hybrid.clone(),
        })
    }

    /// The model's `[hybrid]` table, if it has one.
    pub fn hybrid(&self) -> Option<&invsim_model_api::HybridSpec> {
        self.hybrid.as_deref()
    }

    /// The modes that leave an input to a strategy (`decided`), with the first such input's name.
    pub fn decided_inputs(&self) -> Vec<(String, String)> {
        let names: Vec<&str> = self.inputs.iter().map(|i| i.name.as_str()).collect();
        self.modes
            .iter()
            .filter_map(|(meta, m)| {
                let s = m
                    .info()
                    .signals
                    .iter()
                    .find(|s| names.contains(&s.name.as_str()))?;
                Some((meta.name.clone(), s.name.clone()))
            })
            .collect()
    }

    /// The runtime's view of the plant with the gear schedule resolved to `gear_source`.
    pub fn spec(&self, gear_source: GearSource) -> ModalSpec<'_> {
        let modes = self
            .modes
            .iter()
            .map(|(meta, model)| ModeSpec {
                name: meta.name.clone(),
                family: meta.family.clone(),
                role: meta.role,
                gear: meta.gear,
                free_input: meta.free_input,
                fixed_outputs: meta.fixed_outputs.clone(),
                coupled: meta.coupled.clone(),
                model: model.as_ref(),
            })
            .collect();
        ModalSpec {
            name: self.name.clone(),
            inputs: self.inputs.clone(),
            modes,
            gears: self.gears,
            gear_source,
            sequence: self.sequence.clone(),
            n_outputs: self.n_outputs,
            hybrid: self.hybrid(),
        }
    }
}

/// `NAME[g]` as (NAME, g).
fn per_gear(name: &str) -> Option<(&str, usize)> {
    let (base, rest) = name.split_once('[')?;
    let gear = rest.strip_suffix(']')?.parse().ok()?;
    Some((base, gear))
}

impl ModalPlantBuilder {
    /// A gearbox of `gears` gears choosing by `schedule`, with the parameters it sets per gear.
    pub fn gearbox(
        mut self,
        gears: usize,
        schedule: GearSchedule,
        parameters: Vec<String>,
    ) -> Self {
        self.plant.gears = gears;
        self.plant.schedule = schedule;
        self.plant.gear_parameters = parameters;
        self
    }

    /// The model's `[hybrid]` table.
    pub fn hybrid(mut self, config: invsim_model_api::HybridSpec) -> Self {
        self.plant.hybrid = Some(Box::new(config));
        self
    }

    /// Add a mode (in the model file's order).
    pub fn mode(mut self, meta: ModeMeta, model: Box<dyn InverseModel>) -> Self {
        self.plant.modes.push((meta, model));
        self
    }

    /// The plant, checked: at least one mode, every mode's inputs among the declared ones, every mode with the
    /// same states. The model's own `[outputs]` are the first outputs of every mode (the rest hold the fixed
    /// inputs and the couplings).
    pub fn build(mut self) -> Result<ModalPlant, ModalError> {
        let p = &mut self.plant;
        let Some((meta0, first)) = p.modes.first() else {
            return Err(ModalError::Setup(format!("`{}` has no mode", p.name)));
        };
        // The fixed inputs' outputs and the couplings' (a decided input has none: its value is the run's).
        let n_extra = meta0.fixed_outputs.len() + meta0.coupled.len();
        let total = first.info().outputs.len();
        p.n_outputs = total.checked_sub(n_extra).ok_or_else(|| {
            ModalError::Setup(format!(
                "mode `{}` has {total} outputs, fewer than its {n_extra} fixed inputs and couplings",
                meta0.name
            ))
        })?;
        let states = &first.info().states;
        for (meta, m) in &p.modes {
            if meta.free_input >= p.inputs.len()
                || meta.fixed_outputs.iter().any(|(i, _)| *i >= p.inputs.len())
            {
                return Err(ModalError::Setup(format!(
                    "mode `{}` names an input beyond the {} declared",
                    meta.name,
                    p.inputs.len()
                )));
            }
            if &m.info().states != states {
                return Err(ModalError::Setup(format!(
                    "mode `{}` has other states than mode `{}`",
                    meta.name, meta0.name
                )));
            }
        }
        Ok(self.plant)
    }
}
