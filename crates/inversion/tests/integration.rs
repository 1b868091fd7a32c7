//! The integration tests of this crate in one test binary (one link instead of one per file):
//! - `acceptance`: The acceptance models of `shared/models/` give the results their README states. The directory is reference
//! - `boundary_equilibria`: Zero dynamics whose equilibrium lies on the boundary of a power's domain (η = 0 in η^1.5, where
//! - `budgets`: Size budgets on model files: chains of definitions too deep once inlined are a located model error
//! - `classify`: Classification of the zero dynamics at the nominal point (`Derivation::classify`) and its fields in the JSON,
//! - `coordinates_scale`: The choice of η scales polynomially with the number of states (greedy rank test, at most n + 1 rank tests)
//! - `derive_messages`: Nonsense that used to derive silently is refused with a located, typed error: constant subexpressions that
//! - `eta_free`: Which results of the inverse are free of the internal states η (`Derivation::eta_free`, the
//! - `fuzz_regressions`: Replays the fuzz regressions of the model reader, the expression parser and the derive pipeline
//! - `maps`: Models with lookup maps: CSV and inline maps alike, Lie derivatives against finite differences, a map in h
//!   solved by Newton, the JSON `maps` object, the interpreter.
//! - `model_file`: Model-file reader: every malformed file in `tests/malformed/` fails where its header says, the shared
//! - `properties`: Property tests of the derivation against independent numerical references: L_f h computed symbolically
//! - `read_limits`: Model files are read through a size cap ([`MAX_MODEL_FILE_BYTES`]): devices, endless streams and huge
//! - `textbook`: Known-answer tests of relative degree and normal form from the textbooks (Khalil, *Nonlinear Systems*,
//! - `zd_affine`: Whether the zero dynamics are affine in η (`Derivation::zero_dynamics_affine`, the

mod acceptance;
mod boundary_equilibria;
mod budgets;
mod classify;
mod coordinates_scale;
mod derive_messages;
mod eta_free;
mod fuzz_regressions;
mod maps;
mod model_file;
mod properties;
mod read_limits;
mod textbook;
mod zd_affine;
