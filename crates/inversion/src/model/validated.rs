//! The validated model: every name checked, definitions inlined, each state's right-hand side split into
//! dx/dt = f(x) + g(x)·u, the output y = h(x) free of the input (contract section 2).

use invsim_expr::map::Map;
use invsim_expr::{Id, MapId, Pool, Symbol};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

/// A validated model: every name checked, definitions inlined, each state's right-hand side split into
/// `f + g·u`. All expressions live in [`Model::pool`]; parameters stay symbols (their values are the
/// defaults, see [`Model::nominal`]).
#[derive(Debug, Clone)]
pub struct Model {
    pub name: String,
    pub description: Option<String>,
    /// The model file (for messages).
    pub file: PathBuf,
    /// SHA-256 of the file's bytes, lowercase hex.
    pub source_hash: String,
    pub pool: Pool,
    /// In file order.
    pub parameters: Vec<Parameter>,
    /// In file order.
    pub definitions: Vec<Definition>,
    /// In file order.
    pub states: Vec<State>,
    pub input: Input,
    pub output: Output,
    /// The extra outputs of `[outputs]`, in file order.
    pub outputs: Vec<ExtraOutput>,
    /// `[engine]`: which extra outputs are the engine's speed and torque.
    pub engine: Option<Engine>,
    /// `[headline]`: the accumulated output the summary leads with, and what it measures.
    pub headline: Option<invsim_model_api::HeadlineInfo>,
    /// `[maps]` (contract §6), in file order; each is declared in [`Model::pool`] under its name.
    pub maps: Vec<MapInfo>,
    /// The exogenous signals of `[signals]`, in file order.
    pub signals: Vec<Signal>,
}

/// A lookup map of `[maps]` (contract §6).
#[derive(Debug, Clone)]
pub struct MapInfo {
    pub name: String,
    /// The map in [`Model::pool`].
    pub id: MapId,
    /// Argument names (for the docs); their number is the arity.
    pub args: Vec<String>,
    pub unit: Option<String>,
    pub doc: Option<String>,
    /// The CSV file the values came from, if any.
    pub file: Option<PathBuf>,
    /// Grid, values and settings.
    pub data: Arc<Map>,
}

/// An exogenous signal S (contract §5): a symbol in the expressions; its smoothed derivatives S_d1 … are
/// symbols the derivation adds.
#[derive(Debug, Clone)]
pub struct Signal {
    pub name: String,
    pub symbol: Symbol,
    pub unit: Option<String>,
    pub doc: Option<String>,
    /// Used when neither the command line nor the cycle file gives the signal.
    pub default: Option<f64>,
    /// The cycle file's column (`None`: the signal's name).
    pub column: Option<String>,
}

/// The validated `[engine]`: indices of its speed and torque into [`Model::outputs`], and its map.
#[derive(Debug, Clone, PartialEq)]
pub struct Engine {
    pub speed: usize,
    pub torque: usize,
    /// `map` (an expression in the speed and torque outputs' names, the parameters and the maps, checked),
    /// `map_unit` and `map_range`.
    pub map: Option<invsim_model_api::EngineMapInfo>,
}

/// A named numeric parameter (kept symbolic in derivations; `value` is its default).
#[derive(Debug, Clone)]
pub struct Parameter {
    pub name: String,
    pub symbol: Symbol,
    pub value: f64,
    pub unit: Option<String>,
    pub doc: Option<String>,
}

/// A named intermediate quantity.
#[derive(Debug, Clone)]
pub struct Definition {
    pub name: String,
    pub symbol: Symbol,
    /// The expression as written in the file.
    pub source: String,
    /// The expression as written, parsed (it may refer to earlier definitions).
    pub expr: Id,
    /// The expression with all definitions inlined.
    pub inlined: Id,
    pub unit: Option<String>,
    pub doc: Option<String>,
}

/// A state `x` with `dx/dt = f(x) + g(x) u` (definitions inlined everywhere).
#[derive(Debug, Clone)]
pub struct State {
    pub name: String,
    pub symbol: Symbol,
    pub unit: Option<String>,
    pub doc: Option<String>,
    /// `f + g·u`.
    pub rhs: Id,
    /// The drift, free of the input.
    pub f: Id,
    /// The input gain, free of the input.
    pub g: Id,
    /// `initial = VALUE`: the value at the start of a run for a state the inversion does not fix (an internal
    /// state); `None` when the model file gives none.
    pub initial: Option<f64>,
    /// `rhs` is affine in the input (then `rhs = f + g·u`); otherwise `rhs` is the whole right-hand side and
    /// f, g are its value and slope at u = 0 (contract §5).
    pub affine: bool,
}

/// The model's single input `u`.
#[derive(Debug, Clone)]
pub struct Input {
    pub name: String,
    pub symbol: Symbol,
    pub unit: Option<String>,
    pub doc: Option<String>,
    /// Optional bounds; violations are reported, not clipped.
    pub min: Option<f64>,
    pub max: Option<f64>,
}

/// The tracked output `y = h(x)`.
#[derive(Debug, Clone)]
pub struct Output {
    pub name: String,
    /// `h` with definitions inlined; free of the input.
    pub h: Id,
    /// `h` as written in the file.
    pub source: String,
    pub unit: Option<String>,
    pub doc: Option<String>,
    /// The output's nominal value y0 (`nominal`, optional): where `invsim derive` linearises the zero dynamics
    /// (ξ = (y0, 0, …, 0), y^(r) = 0, η at the equilibrium). `None`: [`Output::reference_offset`].
    pub nominal: Option<f64>,
    /// The reference the drive cycle defines for this output: y_d = `reference_offset` +
    /// `reference_scale` · (smoothed cycle), so that every derivative of y_d stays exact (defaults 0 and 1:
    /// y_d is the smoothed cycle itself, a vehicle speed in m/s).
    pub reference_offset: f64,
    pub reference_scale: f64,
}

impl Output {
    /// The nominal output value y0: `nominal`, or else `reference_offset` (the reference at a standstill).
    pub fn nominal_value(&self) -> f64 {
        self.nominal.unwrap_or(self.reference_offset)
    }
}

/// An extra signal of `[outputs]`, reported per sample (and integrated over the run if `accumulate`).
#[derive(Debug, Clone)]
pub struct ExtraOutput {
    pub name: String,
    /// The expression with definitions inlined (it may use the input).
    pub expr: Id,
    /// The expression as written in the file.
    pub source: String,
    pub unit: Option<String>,
    pub doc: Option<String>,
    pub accumulate: bool,
    /// Its integral is reported per 100 km (`per_distance`; default: accumulated outputs of a model whose
    /// reference map is the identity, i.e. that tracks the cycle's speed).
    pub per_distance: bool,
}

impl Model {
    /// The parameters' default values, by symbol.
    pub fn nominal(&self) -> HashMap<Symbol, f64> {
        self.parameters
            .iter()
            .map(|p| (p.symbol, p.value))
            .collect()
    }

    /// Every state's right-hand side is affine in the input.
    pub fn is_affine(&self) -> bool {
        self.states.iter().all(|s| s.affine)
    }

    /// The states' symbols, in file order.
    pub fn state_symbols(&self) -> Vec<Symbol> {
        self.states.iter().map(|s| s.symbol).collect()
    }
}
