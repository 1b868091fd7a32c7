//! invsim's nonlinear-inversion core: model files, Lie derivatives, relative degree, the normal form
//! (ξ, η, ψ⁻¹, α, β), zero dynamics, and an interpreter that evaluates them from instruction tapes.
//!
//! ```no_run
//! use invsim_inversion::{Derivation, Model};
//! let model = Model::from_path("models/si_engine.toml".as_ref())?;
//! let d = Derivation::new(model)?;
//! assert_eq!(d.relative_degree, 2);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod classify;
pub mod decided;
pub mod derive;
pub mod interpreter;
pub mod model;
pub mod render;

pub use classify::{Classification, ZeroDynamicsClass};
pub use decided::check_decided;
pub use derive::{isolate, lie_derivative, Derivation, DeriveError, Extent, Solution};
pub use interpreter::{model_info, InterpretError, Interpreter};
pub use model::*;

/// Any error from loading a model file or deriving its inverse.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Model(#[from] model::ModelError),
    #[error(transparent)]
    Derive(#[from] DeriveError),
    #[error(transparent)]
    Interpret(#[from] InterpretError),
}

/// Load a model file and derive its inverse.
pub fn derive_file(path: &std::path::Path) -> Result<Derivation, Error> {
    let model = Model::from_path(path)?;
    Ok(Derivation::new(model)?)
}
