//! The model file's `[hybrid]` table (docs/hybrids.md) as the reader validates it and the runtime's strategies
//! read it: the outputs an energy-management strategy weighs, the charge state it keeps, the modes in which the
//! engine runs and the search's settings. Plain data, by name.

/// The `[hybrid]` table.
#[derive(Debug, Clone, PartialEq)]
pub struct HybridSpec {
    /// The `[outputs]` entry that is the fuel's chemical power, W.
    pub fuel_power: String,
    /// The `[outputs]` entry that is the battery's chemical power, W (positive when discharging).
    pub battery_power: String,
    /// The state that is the battery's charge, a fraction of its capacity.
    pub soc: String,
    /// The modes (`[modes.NAME]` names, i.e. mode families) in which the engine runs.
    pub engine_on: Vec<String>,
    /// Energy charged for each engine start, J.
    pub start_penalty: f64,
    /// Points of the grid over each decided input's bounds before the refinement.
    pub grid: usize,
}
