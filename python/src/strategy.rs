//! The energy-management keyword arguments of `Model.simulate` and `Model.sweep` (`strategy="ecms"`,
//! `equivalence=`, `soc_tolerance=`, `soc_grid=`, `split_grid=`, `soc_window=`, `rb_engine_power=`,
//! `rb_soc_low=`, `rb_charge_power=`; docs/hybrids.md), handed over by the Python wrapper as one dict with
//! every key (None where not given) and checked by the runtime's `StrategyRequest`, as the command line's
//! `--strategy` and its options are.

use invsim_runtime::modes::StrategyRequest;
use pyo3::prelude::*;

/// The dict of the strategy's keyword arguments.
#[derive(FromPyObject, Debug, Clone, Default)]
#[pyo3(from_item_all)]
pub struct PyStrategy {
    strategy: Option<String>,
    equivalence: Option<f64>,
    soc_tolerance: Option<f64>,
    soc_grid: Option<usize>,
    split_grid: Option<usize>,
    soc_window: Option<f64>,
    rb_engine_power: Option<f64>,
    rb_soc_low: Option<f64>,
    rb_charge_power: Option<f64>,
}

impl From<PyStrategy> for StrategyRequest {
    fn from(p: PyStrategy) -> StrategyRequest {
        StrategyRequest {
            strategy: p.strategy,
            equivalence: p.equivalence,
            soc_tolerance: p.soc_tolerance,
            soc_grid: p.soc_grid,
            split_grid: p.split_grid,
            soc_window: p.soc_window,
            rb_engine_power: p.rb_engine_power,
            rb_soc_low: p.rb_soc_low,
            rb_charge_power: p.rb_charge_power,
        }
    }
}
