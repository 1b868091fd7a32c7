//! Workspace-level acceptance tests (in `tests/`), and the compiled test models they use.
//!
//! The build script compiles `../shared/models/*.toml` (when that directory exists) into [`shared`] and this
//! crate's `models/*.toml` into [`extra`], each with a registry like `invsim-models`' (`builtin`, `by_hash`,
//! `MODELS`) plus `SKIPPED`, the model files that did not derive; the known-answer models of `models/known/`
//! with their exact solutions are in [`known`]; the workspace's habits as checks are in [`tidy`].
#![deny(clippy::all)]

pub mod known;
pub mod tidy;

// The compiled models are left out of this crate's own unit-test build (the tests of `known` and `tidy` do
// not use them), which would compile their generated code a second time; the tests in `tests/` link the
// library with them.

/// The compiled acceptance models of `../shared/models`.
#[cfg(all(has_shared, not(test)))]
pub mod shared {
    include!(concat!(env!("OUT_DIR"), "/shared/registry.rs"));
}

/// The compiled models of `tests/models`.
#[cfg(not(test))]
pub mod extra {
    include!(concat!(env!("OUT_DIR"), "/extra/registry.rs"));
}
