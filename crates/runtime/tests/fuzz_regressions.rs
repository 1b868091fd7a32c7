//! Replays the fuzz regressions of the drive-cycle reader (`fuzz/regressions/cycle_reader/*`) through the very
//! function the cargo-fuzz target calls, on stable Rust: no input may panic, and each must be rejected with an
//! error unless its file name starts with `ok-` (an input the reader must accept) or `any-` (either outcome,
//! only no panic). Findings whose defect is still open wait in `fuzz/regressions/cycle_reader/pending/`, which
//! is not replayed.

#[path = "../../../fuzz/src/cycle_target.rs"]
mod cycle_target;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

#[test]
fn cycle_reader_regressions() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/regressions/cycle_reader");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| !n.to_string_lossy().starts_with('.'))
        })
        .collect();
    files.sort();
    let mut failures = Vec::new();
    for path in files {
        let data = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let (must_accept, either) = (name.starts_with("ok-"), name.starts_with("any-"));
        match catch_unwind(AssertUnwindSafe(|| cycle_target::cycle_reader(&data))) {
            Err(_) => failures.push(format!("{}: panicked", path.display())),
            Ok(Ok(())) if !must_accept && !either => {
                failures.push(format!("{}: accepted, expected an error", path.display()))
            }
            Ok(Err(e)) if must_accept => {
                failures.push(format!("{}: rejected: {e}", path.display()))
            }
            Ok(_) => {}
        }
    }
    assert!(
        failures.is_empty(),
        "fuzz regressions of cycle_reader:\n{}",
        failures.join("\n")
    );
}
