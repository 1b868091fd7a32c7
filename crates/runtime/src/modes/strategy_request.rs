//! A strategy as a front end asks for it — the command line's `--strategy`, `--equivalence`,
//! `--soc-tolerance`, `--soc-grid`, `--split-grid`, `--soc-window`, `--rb-*`, Python's keyword arguments of
//! the same names — checked once into [`StrategyOptions`] (docs/hybrids.md), so that every front end refuses
//! the same requests with the same message (naming the command line's option).

use super::strategy::{
    DpOptions, Method, RuleOptions, StrategyOptions, DEFAULT_RB_CHARGE_POWER,
    DEFAULT_RB_ENGINE_POWER, DEFAULT_RB_SOC_LOW, DEFAULT_SOC_GRID, DEFAULT_SOC_TOLERANCE,
    DEFAULT_SOC_WINDOW, DEFAULT_SPLIT_GRID,
};

/// The strategy's options as given; `None` (or the default's value) where an option was not given.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StrategyRequest {
    /// `ecms`, `dp` or `rule-based`; `None`: no strategy.
    pub strategy: Option<String>,
    pub equivalence: Option<f64>,
    pub soc_tolerance: Option<f64>,
    pub soc_grid: Option<usize>,
    pub split_grid: Option<usize>,
    pub soc_window: Option<f64>,
    pub rb_engine_power: Option<f64>,
    pub rb_soc_low: Option<f64>,
    pub rb_charge_power: Option<f64>,
}

/// Whether `v` was given with a value other than the default `d`.
fn given<T: PartialEq>(v: Option<T>, d: T) -> bool {
    v.is_some_and(|v| v != d)
}

impl StrategyRequest {
    /// The checked options (`None` without a strategy): an option of another strategy than the one asked
    /// for is refused, as are non-finite or out-of-range values; the message names the command-line option.
    pub fn resolve(&self) -> Result<Option<StrategyOptions>, String> {
        let name = self.strategy.as_deref();
        if !matches!(name, None | Some("ecms" | "dp" | "rule-based")) {
            return Err(format!(
                "--strategy `{}`: expected ecms, dp or rule-based",
                name.unwrap_or_default()
            ));
        }
        self.check_belongs(name)?;
        let method = match name {
            None => return Ok(None),
            Some("dp") => self.dp()?,
            Some("rule-based") => self.rules()?,
            _ => Method::Ecms,
        };
        let soc_tolerance = self.soc_tolerance.unwrap_or(DEFAULT_SOC_TOLERANCE);
        if !(soc_tolerance > 0.0 && soc_tolerance.is_finite()) {
            return Err(format!(
                "--soc-tolerance must be a positive number, got {soc_tolerance}"
            ));
        }
        if let Some(s) = self.equivalence.filter(|s| !s.is_finite()) {
            return Err(format!("--equivalence must be finite, got {s}"));
        }
        Ok(Some(StrategyOptions {
            method,
            equivalence: self.equivalence,
            soc_tolerance,
        }))
    }

    /// Every option given belongs to the strategy `name` asked for (DP's grids to `dp`, the rules' powers to
    /// `rule-based`, the equivalence factor and the tolerance to a strategy, the factor to ECMS).
    fn check_belongs(&self, name: Option<&str>) -> Result<(), String> {
        let dp_given = given(self.soc_grid, DEFAULT_SOC_GRID)
            || given(self.split_grid, DEFAULT_SPLIT_GRID)
            || given(self.soc_window, DEFAULT_SOC_WINDOW);
        if dp_given && name != Some("dp") {
            return Err(
                "--soc-grid, --split-grid and --soc-window apply to --strategy dp; give --strategy dp"
                    .into(),
            );
        }
        let rb_given = given(self.rb_engine_power, DEFAULT_RB_ENGINE_POWER)
            || given(self.rb_soc_low, DEFAULT_RB_SOC_LOW)
            || given(self.rb_charge_power, DEFAULT_RB_CHARGE_POWER);
        if rb_given && name != Some("rule-based") {
            return Err(
                "--rb-engine-power, --rb-soc-low and --rb-charge-power apply to --strategy \
                        rule-based; give --strategy rule-based"
                    .into(),
            );
        }
        if self.equivalence.is_some() && matches!(name, Some("dp" | "rule-based")) {
            return Err(
                "--equivalence applies to --strategy ecms; DP and the rules have no equivalence factor"
                    .into(),
            );
        }
        let tol_given = given(self.soc_tolerance, DEFAULT_SOC_TOLERANCE);
        if name.is_none() && (self.equivalence.is_some() || tol_given) {
            return Err(
                "--equivalence and --soc-tolerance apply to --strategy ecms; give --strategy ecms"
                    .into(),
            );
        }
        Ok(())
    }

