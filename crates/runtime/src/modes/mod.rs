//! Inverse simulation of a model with operating modes (docs/reference.md §2.5): one single-input
//! [`InverseModel`] per mode, a mode sequence decided along the run — the gear from a schedule
//! ([`gears`]), standstill from the smoothed reference, traction or braking from the solution itself — and
//! switches that keep the physical state continuous.
//!
//! At a switch at t_s the state x(t_s) is that of the old mode. Two ways to enter the new mode:
//! - **re-entry** (default): the new mode's reference starts from the ξ that x(t_s) gives in the new mode and
//!   joins the smoothed cycle within the transition time ([`blend`]); every state stays continuous and the
//!   input finite, and each transition's largest deviation from the cycle is reported.
//! - **quasi-static**: the new mode's reference is the smoothed cycle at once; the state jumps to
//!   ψ⁻¹(ξ_cycle, η(x(t_s))), realised as an impulse U of the free input along g(x): Δx = U g, so
//!   U = g·Δx / g·g. Each accumulated output o is booked U · ∂o/∂u (∂o/∂u by central differences), and a part
//!   of Δx that is not along g (no impulse of the input can make it) is reported.

mod bases;
pub mod blend;
mod charge_window;
pub(crate) mod coupling;
mod dp;
mod ecms;
mod equivalence;
pub mod gears;
mod gradient;
mod gradient_point;
mod gradient_strategy;
mod gradient_zd;
pub mod hybrid;
mod hybrid_block;
mod interval_cost;
mod minimise;
pub mod plant;
mod price_cache;
mod record;
mod reference;
mod rows;
mod rule_based;
pub(crate) mod rules;
mod runner;
mod scratch;
pub(crate) mod sequence;
mod signals;
mod still;
mod strategy;
mod strategy_request;
mod summary;
mod tally;
mod verify;
mod zd_ode;

use invsim_model_api::InverseModel;
use thiserror::Error;

pub use crate::smoother::ZeroDynamicsReference;
pub use gears::{GearBox, GearSource};
pub use hybrid::{simulate_hybrid, simulate_hybrid_differentiated};
pub use hybrid_block::{DpBlock, HybridBlock};
pub use plant::{GearSchedule, ModalPlant, ModalPlantBuilder, ModeMeta};
pub use record::{CouplingReset, Impulse, ModeTime, Transition};
pub(crate) use reference::ReferenceCell;
pub use rows::Rows;
pub(crate) use runner::{decided_inputs_of, refuse_decided, simulate_modes_kept};
pub use runner::{
    simulate_modes, simulate_modes_differentiated, simulate_modes_with_reference,
    simulate_modes_with_signals,
};
pub use strategy::{
    DpOptions, Method, RuleOptions, StrategyOptions, DEFAULT_RB_CHARGE_POWER,
    DEFAULT_RB_ENGINE_POWER, DEFAULT_RB_SOC_LOW, DEFAULT_SOC_GRID, DEFAULT_SOC_TOLERANCE,
    DEFAULT_SOC_WINDOW, DEFAULT_SPLIT_GRID,
};
pub use strategy_request::StrategyRequest;
pub use summary::{ModalSummary, ModesBlock};

/// What a mode is for (see `invsim_inversion::ModeRole`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    Traction,
    Brake,
    Standstill,
}

/// One declared input of the model.
#[derive(Debug, Clone, PartialEq)]
pub struct InputSpec {
    pub name: String,
    pub unit: Option<String>,
    pub min: Option<f64>,
    pub max: Option<f64>,
}

/// One mode: its model (single free input), role and gear.
pub struct ModeSpec<'m> {
    pub name: String,
    /// The `[modes.NAME]` table (all gears of a geared mode share it).
    pub family: String,
    pub role: Role,
    pub gear: Option<usize>,
    /// Index into [`ModalSpec::inputs`].
    pub free_input: usize,
    /// For each input that the mode fixes, (input index, index of the model output that holds its value).
    pub fixed_outputs: Vec<(usize, usize)>,
    /// For each state the mode couples to the others (`couple`, a clutch closed), (state index, index of the
    /// model output that holds its coupling c(x)): entering the mode sets the state to c(x).
    pub coupled: Vec<(usize, usize)>,
    pub model: &'m dyn InverseModel,
}

/// The options of the mode sequence.
#[derive(Debug, Clone, PartialEq)]
pub struct SequenceParams {
    pub standstill_below: f64,
    pub standstill_above: f64,
    /// Hysteresis band of the traction → brake switch (units of the traction input); default 1 % of the
    /// traction input's range where it has both bounds, else 0.
    pub brake_band: Option<f64>,
    pub min_dwell: f64,
}

