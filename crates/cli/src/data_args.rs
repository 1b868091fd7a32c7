//! The options that override a model's data, shared by `simulate` and `forward`: `--signal`, `--map` and
//! `--initial` (flattened into each command's arguments, so they keep their names in the provenance record).

use serde::Serialize;

#[derive(clap::Args, Debug, Serialize)]
pub struct DataArgs {
    /// Give a signal of the model's [signals]: NAME=FILE.csv (a time column and a column NAME) or NAME=VALUE
    /// (constant); repeatable. `simulate` and its replay (--verify) use the smoothed signal, `forward` the raw
    /// one (linear between its samples).
    #[arg(long = "signal", value_name = "NAME=FILE.csv|VALUE")]
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub signal: Vec<String>,
    /// Replace a lookup map's grid and values: NAME=FILE.csv (the model file's map CSV format); repeatable.
    #[arg(long = "map", value_name = "NAME=FILE.csv")]
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub map: Vec<String>,
    /// The start value of an internal state: NAME=VALUE (repeatable; over the model file's `initial`): a causal
    /// inverse run and `forward` start there instead of at the equilibrium of the zero dynamics.
    #[arg(
        long = "initial",
        value_name = "NAME=VALUE",
        allow_hyphen_values = true
    )]
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub initial: Vec<String>,
}