    /// `--rb-engine-power`, `--rb-soc-low`, `--rb-charge-power`, checked (each ≥ 0 and finite).
    fn rules(&self) -> Result<Method, String> {
        let o = RuleOptions {
            engine_power: self.rb_engine_power.unwrap_or(DEFAULT_RB_ENGINE_POWER),
            soc_low: self.rb_soc_low.unwrap_or(DEFAULT_RB_SOC_LOW),
            charge_power: self.rb_charge_power.unwrap_or(DEFAULT_RB_CHARGE_POWER),
        };
        for (name, v) in [
            ("--rb-engine-power", o.engine_power),
            ("--rb-soc-low", o.soc_low),
            ("--rb-charge-power", o.charge_power),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(format!("{name} must be a number ≥ 0, got {v}"));
            }
        }
        Ok(Method::RuleBased(o))
    }

    /// `--soc-grid`, `--split-grid` (each at least 2), `--soc-window` (positive, finite), checked.
    fn dp(&self) -> Result<Method, String> {
        let o = DpOptions {
            soc_grid: self.soc_grid.unwrap_or(DEFAULT_SOC_GRID),
            split_grid: self.split_grid.unwrap_or(DEFAULT_SPLIT_GRID),
            soc_window: self.soc_window.unwrap_or(DEFAULT_SOC_WINDOW),
        };
        for (name, n) in [("--soc-grid", o.soc_grid), ("--split-grid", o.split_grid)] {
            if n < 2 {
                return Err(format!("{name} must be at least 2, got {n}"));
            }
        }
        if !(o.soc_window > 0.0 && o.soc_window.is_finite()) {
            return Err(format!(
                "--soc-window must be a positive number, got {}",
                o.soc_window
            ));
        }
        Ok(Method::Dp(o))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ask(strategy: Option<&str>) -> StrategyRequest {
        StrategyRequest {
            strategy: strategy.map(String::from),
            ..StrategyRequest::default()
        }
    }

    #[test]
    fn defaults_give_each_strategy_its_default_options() {
        assert_eq!(ask(None).resolve(), Ok(None));
        let dp = ask(Some("dp")).resolve().unwrap().unwrap();
        assert_eq!(dp.method, Method::Dp(DpOptions::default()));
        let rb = ask(Some("rule-based")).resolve().unwrap().unwrap();
        assert_eq!(rb.method, Method::RuleBased(RuleOptions::default()));
        assert_eq!(
            ask(Some("ecms")).resolve(),
            Ok(Some(StrategyOptions::default()))
        );
    }

    #[test]
    fn options_of_another_strategy_are_refused_naming_them() {
        let r = StrategyRequest {
            soc_grid: Some(11),
            ..ask(Some("ecms"))
        };
        assert!(r.resolve().unwrap_err().contains("--soc-grid"));
        let r = StrategyRequest {
            equivalence: Some(3.0),
            ..ask(Some("dp"))
        };
        assert!(r
            .resolve()
            .unwrap_err()
            .starts_with("--equivalence applies"));
        let r = StrategyRequest {
            soc_grid: Some(DEFAULT_SOC_GRID),
            ..ask(None)
        };
        assert_eq!(r.resolve(), Ok(None), "the default's value is not given");
        assert!(ask(Some("greedy"))
            .resolve()
            .unwrap_err()
            .contains("greedy"));
    }
}
