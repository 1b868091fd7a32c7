//! The integration tests of this crate in one test binary (one link instead of one per file):
//! - `bev`: The battery-electric car against a hand integration of its equations on UDDS and HWFET, and its charge state
//! - `cycle_columns`: A signal read from any column of the cycle file, against the same samples given as a signal
//!   file; a bad cell in a used column names file, line and column
//! - `codegen_vs_interpreter`: Generated code, compiled, agrees with the interpreter tape: every `InverseModel` method of every loadable
//! - `docs_fresh`: The committed derived-equation documents (`docs/models/*.md`, `docs/README.md`) are what
//! - `elevation`: Road grade from elevation over distance: a constant slope, a sinusoidal profile along the
//!   smoothed reference's distance, fuel with the profile against the equivalent grade signal
//! - `fusion_dynamic`: `models/ford_fusion_2012_dynamic.toml` on NEDC and UDDS: the inverse satisfies the original equations, the replay tracks, the imported parameters are kept
//! - `gradient`: Exact parameter gradients against central finite differences on NEDC and UDDS, compiled against
//!   interpreted, a linear model's closed form, and the runs not differentiated refused
//! - `gradient_maps`: Gradients with respect to a map's grid values against central differences of the map's
//!   values (si_engine_maps on NEDC, a map in causal and in stably inverted zero dynamics), compiled against
//!   interpreted, a fuel map's closed form
//! - `golden`: The generated source for `models/si_engine.toml` equals the reviewed copy in
//! - `inverse_consistency`: The inverse simulation satisfies the original model: along NEDC, at every sample, the state and input that
//! - `known_answers`: One harness, every engine, every known-answer model: each model of `tests/models/known/` (listed with its
//! - `non_affine`: Models not affine in the input, solved by isolation and by Newton's method, against their original equations
//! - `reference_complete`: `docs/reference.md` mentions every model-file key, command and option
//! - `signals`: Exogenous signals against independent references: total derivatives against finite differences, the
//!   smoothed signal against quadrature, si_engine_grade against its original equations, constant signal vs parameter, fuel vs grade
//! - `workspace_hack`: Every smaller build resolves the third-party features of the whole workspace
//!   (crates/workspace-hack), so that none compiles the workspace twice
//! - `tidy`: The workspace's habits as tests (rust-analyzer's `tidy`): every source file opens with `//!`, no function

mod bev;
mod codegen_vs_interpreter;
mod cycle_columns;
mod docs_fresh;
mod elevation;
mod fusion_dynamic;
mod golden;
mod gradient;
mod gradient_maps;
mod inverse_consistency;
mod known_answers;
mod non_affine;
mod reference_complete;
mod signals;
mod tidy;
mod workspace_hack;
