//! Replays the fuzz regressions of the model reader, the expression parser and the derive pipeline
//! (`fuzz/regressions/<target>/*`) through the very functions the cargo-fuzz targets call, on stable Rust: no
//! input may panic, and each must be rejected with an error unless its file name starts with `ok-` (an input
//! the library must accept) or `any-` (either outcome, only no panic). Findings whose defect is still open
//! wait in `fuzz/regressions/<target>/pending/`, which is not replayed; move a file up once its defect is
//! fixed.

#[path = "../../../fuzz/src/inversion_targets.rs"]
mod inversion_targets;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// The regression files of `target`, sorted (the `pending/` folder and dot-files excluded).
fn regressions(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/regressions")
        .join(target);
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
    files
}

/// Feed every regression file of `target` to `run`; collect what went wrong.
fn replay(target: &str, run: fn(&[u8]) -> Result<(), String>) {
    let mut failures = Vec::new();
    for path in regressions(target) {
        let data = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let name = path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let (must_accept, either) = (name.starts_with("ok-"), name.starts_with("any-"));
        match catch_unwind(AssertUnwindSafe(|| run(&data))) {
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
        "fuzz regressions of {target}:\n{}",
        failures.join("\n")
    );
}

#[test]
fn model_reader_regressions() {
    replay("model_reader", inversion_targets::model_reader);
}

#[test]
fn expr_parser_regressions() {
    replay("expr_parser", inversion_targets::expr_parser);
}

#[test]
fn derive_pipeline_regressions() {
    replay("derive_pipeline", inversion_targets::derive_pipeline);
}
