//! The options of an energy-management strategy, shared by `simulate` and `sweep` (docs/hybrids.md):
//! `--strategy`, `--equivalence`, `--soc-tolerance`, DP's `--soc-grid`, `--split-grid`, `--soc-window` and the
//! rules' `--rb-*` (flattened into each command's arguments, so they keep their names in the provenance
//! record), checked by the runtime's [`StrategyRequest`] as Python's are.

use invsim_runtime::modes::{StrategyOptions, StrategyRequest};

use crate::error::Failure;

#[derive(clap::Args, Debug, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub struct StrategyArgs {
    /// Models with a [hybrid] table: the energy-management strategy that decides the mode and the decided
    /// inputs at every sample (`ecms`: the equivalent consumption minimisation strategy; `dp`: dynamic
    /// programming over a SOC grid, the charge-sustaining optimum up to the grids' error; `rule-based`: rules
    /// after FASTSim's RESGreedy).
    #[arg(long, value_enum)]
    pub strategy: Option<StrategyArg>,
    /// With --strategy ecms: the equivalence factor s (W of fuel per W of battery power); default: searched
    /// so that the run ends charge-sustaining within --soc-tolerance.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    equivalence: Option<f64>,
    /// With --strategy ecms: the charge-sustaining tolerance on |ΔSOC|, a fraction of the battery's capacity.
    #[arg(long, value_name = "TOL", default_value_t = invsim_runtime::modes::DEFAULT_SOC_TOLERANCE)]
    soc_tolerance: f64,
    /// With --strategy dp: points of the SOC grid over the SOC window (at least 2).
    #[arg(long, value_name = "N", default_value_t = invsim_runtime::modes::DEFAULT_SOC_GRID)]
    soc_grid: usize,
    /// With --strategy dp: values of the decided input's grid over its bounds (at least 2).
    #[arg(long, value_name = "M", default_value_t = invsim_runtime::modes::DEFAULT_SPLIT_GRID)]
    split_grid: usize,
    /// With --strategy dp: the SOC window's half-width w, a fraction of the capacity: the grid spans
    /// [SOC(0) − w, SOC(0) + w] clipped to [0, 1].
    #[arg(long, value_name = "W", allow_negative_numbers = true,
          default_value_t = invsim_runtime::modes::DEFAULT_SOC_WINDOW)]
    soc_window: f64,
    /// With --strategy rule-based: electric drive up to this battery power, W.
    #[arg(long, value_name = "W", allow_negative_numbers = true,
          default_value_t = invsim_runtime::modes::DEFAULT_RB_ENGINE_POWER)]
    rb_engine_power: f64,
    /// With --strategy rule-based: the engine runs whenever the charge is below SOC(0) minus this.
    #[arg(long, value_name = "DSOC", allow_negative_numbers = true,
          default_value_t = invsim_runtime::modes::DEFAULT_RB_SOC_LOW)]
    rb_soc_low: f64,
    /// With --strategy rule-based: the battery power the running engine charges with below SOC(0), W.
    #[arg(long, value_name = "W", allow_negative_numbers = true,
          default_value_t = invsim_runtime::modes::DEFAULT_RB_CHARGE_POWER)]
    rb_charge_power: f64,
}

/// `--strategy`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StrategyArg {
    Ecms,
    Dp,
    RuleBased,
}

impl StrategyArgs {
    /// The strategy's options, checked by the runtime's [`StrategyRequest`] (`None` without `--strategy`):
    /// `--equivalence` or a changed `--soc-tolerance` without `--strategy`, and one strategy's options with
    /// another, are refused.
    pub fn options(&self) -> Result<Option<StrategyOptions>, Failure> {
        let strategy = self.strategy.map(|s| match s {
            StrategyArg::Ecms => "ecms",
            StrategyArg::Dp => "dp",
            StrategyArg::RuleBased => "rule-based",
        });
        StrategyRequest {
            strategy: strategy.map(String::from),
            equivalence: self.equivalence,
            soc_tolerance: Some(self.soc_tolerance),
            soc_grid: Some(self.soc_grid),
            split_grid: Some(self.split_grid),
            soc_window: Some(self.soc_window),
            rb_engine_power: Some(self.rb_engine_power),
            rb_soc_low: Some(self.rb_soc_low),
            rb_charge_power: Some(self.rb_charge_power),
        }
        .resolve()
        .map_err(Failure::user)
    }
}
