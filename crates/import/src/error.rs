//! The importer's failures: malformed YAML (with line and column), a powertrain invsim does not import, a
//! missing or mistyped field (named by its path in the vehicle file).

use thiserror::Error;

/// Why a vehicle file could not be imported.
#[derive(Debug, Error, PartialEq)]
pub enum ImportError {
    /// The file is not valid YAML; `line` and `column` are 1-based.
    #[error("{line}:{column}: malformed YAML: {message}")]
    Yaml {
        line: usize,
        column: usize,
        message: String,
    },
    /// A powertrain type the importer does not handle (hybrids, unknown types).
    #[error("powertrain type `{kind}` is not supported: {reason}")]
    Powertrain { kind: String, reason: String },
    /// A field is missing, has the wrong type or an invalid value.
    #[error("field `{path}`: {message}")]
    Field { path: String, message: String },
}

impl ImportError {
    /// A field error at `path`.
    pub fn field(path: &str, message: impl Into<String>) -> ImportError {
        ImportError::Field {
            path: path.to_string(),
            message: message.into(),
        }
    }
}
