//! The keys of the model file, one list per table: the reader accepts exactly these (every table's unknown
//! keys are refused against its list here), and `docs/reference.md` names every one (a test in
//! `tests/tests/reference_complete.rs` fails for a key it does not mention).

/// Top-level keys and sections of a single-mode model.
pub const TOP_SINGLE: &[&str] = &[
    "name",
    "description",
    "parameters",
    "definitions",
    "states",
    "input",
    "output",
    "outputs",
    "engine",
    "headline",
    "signals",
    "maps",
];
/// Top-level sections that only a model with modes has (it then has `[inputs]` instead of `[input]`).
pub const TOP_MODAL: &[&str] = &["inputs", "modes", "gearbox", "sequence", "hybrid"];
/// A `[parameters]` entry written as a table.
pub const PARAMETER: &[&str] = &["value", "unit", "doc"];
/// A `[definitions]` entry written as a table.
pub const DEFINITION: &[&str] = &["expr", "unit", "doc"];
/// A `[states]` entry.
pub const STATE: &[&str] = &["rhs", "f", "g", "unit", "doc", "initial"];
/// `[input]`.
pub const INPUT: &[&str] = &["name", "unit", "doc", "min", "max"];
/// `[output]` (and a mode's `output` override).
pub const OUTPUT: &[&str] = &[
    "name",
    "h",
    "unit",
    "doc",
    "nominal",
    "reference_offset",
    "reference_scale",
];
/// An `[outputs]` entry written as a table.
pub const EXTRA_OUTPUT: &[&str] = &["expr", "unit", "doc", "accumulate", "per_distance"];
/// `[engine]`.
pub const ENGINE: &[&str] = &["speed", "torque", "map", "map_unit", "map_range"];
/// `[headline]`.
pub const HEADLINE: &[&str] = &["output", "fuel", "density", "carbon_fraction"];
/// A `[maps.NAME]` table.
pub const MAP: &[&str] = &[
    "args",
    "x",
    "y",
    "values",
    "file",
    "smooth",
    "extrapolate",
    "interp",
    "unit",
    "doc",
];
/// A `[signals]` entry written as a table.
pub const SIGNAL: &[&str] = &["default", "column", "unit", "doc"];
/// An `[inputs.NAME]` table.
pub const MODAL_INPUT: &[&str] = &["unit", "doc", "min", "max"];
/// A `[modes.NAME]` table.
pub const MODE: &[&str] = &[
    "free",
    "inputs",
    "role",
    "geared",
    "parameters",
    "definitions",
    "output",
    "couple",
    "decided",
    "doc",
];
/// `[gearbox]`.
pub const GEARBOX: &[&str] = &[
    "parameters",
    "schedule",
    "upshift",
    "downshift",
    "column",
    "doc",
];
/// `[sequence]`.
pub const SEQUENCE: &[&str] = &[
    "standstill_below",
    "standstill_above",
    "brake_band",
    "min_dwell",
];

/// `[hybrid]`: what an energy-management strategy (`--strategy ecms`) weighs.
pub const HYBRID: &[&str] = &[
    "fuel_power",
    "battery_power",
    "soc",
    "engine_on",
    "start_penalty",
    "grid",
    "rule_request",
    "rule_target",
    "rule_min_on",
];

/// Every table of the model file with its keys: (the table as the reference writes it, its keys).
pub const TABLES: &[(&str, &[&str])] = &[
    ("top level", TOP_SINGLE),
    ("top level (modes)", TOP_MODAL),
    ("[parameters] entry", PARAMETER),
    ("[definitions] entry", DEFINITION),
    ("[states] entry", STATE),
    ("[input]", INPUT),
    ("[output]", OUTPUT),
    ("[outputs] entry", EXTRA_OUTPUT),
    ("[engine]", ENGINE),
    ("[headline]", HEADLINE),
    ("[maps.NAME]", MAP),
    ("[signals] entry", SIGNAL),
    ("[inputs.NAME]", MODAL_INPUT),
    ("[modes.NAME]", MODE),
    ("[gearbox]", GEARBOX),
    ("[sequence]", SEQUENCE),
    ("[hybrid]", HYBRID),
];
