//! Rust code generation for derived invsim models.
//!
//! A model file's derivation ([`invsim_inversion::Derivation`]) becomes one Rust module that a person can read
//! and that runs as fast as hand-written code:
//!
//! * `Params` (one documented field per parameter, `Default` = the file's values, serde), constants for the
//!   names and sizes;
//! * `Precomputed`: a parameter set with every parameter-only subexpression computed once, and the model's
//!   functions per point — `h`, `psi`, `psi_inv` (closed form, or Newton's method on the analytic Jacobian with
//!   a convergence error), `alpha`, `beta`, `invert`, `zero_dynamics`, `rhs`, `outputs` — each documented with
//!   the equation it implements (plain and LaTeX); for a y^(r) not affine in the input, with a closed-form
//!   ψ⁻¹ `phi` (φ and ∂φ/∂u), `input_solution` where u was isolated, and `solve_input` (Newton's method
//!   from a given start, as the interpreter), with a numeric ψ⁻¹ the same in the states at Newton's x
//!   (`phi_x`, `input_solution_x`, `solve_input_x`);
//! * batch methods over columns of points, `invert_batch` (where ψ⁻¹ is in closed form) and `outputs_batch`:
//!   block by block, the fractional powers of a block at once by `invsim_model_api::math::pow_pos_slice`, the
//!   rest in loops that vectorise (see `model/batch.rs`);
//! * free functions taking `&Params`, and `Model`, which implements `invsim_model_api::InverseModel` (its batch
//!   methods through the generated ones).
//!
//! Expressions are lowered by the plan the interpreter's tape encodes ([`invsim_expr::lower`], with
//! [`invsim_expr::Strategy::GENERATED`]: sums and products as chains, negative coefficients as subtraction,
//! integer powers as products or `powi`, ½-powers as `sqrt`, one shared `powf` per base, parameter-only work
//! hoisted), with common subexpressions in `let` bindings. Output is parsed with `syn` and formatted with
//! `prettyplease`.
//!
//! ```no_run
//! let (rust, markdown) = invsim_codegen::generate_file("models/si_engine.toml".as_ref())?;
//! # let _ = (rust, markdown);
//! # Ok::<(), invsim_codegen::Error>(())
//! ```
//!
//! In a build script, use [`Builder`].

mod builder;
mod emit;
mod error;
mod format;
mod generate;
mod modal;
mod model;
mod names;

pub use builder::{registry, Builder, Generated};
pub use error::{CodegenError, Error};
pub use format::header;
pub use generate::{generate, generate_file};
pub use modal::{generate_modal, mode_module, DerivedMode, ModalDerivation};
pub use names::module_name;
