//! Shared helpers: the vehicle library's directory and its stored FASTSim files.

use std::path::PathBuf;

/// `models/vehicles/` of the repository.
pub fn vehicles_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models/vehicles")
}

/// The stored vehicle files (`*.yaml`), sorted.
pub fn vehicle_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(vehicles_dir())
        .expect("models/vehicles exists")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "yaml"))
        .collect();
    files.sort();
    files
}
