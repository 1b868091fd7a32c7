//! The columns a sweep with a strategy (`invsim sweep --strategy …`, docs/hybrids.md) adds to every row: each
//! named after its key in the run's summary `hybrid` block, whose number it is — the fuel, the fuel corrected
//! to ΔSOC = 0 by SAE J1711's line, ΔSOC, the final charge, the battery's energy, the engine's starts and time
//! on, the equivalence factor and the runs of its search. The time in each mode is the modal `time_MODE_s`.

use crate::modes::HybridBlock;

/// One field of a hybrid column.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Cell {
    /// A figure; `None` where the block has null (DP's equivalence factor, a correction through two runs that
    /// ended at the same ΔSOC).
    Float(Option<f64>),
    /// A whole count.
    Count(usize),
}

/// A hybrid column: its name (the `hybrid` block's key) and how a run's block gives its field.
pub struct HybridColumn {
    pub name: &'static str,
    pub cell: fn(&HybridBlock) -> Cell,
}

impl HybridColumn {
    /// Whether the column holds counts (INT64 in Parquet).
    pub fn is_count(&self) -> bool {
        matches!((self.cell)(&EMPTY), Cell::Count(_))
    }
}

/// A block to ask a column for its kind.
const EMPTY: HybridBlock = HybridBlock {
    strategy: String::new(),
    equivalence_factor: None,
    equivalence_source: String::new(),
    search_runs: 0,
    dp: None,
    soc_tolerance: 0.0,
    soc_start: 0.0,
    soc_end: 0.0,
    soc_end_replayed: None,
    delta_soc: 0.0,
    charge_sustaining: false,
    fuel_energy_j: 0.0,
    fuel_energy_corrected_j: None,
    correction_slope_j: None,
    battery_energy_j: 0.0,
    engine_starts: 0,
    engine_on_s: 0.0,
    start_penalty_j: 0.0,
    grid: 0,
    decided_inputs: Vec::new(),
};

/// The hybrid columns, in the rows' order (after the modes' columns).
pub const HYBRID_COLUMNS: [HybridColumn; 9] = [
    HybridColumn {
        name: "fuel_energy_j",
        cell: |b| Cell::Float(Some(b.fuel_energy_j)),
    },
    HybridColumn {
        name: "fuel_energy_corrected_j",
        cell: |b| Cell::Float(b.fuel_energy_corrected_j),
    },
    HybridColumn {
        name: "delta_soc",
        cell: |b| Cell::Float(Some(b.delta_soc)),
    },
    HybridColumn {
        name: "soc_end",
        cell: |b| Cell::Float(Some(b.soc_end)),
    },
    HybridColumn {
        name: "battery_energy_j",
        cell: |b| Cell::Float(Some(b.battery_energy_j)),
    },
    HybridColumn {
        name: "engine_starts",
        cell: |b| Cell::Count(b.engine_starts),
    },
    HybridColumn {
        name: "engine_on_s",
        cell: |b| Cell::Float(Some(b.engine_on_s)),
    },
    HybridColumn {
        name: "equivalence_factor",
        cell: |b| Cell::Float(b.equivalence_factor),
    },
    HybridColumn {
        name: "search_runs",
        cell: |b| Cell::Count(b.search_runs),
    },
];
