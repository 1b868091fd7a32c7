//! The `hybrid` block of a strategy's summary (docs/hybrids.md): the equivalence factor and how it was found,
//! the charge, the fuel and its J1711 correction, the engine's starts; with its lines of the printed summary.

use serde::Serialize;

/// The `hybrid` block of the summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HybridBlock {
    /// `ecms`, `dp` or `rule-based`.
    pub strategy: String,
    /// The equivalence factor s of the run (W of fuel per W of battery power); `null` for DP, which has none.
    pub equivalence_factor: Option<f64>,
    /// `given` (`--equivalence`), `searched`, or `none` (DP).
    pub equivalence_source: String,
    /// Runs the search took (1 when s was given or for DP; the J1711 correction's extra run not counted).
    pub search_runs: usize,
    /// DP only: the SOC grid's points, the decided input's grid, the SOC window [lo, hi].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dp: Option<DpBlock>,
    pub soc_tolerance: f64,
    pub soc_start: f64,
    pub soc_end: f64,
    /// `--verify`: the charge at the end of the replay of the run's modes, free input and decided inputs
    /// through the original equations (within the replay's tolerance and the strategy's O(dt⁴) step of the
    /// charge of `soc_end`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub soc_end_replayed: Option<f64>,
    pub delta_soc: f64,
    pub charge_sustaining: bool,
    /// ∫ P_fuel dt, J.
    pub fuel_energy_j: f64,
    /// The fuel energy at ΔSOC = 0 by SAE J1711's linear correction (the line through this run and a second
    /// one at another s); `null` where the two runs end at the same ΔSOC.
    pub fuel_energy_corrected_j: Option<f64>,
    /// d(fuel energy)/d(ΔSOC) of the correction, J.
    pub correction_slope_j: Option<f64>,
    /// ∫ P_batt dt, J (positive: drawn from the battery).
    pub battery_energy_j: f64,
    pub engine_starts: usize,
    pub engine_on_s: f64,
    /// J per start.
    pub start_penalty_j: f64,
    /// Grid points over each decided input's bounds before the refinement.
    pub grid: usize,
    /// The decided inputs.
    pub decided_inputs: Vec<String>,
}

/// The grids of a DP run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DpBlock {
    pub soc_grid: usize,
    pub split_grid: usize,
    pub soc_window: [f64; 2],
    /// The terminal penalty's slope μ, J per unit of SOC off the target.
    pub terminal_penalty: f64,
}

impl HybridBlock {
    /// The block's lines of the printed summary.
    pub fn write_text(&self, s: &mut String) {
        use std::fmt::Write as _;
        let corrected = match self.fuel_energy_corrected_j {
            Some(c) => format!("{:.6e} J", c),
            None => "none (both runs ended at the same ΔSOC)".into(),
        };
        match (&self.dp, self.equivalence_factor) {
            (Some(dp), _) => {
                let _ = writeln!(
                    s,
                    "strategy: {}  SOC grid {} points over [{:.4}, {:.4}], decided input's grid {} values",
                    self.strategy, dp.soc_grid, dp.soc_window[0], dp.soc_window[1], dp.split_grid
                );
            }
            (None, eq) => {
                let _ = writeln!(
                    s,
                    "strategy: {}  equivalence factor s = {:.9} ({}, {} run{})",
                    self.strategy,
                    eq.unwrap_or(f64::NAN),
                    self.equivalence_source,
                    self.search_runs,
                    if self.search_runs == 1 { "" } else { "s" }
                );
            }
        }
        let _ = writeln!(
            s,
            "SOC: {:.6} → {:.6}  ΔSOC = {:+.3e} (tolerance {:.1e}: {})",
            self.soc_start,
            self.soc_end,
            self.delta_soc,
            self.soc_tolerance,
            if self.charge_sustaining {
                "charge-sustaining"
            } else {
                "not charge-sustaining"
            }
        );
        if let Some(replayed) = self.soc_end_replayed {
            let _ = writeln!(
                s,
                "SOC at the end of the replay (--verify): {replayed:.6} ({:+.3e} from the run's)",
                replayed - self.soc_end
            );
        }
        let _ = writeln!(
            s,
            "fuel energy: {:.6e} J  corrected to ΔSOC = 0 (SAE J1711): {corrected}  battery energy: {:.6e} J",
            self.fuel_energy_j, self.battery_energy_j
        );
        let _ = writeln!(
            s,
            "engine starts: {}  engine on: {:.1} s",
            self.engine_starts, self.engine_on_s
        );
    }
}
