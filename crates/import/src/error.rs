//! The importer's failures: an unreadable or too large file, malformed or too deeply nested YAML (with line
//! and column), a powertrain invsim does not import, a missing or mistyped field or a value outside its
//! physical range (named by its path in the vehicle file, with the line and column where the file gives it).

use thiserror::Error;

/// Why a vehicle file could not be imported.
#[derive(Debug, Error, PartialEq)]
pub enum ImportError {
    /// The file cannot be read, is larger than the cap or is not UTF-8 text.
    #[error("{message}")]
    File { message: String },
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
    /// A field is missing, has the wrong type or an invalid value; `at` is the 1-based line and column of
    /// its value in the file, when the file has the field.
    #[error("field `{path}`: {message}")]
    Field {
        path: String,
        message: String,
        at: Option<(usize, usize)>,
    },
}

impl ImportError {
    /// A field error at `path` (its position is filled in by [`ImportError::located`]).
    pub fn field(path: &str, message: impl Into<String>) -> ImportError {
        ImportError::Field {
            path: path.to_string(),
            message: message.into(),
            at: None,
        }
    }

    /// The error with the position of its field in the YAML `text` filled in (when the text has it).
    pub fn located(self, text: &str) -> ImportError {
        match self {
            ImportError::Field {
                path,
                message,
                at: None,
            } => {
                let at = crate::locate::locate(text, &path);
                ImportError::Field { path, message, at }
            }
            other => other,
        }
    }

    /// The message as the command line prints it for the vehicle file `file`: `file:line:column: …` where
    /// the error has a position, else `file: …`.
    pub fn message_for(&self, file: &str) -> String {
        match self {
            ImportError::Yaml { .. } => format!("{file}:{self}"),
            ImportError::Field {
                at: Some((line, column)),
                ..
            } => format!("{file}:{line}:{column}: {self}"),
            _ => format!("{file}: {self}"),
        }
    }
}
