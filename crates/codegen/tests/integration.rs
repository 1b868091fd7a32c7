//! The integration tests of this crate in one test binary (one link instead of one per file):
//! - `builder`: The build-script API: what `Builder::compile` writes, when it rewrites, and how it fails.
//! - `imports`: No import circle between the files of invsim-expr or invsim-codegen: a scan of the `crate::…` and

mod builder;
mod imports;
mod modal;
