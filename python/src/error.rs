//! The extension's error: a message and, where invsim knows it, the model file, line and column; raised in
//! Python as `invsim.InvsimError` (a subclass of `ValueError`) with the attributes `file`, `line`, `column`.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pyo3::create_exception!(
    invsim,
    InvsimError,
    PyValueError,
    "An invsim user error (bad model or cycle file, bad option, a model that cannot be inverted, a run that \
     stopped). `file`, `line` and `column` (1-based) say where, when invsim knows it; otherwise they are None."
);

/// An error from loading, deriving or running a model, with its position when known. `Send`, so that it can
/// leave a closure that ran without the GIL.
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    pub message: String,
    pub file: Option<String>,
    pub line: Option<usize>,
    pub column: Option<usize>,
}

impl Failure {
    /// An error without a position.
    pub fn msg(message: impl Into<String>) -> Failure {
        Failure {
            message: message.into(),
            file: None,
            line: None,
            column: None,
        }
    }

    /// An error that names a file but no position in it.
    pub fn in_file(message: impl Into<String>, file: impl Into<String>) -> Failure {
        Failure {
            file: Some(file.into()),
            ..Failure::msg(message)
        }
    }

    /// The Python exception: `InvsimError(message)` with `file`, `line` and `column` set.
    pub fn into_pyerr(self, py: Python<'_>) -> PyErr {
        let err = InvsimError::new_err(self.message);
        let value = err.value(py);
        // Setting attributes on a fresh exception instance cannot fail short of memory exhaustion; if it
        // does, the exception is still raised with its message.
        let _ = value.setattr("file", self.file);
        let _ = value.setattr("line", self.line);
        let _ = value.setattr("column", self.column);
        err
    }
}

impl From<invsim_inversion::Error> for Failure {
    fn from(e: invsim_inversion::Error) -> Failure {
        let message = e.to_string();
        match e {
            invsim_inversion::Error::Model(m) => Failure {
                message,
                file: Some(m.file.display().to_string()),
                line: m.line,
                column: m.column,
            },
            invsim_inversion::Error::Derive(d) => Failure::in_file(message, derive_file(&d)),
            invsim_inversion::Error::Interpret(_) => Failure::msg(message),
        }
    }
}

impl From<invsim_inversion::ModelError> for Failure {
    fn from(e: invsim_inversion::ModelError) -> Failure {
        Failure::from(invsim_inversion::Error::Model(e))
    }
}

/// The model file a derivation error names.
fn derive_file(e: &invsim_inversion::DeriveError) -> String {
    match e {
        invsim_inversion::DeriveError::NoRelativeDegree { file, .. }
        | invsim_inversion::DeriveError::NoCoordinates { file, .. }
        | invsim_inversion::DeriveError::NotFinite { file, .. }
        | invsim_inversion::DeriveError::LieDerivativeTooLarge { file, .. } => file.clone(),
    }
}

/// `Result<T, Failure>` → `PyResult<T>`.
pub fn to_py<T>(py: Python<'_>, r: Result<T, Failure>) -> PyResult<T> {
    r.map_err(|f| f.into_pyerr(py))
}
