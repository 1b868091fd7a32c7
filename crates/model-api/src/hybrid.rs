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
    /// The rules `--strategy rule-based` follows when the model gives them (`rule_request`, `rule_target`,
    /// `rule_min_on`); `None`: the default rules (docs/hybrids.md, "Rule-based").
    pub rules: Option<RuleSpec>,
}

/// A model's own rules for `--strategy rule-based` (FASTSim's hybrid controller, as its import writes them):
/// the engine runs where the output `request` is positive or within `min_on` seconds of its start, with the
/// decided input at the value that brings the output `target` nearest zero.
#[derive(Debug, Clone, PartialEq)]
pub struct RuleSpec {
    /// The `[outputs]` entry that asks for the engine where it is positive.
    pub request: String,
    /// The `[outputs]` entry the engine's decided input brings nearest zero.
    pub target: String,
    /// The least time the engine runs once started, s.
    pub min_on: f64,
}
