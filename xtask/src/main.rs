//! `cargo xtask`: the workspace's developer tasks (see the library's documentation).

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use xtask::{docs, figures, gen, golden, vehicles, workspace_root, Failure};

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
    /// Run every test: `cargo test --workspace`, then the Python package's (`.ci/python`: a fresh venv,
    /// `pip install ./python`, pytest).
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
        Task::Test { no_python } => run_tests(&root, no_python),
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

/// `cargo test --workspace` (less the benchmarks' crate), then the Python package's tests (`.ci/python run DIR`) unless `no_python`. The
/// venv and the test dependencies from PyPI (`.ci/python prepare DIR`, network-bound) are set up while the
/// Rust tests compile; that step's output goes to `DIR/prepare.log`, shown when it fails. The first failure
/// stops.
fn run_tests(root: &std::path::Path, no_python: bool) -> Result<(), Failure> {
    let dir = root.join("target").join("xtask-test-python");
    let mut prepare = if no_python {
        None
    } else {
        Some(spawn_prepare(root, &dir)?)
    };
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut rust = std::process::Command::new(&cargo);
    // crates/bench holds only benchmarks: excluded, its dev-dependencies (criterion) do not take part in the
    // feature resolution, which would switch on zerocopy's derive macro (criterion → ciborium → half) for
    // nothing that a test uses.
    rust.args(["test", "--workspace", "--exclude", "invsim-bench"]);
    if let Err(f) = run_step(root, rust, "cargo test --workspace --exclude invsim-bench") {
        if let Some(child) = prepare.as_mut() {
            // The Rust tests failed: the venv is not needed any more.
            let _ = child.kill();
            let _ = child.wait();
        }
        return Err(f);
    }
    let Some(mut child) = prepare else {
        return Ok(());
    };
    let status = child.wait().map_err(|e| Failure {
        message: format!("cannot wait for `bash .ci/python prepare`: {e}"),
        code: 1,
    })?;
    if !status.success() {
        let log = std::fs::read_to_string(dir.join("prepare.log")).unwrap_or_default();
        eprintln!("{log}");
        return Err(Failure {
            message: format!("`bash .ci/python prepare` failed ({status})"),
            code: 1,
        });
    }
    let mut python = std::process::Command::new("bash");
    python.arg(root.join(".ci/python")).arg("run").arg(&dir);
    run_step(root, python, "bash .ci/python run")
}

/// Starts `bash .ci/python prepare DIR` in the background, its output into `DIR/prepare.log`.
fn spawn_prepare(
    root: &std::path::Path,
    dir: &std::path::Path,
) -> Result<std::process::Child, Failure> {
    let fail = |what: &str, e: std::io::Error| Failure {
        message: format!("cannot {what} {}: {e}", dir.display()),
        code: 1,
    };
    std::fs::create_dir_all(dir).map_err(|e| fail("create", e))?;
    let log =
        std::fs::File::create(dir.join("prepare.log")).map_err(|e| fail("write a log in", e))?;
    let err = log.try_clone().map_err(|e| fail("write a log in", e))?;
    std::process::Command::new("bash")
        .arg(root.join(".ci/python"))
        .arg("prepare")
        .arg(dir)
        .current_dir(root)
        .stdout(log)
        .stderr(err)
        .spawn()
        .map_err(|e| fail("prepare a Python venv in", e))
}

/// Runs one step in `root`; an error unless it succeeds.
fn run_step(
    root: &std::path::Path,
    mut cmd: std::process::Command,
    what: &str,
) -> Result<(), Failure> {
    let status = cmd.current_dir(root).status().map_err(|e| Failure {
        message: format!("cannot run `{what}`: {e}"),
        code: 1,
    })?;
    if status.success() {
        Ok(())
    } else {
        Err(Failure {
            message: format!("`{what}` failed ({status})"),
            code: 1,
        })
    }
}
