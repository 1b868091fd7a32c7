//! The types of an energy-management strategy's run (docs/hybrids.md): the model file's `[hybrid]` table as
//! the plant keeps it, and the options of `--strategy ecms`. Plain data, imported by the run's options, the
//! plant and the hybrid run alike.

/// The model file's `[hybrid]` table, by name (see `invsim_inversion::HybridSpec`).
#[derive(Debug, Clone, PartialEq)]
pub struct HybridConfig {
    pub fuel_power: String,
    pub battery_power: String,
    pub soc: String,
    /// Mode families in which the engine runs.
    pub engine_on: Vec<String>,
    /// J per engine start.
    pub start_penalty: f64,
    /// Grid points over a decided input's bounds.
    pub grid: usize,
}

/// The ECMS strategy's options (`--strategy ecms`, `--equivalence`, `--soc-tolerance`).
#[derive(Debug, Clone, PartialEq)]
pub struct EcmsOptions {
    /// The equivalence factor s; `None`: searched so that |ΔSOC| ≤ `soc_tolerance`.
    pub equivalence: Option<f64>,
    /// Charge-sustaining tolerance on |ΔSOC| (fraction of the capacity).
    pub soc_tolerance: f64,
}

/// The default charge-sustaining tolerance: 10⁻⁴ of the capacity.
pub const DEFAULT_SOC_TOLERANCE: f64 = 1e-4;

impl Default for EcmsOptions {
    fn default() -> Self {
        EcmsOptions {
            equivalence: None,
            soc_tolerance: DEFAULT_SOC_TOLERANCE,
        }
    }
}
