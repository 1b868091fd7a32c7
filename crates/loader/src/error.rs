//! Why a model could not be loaded or set up.

use thiserror::Error;

/// Why a model could not be loaded or set up. The messages name the file (and for a model-file error its
/// line and column); the front end adds how to ask for another engine.
#[derive(Debug, Error)]
pub enum LoadError {
    /// The model file does not read, check or derive (the reader's message: file, line, column).
    #[error(transparent)]
    Model(Box<invsim_inversion::Error>),
    /// A mode of a model with modes does not derive.
    #[error("mode `{mode}`: {source}")]
    Mode {
        mode: String,
        source: Box<invsim_inversion::Error>,
    },
    /// The loaded model cannot be assembled or copied (a built-in model missing from this build).
    #[error("{0}")]
    Setup(String),
    /// Compiled code was asked for, and the file is none of the built-in models.
    #[error(
        "no compiled code for `{file}`: the file (sha256 {hash}) matches none of the built-in models{} this \
         program was built with ({}; a built-in model must be byte-for-byte the file in models/)",
        if *.modal { " with modes" } else { "" },
        .known.join(", ")
    )]
    NotBuiltIn {
        file: String,
        hash: String,
        modal: bool,
        known: Vec<String>,
    },
    /// A parameter could not be set.
    #[error("{name}: {reason}")]
    Parameter { name: String, reason: String },
    /// An engine name that is none of `auto`, `compiled`, `interpreted`.
    #[error("engine `{0}`: expected \"auto\", \"compiled\" or \"interpreted\"")]
    Engine(String),
}

impl<E: Into<invsim_inversion::Error>> From<E> for LoadError {
    fn from(e: E) -> LoadError {
        LoadError::Model(Box::new(e.into()))
    }
}
