//! The types of a model with several inputs and operating modes (docs/reference.md §2.5): the declared inputs, one
//! ordinary single-input [`Model`] per mode (the mode's other inputs substituted by their values), the
//! gearbox with its schedule and the options of the mode sequence.

use super::validated::Model;
use std::path::PathBuf;

/// A model file read: an ordinary single-input model, or one with modes.
#[derive(Debug)]
pub enum ModelFile {
    Single(Box<Model>),
    Modal(Box<ModalModel>),
}

/// One of a modal model's declared inputs.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalInput {
    pub name: String,
    pub unit: Option<String>,
    pub doc: Option<String>,
    pub min: Option<f64>,
    pub max: Option<f64>,
}

/// What a mode is for, which decides when the sequence enters it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModeRole {
    /// The default: the car drives; entered unless another role applies.
    Traction,
    /// Entered when the traction mode's free input would fall below its minimum; left when this mode's free
    /// input would fall below its own minimum.
    Brake,
    /// Entered when the smoothed reference is below `standstill_below`; left when the free input would fall
    /// below its minimum or the reference exceeds `standstill_above`.
    Standstill,
}

impl ModeRole {
    pub fn as_str(self) -> &'static str {
        match self {
            ModeRole::Traction => "traction",
            ModeRole::Brake => "brake",
            ModeRole::Standstill => "standstill",
        }
    }
}

/// What a run needs to know of a mode beside its model: its name, gear, role, inputs and couplings
/// ([`Mode`] without the model; what [`ModelFile::modal_headers`] reads for a file compiled code was made
/// from).
#[derive(Debug, Clone, PartialEq)]
pub struct ModeHeader {
    /// `drive_3` for gear 3 of the geared mode `drive`, else the mode's name.
    pub name: String,
    /// The `[modes.NAME]` table it comes from.
    pub family: String,
    /// The gear (1-based) of a geared mode.
    pub gear: Option<usize>,
    pub role: ModeRole,
    /// Index into [`ModalModel::inputs`] of the free input.
    pub free: usize,
    /// The values of the other inputs as written (expression text), by input index.
    pub fixed: Vec<(usize, String)>,
    /// The states the mode couples to the others (`couple`), by state index, with the coupling as written.
    pub coupled: Vec<(usize, String)>,
    /// The inputs a strategy decides in this mode (`decided`), by input index: each is a signal of the
    /// mode's model whose value the strategy supplies per sample.
    pub decided: Vec<usize>,
    /// The parameters the mode sets itself (`parameters = { c_fuel = 0.0 }`), by name: the mode does not take
    /// the file's value of these.
    pub parameters: Vec<String>,
}

impl Mode {
    /// The mode with its model, from its header.
    pub(super) fn new(h: ModeHeader, model: Model) -> Mode {
        Mode {
            name: h.name,
            family: h.family,
            gear: h.gear,
            role: h.role,
            free: h.free,
            fixed: h.fixed,
            coupled: h.coupled,
            decided_at: vec![None; h.decided.len()],
            decided: h.decided,
            parameters: h.parameters,
            model,
        }
    }

    /// The mode without its model.
    pub fn into_header(self) -> ModeHeader {
        self.into_parts().0
    }

    /// The mode's header and its model.
    pub fn into_parts(self) -> (ModeHeader, Model) {
        let header = ModeHeader {
            name: self.name,
            family: self.family,
            gear: self.gear,
            role: self.role,
            free: self.free,
            fixed: self.fixed,
            coupled: self.coupled,
            decided: self.decided,
            parameters: self.parameters,
        };
        (header, self.model)
    }
}

/// What compiled code made from a file with modes knows of it (the first mode's description: every mode has
/// the model's name, description, parameters and states), so that a run of that code reads only the file's
/// modes, inputs, gearbox and sequence ([`ModelFile::modal_headers_of`]) and builds no mode's equations.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalFacts {
    pub name: String,
    pub description: Option<String>,
    pub parameters: Vec<String>,
    pub states: Vec<String>,
}

impl ModalFacts {
    /// What the description of a mode's compiled code says of its file.
    pub fn from_info(info: &invsim_model_api::ModelInfo) -> ModalFacts {
        ModalFacts {
            name: info.name.clone(),
            description: Some(info.description.clone()).filter(|d| !d.is_empty()),
            parameters: info.parameters.clone(),
            states: info.states.clone(),
        }
    }

