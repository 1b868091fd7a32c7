//! The CLI's failures and their exit status (contract §3): 2 for a user error (bad model or cycle file, bad
//! option, a model the method cannot invert, a simulation that had to stop, an output file that cannot be
//! written or stdout closed), 1 only for an internal failure (a built-in table missing, a serialiser failing);
//! the message is one paragraph on stderr.
//!
//! A stderr that cannot be written (`2>/dev/full`, a closed pipe) loses the message, never the exit status:
//! every line for stderr goes through [`stderr_line`], which ignores a write error (a warning or note that
//! cannot be printed does not fail a run that succeeded; a failure keeps its status).

use std::io::Write;

/// A user-facing failure: the message and the exit status.
pub struct Failure {
    pub message: String,
    pub code: u8,
}

impl Failure {
    /// A user error (exit 2). The message's control characters (from a file name, a model's text) are escaped
    /// (`\u{1b}`): it goes to a terminal as one paragraph.
    pub fn user(message: impl Into<String>) -> Failure {
        Failure {
            message: escaped(message.into()),
            code: 2,
        }
    }
    /// An internal failure, not caused by the user's input (exit 1).
    pub fn io(message: impl Into<String>) -> Failure {
        Failure {
            message: escaped(message.into()),
            code: 1,
        }
    }

    /// Print the message as `invsim: error: …` on stderr; the exit status.
    pub fn report(self) -> u8 {
        stderr_line(&format!("invsim: error: {}", self.message));
        self.code
    }
}

/// Write `line` and a newline on stderr; a write error is ignored (see the module docs).
pub fn stderr_line(line: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

/// `invsim: warning: …` on stderr, its control characters escaped.
pub fn warn(text: &str) {
    stderr_line(&format!("invsim: warning: {}", escaped(text.to_string())));
}

/// What to do with warnings: print them (`invsim: warning: …`), or with `--strict` (a global option) fail with
/// them, exit 2, before any output is written.
#[derive(Clone, Copy, Debug, Default)]
pub struct Warnings {
    pub strict: bool,
}

impl Warnings {
    /// Warnings no output carries (a cycle file's, an import's): printed on stderr, or with `--strict` the
    /// failure.
    pub fn emit(self, warnings: &[String]) -> Result<(), Failure> {
        self.check(warnings)?;
        for w in warnings {
            warn(w);
        }
        Ok(())
    }

    /// Warnings the output carries (a summary's, a derivation's): with `--strict` the failure, else nothing.
    pub fn check(self, warnings: &[String]) -> Result<(), Failure> {
        match warnings {
            [] => Ok(()),
            _ if !self.strict => Ok(()),
            [one] => Err(Failure::user(format!(
                "{one} (a warning, an error with --strict)"
            ))),
            many => Err(Failure::user(format!(
                "{} warnings, errors with --strict: {}",
                many.len(),
                many.join("; ")
            ))),
        }
    }
}

/// `message` with its control characters escaped ([`invsim_runtime::textfmt::escape_controls`]).
fn escaped(message: String) -> String {
    match invsim_runtime::textfmt::escape_controls(&message, false) {
        std::borrow::Cow::Borrowed(_) => message,
        std::borrow::Cow::Owned(s) => s,
    }
}
