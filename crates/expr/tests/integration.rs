//! The integration tests of this crate in one test binary (one link instead of one per file):
//! - `budgets`: Depth and size of user-controlled structure: every walk over the DAG (differentiation, substitution,
//! - `engine`: Known-answer tests of the expression engine, written to be read as a tour of it: canonical forms,
//! - `properties`: Property tests of the expression engine on randomly generated expression sources: print/parse round

mod budgets;
mod engine;
mod properties;
