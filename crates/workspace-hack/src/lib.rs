//! No code: this crate only fixes the features of shared third-party crates (see its Cargo.toml), so that every
//! cargo command in the workspace compiles each crate once and reuses it.
