//! Emits the kernel's tables (the 128 pieces of `K₁`, `R₁`, `h/C₀` and the derivative polynomials, see
//! `src/construction.rs`) as constants into `OUT_DIR/kernel_tables.rs`, so that no program builds
//! them (with its 131 072 cosines) at start-up.

#[allow(dead_code)]
#[path = "src/construction.rs"]
mod construction;

use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=src/construction.rs");
    let Some(out) = std::env::var_os("OUT_DIR").map(PathBuf::from) else {
        eprintln!("invsim-kernel: error: OUT_DIR is not set");
        return ExitCode::FAILURE;
    };
    match std::fs::write(out.join("kernel_tables.rs"), construction::tables_source()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("invsim-kernel: error: cannot write the kernel tables: {e}");
            ExitCode::FAILURE
        }
    }
}
