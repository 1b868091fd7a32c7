//! Writing the CLI's output: files with errors that name them, and stdout.

use std::io::Write;
use std::path::Path;

use crate::error::Failure;

/// Create `path` and fill it with `write`, reporting either failure with the path.
pub fn write_file(
    path: &Path,
    write: impl FnOnce(std::fs::File) -> std::io::Result<()>,
) -> Result<(), Failure> {
    let file = std::fs::File::create(path)
        .map_err(|e| Failure::io(format!("cannot create {}: {e}", path.display())))?;
    write(file).map_err(|e| Failure::io(format!("cannot write {}: {e}", path.display())))
}

pub fn print_stdout(text: &str) -> Result<(), Failure> {
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(|e| Failure::io(format!("cannot write to stdout: {e}")))
}
