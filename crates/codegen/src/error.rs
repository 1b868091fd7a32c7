//! The errors of code generation: a bug-level [`CodegenError`] and [`Error`] for everything a caller meets.

use std::path::PathBuf;

/// Code generation failed for a model that derived fine (a bug here or in the derivation).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CodegenError {
    #[error(
        "model `{model}`: `{function}` refers to `{symbol}`, which is neither a parameter nor one of its inputs \
         (a bug in the derivation)"
    )]
    Unbound {
        model: String,
        function: &'static str,
        symbol: String,
    },
    #[error("the generated code for {what} does not parse: {message} (a bug in invsim-codegen)")]
    Syntax { what: String, message: String },
}

/// Any failure of [`generate_file`] or [`Builder::compile`].
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The model file cannot be loaded or inverted; displays exactly as `invsim derive` reports it.
    #[error(transparent)]
    Model(#[from] invsim_inversion::Error),
    #[error(transparent)]
    Codegen(#[from] CodegenError),
    #[error("cannot write {}: {source}", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("no output directory: call Builder::out_dir, or run from a build script (which sets OUT_DIR)")]
    NoOutDir,
    #[error("{} and {} both generate the module `{module}`; rename one model", first.display(), second.display())]
    DuplicateModule {
        module: String,
        first: PathBuf,
        second: PathBuf,
    },
}
