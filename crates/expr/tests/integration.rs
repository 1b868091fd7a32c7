//! The integration tests of this crate in one test binary (one link instead of one per file):
//! - `budgets`: Depth and size of user-controlled structure: every walk over the DAG (differentiation, substitution,
//! - `engine`: Known-answer tests of the expression engine, written to be read as a tour of it: canonical forms,
//! - `maps`: Lookup maps as expression nodes: parse/print round trip, derivative maps by the chain rule, the zero
//!   test's surrogate, evaluation by the pool and the tape against the kernel's map.
//! - `properties`: Property tests of the expression engine on randomly generated expression sources: print/parse round

mod budgets;
mod engine;
mod maps;
mod properties;
