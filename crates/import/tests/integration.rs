//! The integration tests of this crate in one test binary:
//! - `library`: the vehicle library `models/vehicles/` is what the importer makes of its stored FASTSim files;
//! - `parameters`: every parameter of the imported Fusion and Leaf equals the vehicle file's field its doc names;
//! - `ranges`: a field outside its physical range is refused naming it, and a hostile vehicle name stays one
//!   TOML string;
//! - `refused`: plug-in hybrids, unknown powertrain types and malformed YAML are refused with a clear message.

mod common;
mod library;
mod parameters;
mod ranges;
mod refused;
