//! Why a run's parameter gradient cannot be computed.

use thiserror::Error;

/// Why a run's gradient cannot be computed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum GradientError {
    #[error("unknown parameter `{name}` (the model declares: {known})")]
    UnknownParameter { name: String, known: String },
    #[error("parameter `{name}` is named twice")]
    Duplicate { name: String },
    #[error(
        "`{name}` is set per gear by the model's [gearbox]: differentiate by each gear's value, \
         {name}[1] … {name}[{gears}]"
    )]
    PerGear { name: String, gears: usize },
    #[error("`{name}`: the gearbox has gears 1 … {gears}")]
    NoSuchGear { name: String, gears: usize },
    #[error("{what} are not differentiated yet")]
    ModalUnsupported { what: &'static str },
    #[error("`{name}` is not a grid value of its map: name one as {expected}")]
    BadGridValue { name: String, expected: String },
    #[error(
        "more than {max} grid values asked for: name fewer (`MAP[i,j]`) than every value of the maps"
    )]
    TooManyGridValues { max: usize },
}