    /// The index of the state called `name`.
    pub fn state_index(&self, name: &str) -> Option<usize> {
        self.states.iter().position(|s| s == name)
    }
}

/// One operating mode: a single-input model of its own.
#[derive(Debug)]
pub struct Mode {
    /// `drive_3` for gear 3 of the geared mode `drive`, else the mode's name.
    pub name: String,
    /// The `[modes.NAME]` table it comes from.
    pub family: String,
    /// The gear (1-based) of a geared mode.
    pub gear: Option<usize>,
    pub role: ModeRole,
    /// Index into [`ModalModel::inputs`] of the free input.
    pub free: usize,
    /// The values of the other inputs as written (expression text), by input index.
    pub fixed: Vec<(usize, String)>,
    /// The states the mode couples to the others (`couple`), by state index, with the coupling as written;
    /// each is also the extra output `coupling_NAME` (after the fixed inputs' outputs).
    pub coupled: Vec<(usize, String)>,
    /// The mode's model: its `[input]` the free input, the other inputs definitions, and each other input
    /// also an extra output of its name (appended after the file's `[outputs]`).
    pub model: Model,
    /// The inputs a strategy decides in this mode, by input index (see [`ModeHeader::decided`]).
    pub decided: Vec<usize>,
    /// Where each of [`Mode::decided`] is written: 1-based line and column.
    pub decided_at: Vec<Option<(usize, usize)>>,
    /// The parameters the mode sets itself (see [`ModeHeader::parameters`]).
    pub parameters: Vec<String>,
}

/// How the gear is chosen along the run.
#[derive(Debug, Clone, PartialEq)]
pub enum Schedule {
    /// Up- and downshift speeds of the smoothed cycle (m/s): shift from gear k to k+1 when the speed rises
    /// above `up[k-1]`, from k+1 to k when it falls below `down[k-1]`.
    Speed { up: Vec<f64>, down: Vec<f64> },
    /// The regulation's gear prescription for a manual car (ECE-15 and EUDC parts of the NEDC).
    Regulation,
    /// A column of the cycle file holding the gear (0 or empty: the lowest gear).
    Column(String),
}

/// The gearbox: the parameters each gear sets, and the schedule.
#[derive(Debug, Clone, PartialEq)]
pub struct Gearbox {
    pub gears: usize,
    /// Parameter name → its value in gear 1 … N.
    pub parameters: Vec<(String, Vec<f64>)>,
    pub schedule: Schedule,
}

/// Options of the mode sequence (`[sequence]`).
#[derive(Debug, Clone, PartialEq)]
pub struct SequenceOptions {
    /// Standstill below this smoothed-cycle speed (m/s).
    pub standstill_below: f64,
    /// Standstill left at the latest above this speed (m/s).
    pub standstill_above: f64,
    /// Hysteresis of the traction → brake switch, in units of the traction input: brake is entered when the
    /// traction input falls below min + band (after it has once been above min + band since the last brake).
    pub brake_band: Option<f64>,
    /// Shortest time between two traction/brake switches, s.
    pub min_dwell: f64,
}

impl Default for SequenceOptions {
    fn default() -> Self {
        SequenceOptions {
            standstill_below: 0.05,
            standstill_above: 1.0,
            brake_band: None,
            min_dwell: 0.0,
        }
    }
}

/// A model with several inputs and operating modes.
#[derive(Debug)]
pub struct ModalModel {
    pub name: String,
    pub description: Option<String>,
    pub file: PathBuf,
    pub source_hash: String,
    pub inputs: Vec<ModalInput>,
    pub modes: Vec<Mode>,
    pub gearbox: Option<Gearbox>,
    pub sequence: SequenceOptions,
    /// `[hybrid]`: what an energy-management strategy weighs (none without the table).
    pub hybrid: Option<HybridSpec>,
}

pub use invsim_model_api::HybridSpec;

impl ModalModel {
    /// The index of the mode called `name`.
    pub fn mode_index(&self, name: &str) -> Option<usize> {
        self.modes.iter().position(|m| m.name == name)
    }
}
