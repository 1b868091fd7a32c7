//! The model-file error: where a problem is (file, 1-based line and column in characters) and what kind it
//! is; displays as `FILE:LINE:COLUMN: MESSAGE` (contract section 2).

use std::path::PathBuf;

/// A model-file error: where it is and what was expected.
///
/// Displays as `FILE:LINE:COLUMN: MESSAGE`, or `FILE: MESSAGE` when the error has no single position
/// (an unreadable file, a missing section).
#[derive(Debug, Clone, thiserror::Error)]
#[error("{}", self.render())]
pub struct ModelError {
    pub file: PathBuf,
    /// 1-based.
    pub line: Option<usize>,
    /// 1-based, counted in characters.
    pub column: Option<usize>,
    pub message: String,
    pub kind: ModelErrorKind,
}

impl ModelError {
    fn render(&self) -> String {
        let text = match (self.line, self.column) {
            (Some(l), Some(c)) => format!("{}:{l}:{c}: {}", self.file.display(), self.message),
            (Some(l), None) => format!("{}:{l}: {}", self.file.display(), self.message),
            _ => format!("{}: {}", self.file.display(), self.message),
        };
        escape_controls(&text)
    }
}

/// `text` with every control character but the newline escaped (`\u{0}` for NUL), so that a message never
/// echoes raw bytes from a file into a terminal or a log.
fn escape_controls(text: &str) -> String {
    if !text.chars().any(|c| c.is_control() && c != '\n') {
        return text.to_string();
    }
    text.chars()
        .map(|c| {
            if c.is_control() && c != '\n' {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// What kind of problem a [`ModelError`] reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ModelErrorKind {
    /// The file cannot be read, or is not UTF-8.
    Io,
    /// TOML syntax error.
    Toml,
    /// Wrong structure: unknown or missing keys and sections, wrong value types, empty `[states]`, input
    /// bounds out of order.
    Schema,
    /// An expression does not parse (including empty and overlong expressions).
    Expression,
    /// A declared name is not an identifier.
    InvalidName,
    /// An expression uses a name that is not declared.
    UnknownName,
    /// A declared name is reserved (`t`, `pi`, `yr`, `xi<N>`, `eta<N>`, function names).
    ReservedName,
    /// A name is declared twice.
    DuplicateName,
    /// Definitions refer to each other in a cycle.
    CircularDefinition,
    /// A definition uses a definition that comes later in the file.
    DefinitionOrder,
    /// A parameter, bound or number literal is NaN or infinite.
    NonFinite,
    /// `abs`, `sign`, `min` or `max` where it would enter f, g or h.
    NonSmooth,
    /// A state's `rhs` is not affine in the input.
    NotAffine,
    /// The output's `h` depends on the input.
    OutputDependsOnInput,
    /// A state's given `f` or `g` depends on the input.
    StateFunctionDependsOnInput,
}