/// A model with modes, ready to run.
pub struct ModalSpec<'m> {
    pub name: String,
    pub inputs: Vec<InputSpec>,
    pub modes: Vec<ModeSpec<'m>>,
    pub gears: usize,
    pub gear_source: GearSource,
    pub sequence: SequenceParams,
    /// Number of the model's own `[outputs]` (the first ones of every mode's outputs; the rest hold fixed
    /// inputs).
    pub n_outputs: usize,
    /// The `[hybrid]` table of a model whose modes a strategy decides (its figures show the charge and the
    /// engine's on/off band), else `None`.
    pub hybrid: Option<&'m invsim_model_api::HybridSpec>,
}

impl ModalSpec<'_> {
    /// The highest relative degree of its modes (0 without modes).
    pub fn r_max(&self) -> usize {
        self.modes
            .iter()
            .map(|m| m.model.info().relative_degree)
            .max()
            .unwrap_or(0)
    }

    /// The traction input: the free input of the first traction mode (the throttle or fuel flow; the first
    /// input for a model without a traction mode). The summaries report it as the run's `input`.
    pub fn traction_input(&self) -> usize {
        self.modes
            .iter()
            .find(|m| m.role == Role::Traction)
            .map_or(0, |m| m.free_input)
    }

    /// Every input with the `ranges` ([min, max]) it took over a run and its declared bounds.
    pub(crate) fn input_ranges(&self, ranges: &[[f64; 2]]) -> Vec<crate::report::InputRange> {
        self.inputs
            .iter()
            .zip(ranges)
            .map(|(i, r)| crate::report::InputRange {
                name: i.name.clone(),
                unit: i.unit.clone(),
                min: r[0],
                max: r[1],
                lower_bound: i.min,
                upper_bound: i.max,
            })
            .collect()
    }
}

/// How a switch enters the new mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Switching {
    Reentry,
    QuasiStatic,
}

impl Switching {
    pub fn as_str(self) -> &'static str {
        match self {
            Switching::Reentry => "reentry",
            Switching::QuasiStatic => "quasi_static",
        }
    }
}

/// Options of a run with modes.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalOptions {
    pub lookahead: f64,
    pub dt: f64,
    pub switching: Switching,
    /// Transition time of the re-entry, s (default: the look-ahead).
    pub transition_time: Option<f64>,
    pub verify: bool,
    /// Keep the time series (default true); `false` (a sweep) tallies the summary without building the
    /// table of every column at every sample.
    pub keep_series: bool,
    /// Tally the engine's operating points (default true; a sweep's rows do not report them).
    pub operating_points: bool,
}

impl Default for ModalOptions {
    fn default() -> Self {
        ModalOptions {
            lookahead: 5.0,
            dt: 0.1,
            switching: Switching::Reentry,
            transition_time: None,
            verify: false,
            keep_series: true,
            operating_points: true,
        }
    }
}

/// Errors of a run with modes.
#[derive(Debug, Error)]
pub enum ModalError {
    #[error("{0}")]
    Run(#[from] crate::RunError),
    #[error("mode `{mode}` at t = {} s: {message}", crate::numfmt::num(*t))]
    Mode {
        mode: String,
        t: f64,
        message: String,
    },
    #[error("{0}")]
    Setup(String),
}

/// The result: summary and columns (`t`, `mode`, `gear`, `yd_0` … `yd_R`, every input, the states, the
/// model's `[outputs]`).
#[derive(Debug, Clone)]
pub struct ModalResult {
    pub summary: ModalSummary,
    pub columns: Vec<String>,
    pub units: Vec<Option<String>>,
    pub data: Vec<Vec<f64>>,
    /// Mode index at each sample (into the spec's modes).
    pub mode: Vec<usize>,
    /// The mode's free input at the end of each interval [t_k, t_{k+1}] before any switch at t_{k+1}.
    pub u_end: Vec<f64>,
    /// The state at the end of each interval [t_k, t_{k+1}] in its mode, before any switch at t_{k+1}.
    pub x_end: Rows,
    /// The mode's solution at each sample: the state, the free input and the reference y^(0 … R) it tracked.
    pub states: Rows,
    pub free: Vec<f64>,
    pub yref: Rows,
    /// Impulse of the free input at each sample (quasi-static switches; 0 elsewhere).
    pub impulse: Vec<f64>,
    /// The model's signals as the run resolved them (the run used them smoothed).
    pub signals: Vec<crate::signals::ResolvedSignal>,
}

impl ModalResult {
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .position(|c| c == name)
            .map(|i| self.data[i].as_slice())
    }
}
