//! The integration tests of this crate in one test binary.
