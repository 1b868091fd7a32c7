//! The options of an energy-management strategy, shared by `simulate` and `sweep` (docs/hybrids.md):
//! `--strategy`, `--equivalence`, `--soc-tolerance`, DP's `--soc-grid`, `--split-grid`, `--soc-window` and the
//! rules' `--rb-*` (flattened into each command's arguments, so they keep their names in the provenance
//! record), checked once into the runtime's [`StrategyOptions`].

use invsim_runtime::modes::StrategyOptions;

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
    /// The strategy's options, checked (`None` without `--strategy`).
    pub fn options(&self) -> Result<Option<StrategyOptions>, Failure> {
        strategy(self)
    }
}

/// The strategy's options; `--equivalence` or a changed `--soc-tolerance` without `--strategy`, and DP's
/// options without `--strategy dp`, are refused.
fn strategy(args: &StrategyArgs) -> Result<Option<StrategyOptions>, Failure> {
    use invsim_runtime::modes as m;
    let tol_given = args.soc_tolerance != m::DEFAULT_SOC_TOLERANCE;
    let dp_given = args.soc_grid != m::DEFAULT_SOC_GRID
        || args.split_grid != m::DEFAULT_SPLIT_GRID
        || args.soc_window != m::DEFAULT_SOC_WINDOW;
    if dp_given && args.strategy != Some(StrategyArg::Dp) {
        return Err(Failure::user(
            "--soc-grid, --split-grid and --soc-window apply to --strategy dp; give --strategy dp"
                .to_string(),
        ));
    }
    let rb_given = args.rb_engine_power != m::DEFAULT_RB_ENGINE_POWER
        || args.rb_soc_low != m::DEFAULT_RB_SOC_LOW
        || args.rb_charge_power != m::DEFAULT_RB_CHARGE_POWER;
    if rb_given && args.strategy != Some(StrategyArg::RuleBased) {
        return Err(Failure::user(
            "--rb-engine-power, --rb-soc-low and --rb-charge-power apply to --strategy rule-based; give \
             --strategy rule-based"
                .to_string(),
        ));
    }
    if args.equivalence.is_some()
        && matches!(
            args.strategy,
            Some(StrategyArg::Dp | StrategyArg::RuleBased)
        )
    {
        return Err(Failure::user(
            "--equivalence applies to --strategy ecms; DP and the rules have no equivalence factor"
                .to_string(),
        ));
    }
    let method =
        match args.strategy {
            None if args.equivalence.is_some() || tol_given => return Err(Failure::user(
                "--equivalence and --soc-tolerance apply to --strategy ecms; give --strategy ecms"
                    .to_string(),
            )),
            None => return Ok(None),
            Some(StrategyArg::Ecms) => m::Method::Ecms,
            Some(StrategyArg::Dp) => dp_options(args)?,
            Some(StrategyArg::RuleBased) => rule_options(args)?,
        };
    if !(args.soc_tolerance > 0.0 && args.soc_tolerance.is_finite()) {
        return Err(Failure::user(format!(
            "--soc-tolerance must be a positive number, got {}",
            args.soc_tolerance
        )));
    }
    if let Some(s) = args.equivalence.filter(|s| !s.is_finite()) {
        return Err(Failure::user(format!(
            "--equivalence must be finite, got {s}"
        )));
    }
    Ok(Some(StrategyOptions {
        method,
        equivalence: args.equivalence,
        soc_tolerance: args.soc_tolerance,
    }))
}

/// `--rb-engine-power`, `--rb-soc-low`, `--rb-charge-power`, checked.
fn rule_options(args: &StrategyArgs) -> Result<invsim_runtime::modes::Method, Failure> {
    for (name, v) in [
        ("--rb-engine-power", args.rb_engine_power),
        ("--rb-soc-low", args.rb_soc_low),
        ("--rb-charge-power", args.rb_charge_power),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(Failure::user(format!(
                "{name} must be a number ≥ 0, got {v}"
            )));
        }
    }
    Ok(invsim_runtime::modes::Method::RuleBased(
        invsim_runtime::modes::RuleOptions {
            engine_power: args.rb_engine_power,
            soc_low: args.rb_soc_low,
            charge_power: args.rb_charge_power,
        },
    ))
}

/// `--soc-grid`, `--split-grid`, `--soc-window`, checked.
fn dp_options(args: &StrategyArgs) -> Result<invsim_runtime::modes::Method, Failure> {
    if args.soc_grid < 2 {
        return Err(Failure::user(format!(
            "--soc-grid must be at least 2, got {}",
            args.soc_grid
        )));
    }
    if args.split_grid < 2 {
        return Err(Failure::user(format!(
            "--split-grid must be at least 2, got {}",
            args.split_grid
        )));
    }
    if !(args.soc_window > 0.0 && args.soc_window.is_finite()) {
        return Err(Failure::user(format!(
            "--soc-window must be a positive number, got {}",
            args.soc_window
        )));
    }
    Ok(invsim_runtime::modes::Method::Dp(
        invsim_runtime::modes::DpOptions {
            soc_grid: args.soc_grid,
            split_grid: args.split_grid,
            soc_window: args.soc_window,
        },
    ))
}
