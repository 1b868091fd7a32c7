//! The `invsim` command line: `derive` prints a model's inversion, `simulate` runs it along a drive cycle,
//! `sweep` runs many parameter variants of it, `forward` runs the original model along the cycle with a PI
//! driver, `compare` sets runs' summaries side by side, `cycles` lists the built-in drive cycles, `import` turns
//! a FASTSim vehicle file into a model file, `completions` prints a shell completion script.
//!
//! Exit status (contract §3): 0 on success, 2 on a user error (bad model or cycle file, bad option, a model
//! the method cannot invert, a simulation that had to stop), 3 when some variants of a sweep failed, with a
//! one-paragraph message on stderr ([`error`]). This file only parses the command line and dispatches; each
//! command has its module. On Linux with glibc the process starts without std's runtime wrapper (`no_main`;
//! `process.rs` says why and what it does instead): there glibc hands the arguments to std before `main`.
#![cfg_attr(all(target_os = "linux", target_env = "gnu", not(test)), no_main)]

mod compare_cmd;
mod compare_plot;
mod compare_table;
mod completions;
mod cycle_spec;
mod cycles_cmd;
mod data_args;
mod derive;
mod derive_format;
mod engine;
mod error;
mod files;
mod forward;
mod import_cmd;
mod initial_args;
mod inputs;
mod interrupt;
mod lookahead_arg;
mod map_args;
mod number_arg;
mod outputs;
mod plotting;
#[cfg(all(target_os = "linux", target_env = "gnu"))]
mod process;
mod progress;
mod provenance;
mod run_series;
mod run_summary;
mod signal_args;
mod simulate;
mod strategy_args;
mod sweep_cmd;
mod version;

use std::path::PathBuf;

use clap::{CommandFactory, Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(name = "invsim", version = version::VERSION, about = "Inverse dynamic simulation of vehicle powertrains", long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Make every warning an error (exit 2, no output written): a cycle file's plausibility warnings, a run's
    /// and a derivation's warnings, an import's.
    #[arg(long, global = true)]
    strict: bool,
}

/// Each command's arguments are built only when it is the one run (`defer`): building them all for every
/// process was a fifth of a `simulate --dt 1` run's instructions. Its about is the variant's doc comment here,
/// so an `Args` struct of a command carries none (clap would put it over this one).
#[derive(Subcommand, Debug)]
#[command(defer = true)]
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
    /// Run many variants of a model (a parameter grid or table) on one or more cycles, one CSV row each.
    Sweep(sweep_cmd::SweepArgs),
    /// Run the forward simulation of a model along a drive cycle, closed by a PI driver on the raw cycle.
    Forward(forward::ForwardArgs),
    /// Compare runs: the figures of two or more summary JSON files side by side with their differences to
    /// the first; `--plot` overlays their CSV series.
    Compare(compare_cmd::CompareArgs),
    /// List the built-in drive cycles with their duration, distance and top speed.
    Cycles(cycles_cmd::CyclesArgs),
    /// Import another tool's vehicle file as a model file (`invsim import fastsim VEHICLE.yaml`).
    #[command(subcommand)]
    Import(import_cmd::ImportFormat),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell) on stdout.
    Completions(completions::CompletionsArgs),
}

/// The entry point the C runtime calls (std's `lang_start` is not used, see `process.rs`); the arguments are
/// std's `env::args`, which glibc hands to std (its `.init_array` entry) before `main`.
#[cfg(all(target_os = "linux", target_env = "gnu", not(test)))]
#[no_mangle]
extern "C" fn main(
    _argc: std::ffi::c_int,
    _argv: *const *const std::ffi::c_char,
) -> std::ffi::c_int {
    process::start();
    process::finish(std::panic::catch_unwind(run))
}

/// Elsewhere std's runtime wrapper starts the process (and gives a panic the status 101 too).
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn main() -> std::process::ExitCode {
    std::process::ExitCode::from(run())
}

/// Parse the command line, run the command; the exit status.
#[cfg_attr(all(target_os = "linux", target_env = "gnu", test), allow(dead_code))] // the unit tests' harness has a main of its own
fn run() -> u8 {
    let cli = Cli::parse();
    let warnings = error::Warnings { strict: cli.strict };
    let result = match cli.command {
        Command::Derive { model, format } => derive::run(&model, format, warnings),
        Command::Simulate(args) => simulate::run(&args, warnings),
        Command::Sweep(args) => sweep_cmd::run(&args, warnings),
        Command::Forward(args) => forward::run(&args, warnings),
        Command::Compare(args) => compare_cmd::run(&args, warnings),
        Command::Cycles(args) => cycles_cmd::run(&args),
        Command::Import(format) => import_cmd::run(&format, warnings),
        Command::Completions(args) => completions::run(&args, Cli::command()),
    };
    match result {
        Ok(()) => 0,
        Err(f) => f.report(),
    }
}
