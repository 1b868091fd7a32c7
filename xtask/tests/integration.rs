//! The integration tests of this crate in one test binary (one link instead of one per file):
//! - `ensure_file_contents`: `ensure_file_contents`, through which every generated file goes: write mode writes only what changed,
//! - `figures`: `cargo xtask figures --check`: every figure group renders without error into a scratch directory, every SVG
//! - `xtask_gen_bad_model`: `cargo xtask gen` on a model that cannot be inverted exits with status 2 and prints exactly what

mod ensure_file_contents;
mod figures;
mod xtask_gen_bad_model;
