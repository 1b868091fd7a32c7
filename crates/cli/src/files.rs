//! Writing the CLI's text output on stdout (output files: [`crate::outputs`]).

use std::io::Write;

use crate::error::Failure;

pub fn print_stdout(text: &str) -> Result<(), Failure> {
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(|e| Failure::user(format!("cannot write to stdout: {e}")))
}
