//! The functions invsim's fuzz targets call, shared with the replay tests of `fuzz/regressions/` that run on
//! stable Rust (`crates/inversion/tests/fuzz_regressions.rs`, `crates/runtime/tests/fuzz_regressions.rs`
//! include these files by path).

pub mod cycle_target;
pub mod inversion_targets;
