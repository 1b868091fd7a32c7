//! The types of an energy-management strategy's run (docs/hybrids.md): the options of `--strategy ecms`,
//! `--strategy dp` and `--strategy rule-based` (the model file's `[hybrid]` table is
//! [`invsim_model_api::HybridSpec`]). Plain data, imported by the run's options, the
//! plant and the hybrid run alike.

/// Which strategy decides (`--strategy`).
#[derive(Debug, Clone, PartialEq)]
pub enum Method {
    /// The equivalent consumption minimisation strategy (docs/hybrids.md, ECMS).
    Ecms,
    /// Deterministic dynamic programming over a SOC grid (docs/hybrids.md, Dynamic programming).
    Dp(DpOptions),
    /// Rules after FASTSim's RESGreedy (docs/hybrids.md, Rule-based).
    RuleBased(RuleOptions),
}

impl Method {
    /// The command-line option that chose it (`--strategy ecms`, `--strategy dp`, `--strategy rule-based`),
    /// for messages.
    pub fn flag(&self) -> &'static str {
        match self {
            Method::Ecms => "--strategy ecms",
            Method::Dp(_) => "--strategy dp",
            Method::RuleBased(_) => "--strategy rule-based",
        }
    }
}

/// The options of `--strategy rule-based`.
#[derive(Debug, Clone, PartialEq)]
pub struct RuleOptions {
    /// Electric drive up to this battery power, W (`--rb-engine-power`).
    pub engine_power: f64,
    /// The engine runs below SOC(0) − this (`--rb-soc-low`).
    pub soc_low: f64,
    /// Battery power the engine charges with below SOC(0), W (`--rb-charge-power`).
    pub charge_power: f64,
}

/// Default `--rb-engine-power`: 15 kW.
pub const DEFAULT_RB_ENGINE_POWER: f64 = 15e3;
/// Default `--rb-soc-low`: 0.02.
pub const DEFAULT_RB_SOC_LOW: f64 = 0.02;
/// Default `--rb-charge-power`: 5 kW.
pub const DEFAULT_RB_CHARGE_POWER: f64 = 5e3;

impl Default for RuleOptions {
    fn default() -> Self {
        RuleOptions {
            engine_power: DEFAULT_RB_ENGINE_POWER,
            soc_low: DEFAULT_RB_SOC_LOW,
            charge_power: DEFAULT_RB_CHARGE_POWER,
        }
    }
}

/// The options of `--strategy dp`.
#[derive(Debug, Clone, PartialEq)]
pub struct DpOptions {
    /// Points of the SOC grid (`--soc-grid`).
    pub soc_grid: usize,
    /// Values of the decided input's grid over its bounds (`--split-grid`).
    pub split_grid: usize,
    /// Half-width w of the SOC window [SOC(0) − w, SOC(0) + w] (`--soc-window`; default
    /// [`DEFAULT_SOC_WINDOW`], clipped to [0, 1]).
    pub soc_window: f64,
}

/// The default SOC grid: 101 points.
pub const DEFAULT_SOC_GRID: usize = 101;
/// The default grid of the decided input: 41 values.
pub const DEFAULT_SPLIT_GRID: usize = 41;
/// The default half-width of the SOC window, a fraction of the capacity.
pub const DEFAULT_SOC_WINDOW: f64 = 0.2;

impl Default for DpOptions {
    fn default() -> Self {
        DpOptions {
            soc_grid: DEFAULT_SOC_GRID,
            split_grid: DEFAULT_SPLIT_GRID,
            soc_window: DEFAULT_SOC_WINDOW,
        }
    }
}

/// A strategy's options (`--strategy`, `--equivalence`, `--soc-tolerance`, and DP's grids).
#[derive(Debug, Clone, PartialEq)]
pub struct StrategyOptions {
    pub method: Method,
    /// ECMS: the equivalence factor s; `None`: searched so that |ΔSOC| ≤ `soc_tolerance`.
    pub equivalence: Option<f64>,
    /// Charge-sustaining tolerance on |ΔSOC| (fraction of the capacity).
    pub soc_tolerance: f64,
}

/// The default charge-sustaining tolerance: 10⁻⁴ of the capacity.
pub const DEFAULT_SOC_TOLERANCE: f64 = 1e-4;

impl Default for StrategyOptions {
    fn default() -> Self {
        StrategyOptions {
            method: Method::Ecms,
            equivalence: None,
            soc_tolerance: DEFAULT_SOC_TOLERANCE,
        }
    }
}
