//! The list of built-in drive cycles with their descriptions, and the second-by-second regulation tables
//! (UDDS, HWFET, US06, WLTC class 3b and its phases) turned into time and speed in SI units. The tables
//! themselves are in the files `builtin/udds.rs`, `builtin/hwfet.rs`, `builtin/us06.rs` and `builtin/wltc3b.rs`.

mod hwfet;
mod udds;
mod us06;
mod wltc3b;

pub(super) const BUILTIN_NAMES: &[&str] = &[
    "nedc",
    "ece",
    "eudc",
    "udds",
    "hwfet",
    "us06",
    "wltc3b",
    "wltc3b-low",
    "wltc3b-medium",
    "wltc3b-high",
    "wltc3b-extra-high",
];

/// A built-in cycle: its name (as accepted by `Cycle::builtin`) and what it is, with its source.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BuiltinCycle {
    pub name: &'static str,
    pub description: &'static str,
}

/// Every built-in cycle, in the order of [`BUILTIN_NAMES`].
pub(super) const BUILTINS: &[BuiltinCycle] = &[
    BuiltinCycle {
        name: "nedc",
        description: "New European Driving Cycle: 4 × ECE-15 + EUDC (UNECE R83, 70/220/EEC)",
    },
    BuiltinCycle {
        name: "ece",
        description: "ECE-15 urban cycle, one of the four in the NEDC (UNECE R83)",
    },
    BuiltinCycle {
        name: "eudc",
        description: "Extra-Urban Driving Cycle, the last part of the NEDC (UNECE R83)",
    },
    BuiltinCycle {
        name: "udds",
        description: "EPA Urban Dynamometer Driving Schedule, FTP-72 (40 CFR 86 App. I)",
    },
    BuiltinCycle {
        name: "hwfet",
        description: "EPA Highway Fuel Economy Test (40 CFR 600 App. I)",
    },
    BuiltinCycle {
        name: "us06",
        description: "EPA US06 Supplemental FTP, aggressive driving (40 CFR 86 App. I)",
    },
    BuiltinCycle {
        name: "wltc3b",
        description: "WLTC class 3b, all four phases (UN GTR 15 Annex 1)",
    },
    BuiltinCycle {
        name: "wltc3b-low",
        description: "WLTC class 3b, phase Low, 0-589 s (UN GTR 15 Annex 1)",
    },
    BuiltinCycle {
        name: "wltc3b-medium",
        description: "WLTC class 3b, phase Medium, 589-1022 s (UN GTR 15 Annex 1)",
    },
    BuiltinCycle {
        name: "wltc3b-high",
        description: "WLTC class 3b, phase High, 1022-1477 s (UN GTR 15 Annex 1)",
    },
    BuiltinCycle {
        name: "wltc3b-extra-high",
        description: "WLTC class 3b, phase Extra High, 1477-1800 s (UN GTR 15 Annex 1)",
    },
];

/// Exact conversions of the tables' units to m/s: 1 mph = 1609.344 m / 3600 s, 1 km/h = 1/3.6 m/s.
const MPS_PER_MPH: f64 = 0.44704;
const MPS_PER_KMH: f64 = 1.0 / 3.6;

/// WLTC class 3b phases: (name, first second, last second) of UN GTR 15 Annex 1. Each phase keeps the
/// regulation's time, so it starts at its first second, not at t = 0, and shares its end point (a standstill)
/// with the next phase.
const WLTC3B_PHASES: [(&str, usize, usize); 4] = [
    ("wltc3b-low", 0, 589),
    ("wltc3b-medium", 589, 1022),
    ("wltc3b-high", 1022, 1477),
    ("wltc3b-extra-high", 1477, 1800),
];

/// A 1 Hz table cut to seconds `first..=last`: times t = `first` … `last` s and speeds (m/s) =
/// `table[t]` × `mps_per_unit`, linear in between (as the regulations interpolate their second-by-second tables).
fn from_1hz(table: &[u16], mps_per_unit: f64, first: usize, last: usize) -> (Vec<f64>, Vec<f64>) {
    let seconds = first..=last.min(table.len().saturating_sub(1));
    let time = seconds.clone().map(|t| t as f64).collect();
    let speed = table[seconds]
        .iter()
        .map(|&x| f64::from(x) * mps_per_unit)
        .collect();
    (time, speed)
}

/// Times (s) and speeds (m/s) of the second-by-second built-in `name` (lower case): UDDS, HWFET and US06 (tables in
/// 0.1 mph), WLTC class 3b and its phases (tables in 0.1 km/h; the tables hold tenths, hence the factor 0.1).
pub(super) fn tabulated(name: &str) -> Option<(Vec<f64>, Vec<f64>)> {
    let whole = |table: &[u16], unit: f64| Some(from_1hz(table, 0.1 * unit, 0, table.len() - 1));
    match name {
        "udds" => whole(&udds::MPH_X10, MPS_PER_MPH),
        "hwfet" => whole(&hwfet::MPH_X10, MPS_PER_MPH),
        "us06" => whole(&us06::MPH_X10, MPS_PER_MPH),
        "wltc3b" => whole(&wltc3b::KMH_X10, MPS_PER_KMH),
        _ => WLTC3B_PHASES
            .iter()
            .find(|(phase, _, _)| *phase == name)
            .map(|&(_, first, last)| from_1hz(&wltc3b::KMH_X10, 0.1 * MPS_PER_KMH, first, last)),
    }
}
