//! `cargo xtask`: the workspace's developer tasks (see the library's documentation).

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use xtask::{docs, figures, gen, golden, test, vehicles, workspace_root, Failure};

#[derive(Parser, Debug)]
#[command(name = "xtask", about = "invsim developer tasks", long_about = None)]
struct Cli {
    #[command(subcommand)]
    task: Task,
}

#[derive(Subcommand, Debug)]
enum Task {
    /// Write the Rust source (<name>.rs) and Markdown derivation (<name>.md) of one model file.
    Gen {
        /// The model file (TOML).
        model: PathBuf,
        /// Output directory [default: target/invsim-gen/ under the workspace root].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Regenerate docs/models/<name>.md for every models/*.toml, and docs/README.md.
    Docs {
        /// Write nothing; fail listing the stale files.
        #[arg(long)]
        check: bool,
    },
    /// Check the golden generated source crates/codegen/tests/golden/si_engine.rs.
    Golden {
        /// Overwrite the golden file with the current output.
        #[arg(long)]
        bless: bool,
    },
    /// Regenerate the SVG figures in docs/figures/ (the paper's figures reproduced, and others).
    Figures {
        /// Render into a scratch directory and check that every figure renders; write nothing to docs/.
        #[arg(long)]
        check: bool,
    },
    /// Export the FASTSim vehicles of the library from the installed `fastsim` package into models/vehicles/
    /// (NAME.yaml) and import them (NAME.toml).
    Vehicles {
        /// Export nothing (no Python needed): re-import the stored vehicle files and fail listing stale models.
        #[arg(long)]
        check: bool,
    },
    /// Run every test: one build of every test target, then `cargo test --workspace` beside the Python
    /// package's tests (`.ci/python`: a fresh venv, the extension as a wheel, pytest); see `xtask::test`.
    Test {
        /// Only the Rust tests.
        #[arg(long)]
        no_python: bool,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let root = workspace_root();
    // `gen` reports a bad model exactly as `invsim derive` does.
    let prefix = if matches!(cli.task, Task::Gen { .. }) {
        "invsim"
    } else {
        "xtask"
    };
    let result: Result<(), Failure> = match cli.task {
        Task::Gen { model, out } => gen::run(&root, &model, out.as_deref()).map(|w| {
            println!("wrote {}\nwrote {}", w.rust.display(), w.markdown.display());
        }),
        Task::Docs { check } => docs::run(&root, check).map(|written| {
            if check || written.is_empty() {
                println!("docs are up to date");
            } else {
                for w in written {
                    println!("updated {}", w.display());
                }
            }
        }),
        Task::Golden { bless } => golden::run(&root, bless).map(|path| {
            if bless {
                println!("blessed {}", path.display());
            } else {
                println!("{} is up to date", path.display());
            }
        }),
        Task::Vehicles { check } => vehicles::run(&root, check).map(|written| {
            if written.is_empty() {
                println!("vehicles are up to date");
            }
            for w in written {
                println!("updated {}", w.display());
            }
        }),
        Task::Test { no_python } => test::run(&root, no_python),
        Task::Figures { check } => figures::run(&root, check).map(|written| {
            let verb = if check { "rendered" } else { "wrote" };
            for w in written {
                println!("{verb} {}", w.display());
            }
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("{prefix}: error: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}
