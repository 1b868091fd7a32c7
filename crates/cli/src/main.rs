//! The `invsim` command line: `derive` prints a model's inversion, `simulate` runs it along a drive cycle,
//! `forward` runs the original model along the cycle with a PI driver.
//!
//! Exit status (contract §3): 0 on success, 2 on a user error (bad model or cycle file, bad option, a model
//! the method cannot invert, a simulation that had to stop), with a one-paragraph message on stderr
//! ([`error`]). This file only parses the command line and dispatches; each command has its module.

mod derive;
mod engine;
mod error;
mod files;
mod forward;
mod simulate;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(name = "invsim", version, about = "Inverse dynamic simulation of vehicle powertrains", long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Derive the relative degree, normal form, ψ⁻¹, α, β and zero dynamics of a model file.
    Derive {
        /// The model file (TOML).
        model: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value_t = derive::Format::Text)]
        format: derive::Format,
    },
    /// Run the inverse simulation of a model along a drive cycle.
    Simulate(simulate::SimulateArgs),
    /// Run the forward simulation of a model along a drive cycle, closed by a PI driver on the raw cycle.
    Forward(forward::ForwardArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Derive { model, format } => derive::run(&model, format),
        Command::Simulate(args) => simulate::run(&args),
        Command::Forward(args) => forward::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => f.report(),
    }
}
