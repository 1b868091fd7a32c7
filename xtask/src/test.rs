//! `cargo xtask test`: every test of the workspace in one build, then the Rust tests and the Python package's
//! side by side.
//!
//! On a two-core machine from a fresh clone the time is the compiling; the order below keeps both cores busy:
//!
//! 1. `.ci/python prepare DIR` (a fresh venv with the test dependencies from PyPI, network-bound) starts in
//!    the background, its output in `DIR/prepare.log`;
//! 2. one `cargo build` compiles every library (the Python extension's too), binary and test target, so that
//!    the pyo3 crates compile beside the rest instead of after the tests;
//! 3. the Rust tests run in two lanes side by side (nothing left to compile): the command line's tests
//!    (`cargo test -p invsim`, the longest test binary, its output in `target/xtask-test-cli.log`) and the
//!    rest (`cargo test --workspace --exclude invsim`, in the foreground); one test binary alone leaves a core
//!    idle whenever its last long test runs alone. Beside them, once the venv is ready, `.ci/python run DIR`
//!    packs the already built extension and runs pytest, its output in `DIR/run.log`. The logs print after
//!    the foreground lane, the command line's first.
//!
//! crates/bench holds only benchmarks and is left out: its dev-dependencies (criterion) would otherwise take
//! part in the feature resolution and switch on zerocopy's derive macro (criterion → ciborium → half) for
//! nothing that a test uses.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus};

use crate::Failure;

/// The packages `cargo xtask test` leaves out, as `cargo` arguments.
const EXCLUDED: [&str; 2] = ["--exclude", "invsim-bench"];

/// The command line's package, whose tests run in a lane of their own.
const CLI: &str = "invsim";

/// Runs the tests as the module documentation says; `no_python`: the Rust tests alone. The first failure is
/// the error (the Python tests still finish and print their log when the Rust tests fail).
pub fn run(root: &Path, no_python: bool) -> Result<(), Failure> {
    let dir = root.join("target").join("xtask-test-python");
    let mut prepare = if no_python {
        None
    } else {
        Some(spawn_prepare(root, &dir)?)
    };
    if let Err(f) = build(root, no_python) {
        if let Some(child) = prepare.as_mut() {
            // Nothing to test: the venv is not needed any more.
            let _ = child.kill();
            let _ = child.wait();
        }
        return Err(f);
    }
    let python = prepare.map(|child| {
        let (root, dir) = (root.to_path_buf(), dir.clone());
        std::thread::spawn(move || python(&root, &dir, child))
    });
    let rust = rust_tests(root);
    let python = match python.map(std::thread::JoinHandle::join) {
        None => Ok(()),
        Some(Ok((log, outcome))) => {
            println!("{}", std::fs::read_to_string(log).unwrap_or_default());
            outcome
        }
        Some(Err(_)) => Err(Failure {
            message: "the Python tests' thread panicked".to_string(),
            code: 1,
        }),
    };
    rust.and(python)
}

/// The Rust tests in two lanes: the command line's (`cargo test -p invsim`, into `target/xtask-test-cli.log`,
/// printed afterwards) beside the rest (`cargo test --workspace --exclude invsim`, in the foreground).
fn rust_tests(root: &Path) -> Result<(), Failure> {
    let log = root.join("target").join("xtask-test-cli.log");
    let cli = spawn_logged(root, &log, cargo(&["test", "-p", CLI]));
    let rest = run_step(
        root,
        cargo(&["test", "--workspace", "--exclude", CLI]),
        "cargo test --workspace --exclude invsim-bench --exclude invsim",
    );
    let cli = match cli.and_then(|mut child| child.wait()) {
        Ok(status) if status.success() => Ok(()),
        Ok(status) => Err(step_failed("cargo test -p invsim", status)),
        Err(e) => Err(cannot("run `cargo test -p invsim`", &e)),
    };
    println!("{}", std::fs::read_to_string(&log).unwrap_or_default());
    rest.and(cli)
}

/// `cargo build` of every library, binary and test target (less `invsim-python` with `no_python`).
fn build(root: &Path, no_python: bool) -> Result<(), Failure> {
    let mut cmd = cargo(&["build", "--workspace", "--lib", "--bins", "--tests"]);
    if no_python {
        cmd.args(["--exclude", "invsim-python"]);
    }
    run_step(
        root,
        cmd,
        "cargo build --workspace --lib --bins --tests --exclude invsim-bench",
    )
}

/// `cargo ARGS` (and `--exclude invsim-bench` unless ARGS pick one package with `-p`), with the cargo that
/// runs xtask.
fn cargo(args: &[&str]) -> Command {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.args(args);
    if !args.contains(&"-p") {
        cmd.args(EXCLUDED);
    }
    cmd
}

/// Starts `cmd` in `root`, its output (both streams) into `log`.
fn spawn_logged(root: &Path, log: &Path, mut cmd: Command) -> std::io::Result<Child> {
    let out = std::fs::File::create(log)?;
    let err = out.try_clone()?;
    cmd.current_dir(root).stdout(out).stderr(err).spawn()
}

/// The Python step: wait for the venv, then `.ci/python run DIR` into `DIR/run.log`. Returns the log to print
/// (the run's, or the preparation's when that failed) and the outcome.
fn python(root: &Path, dir: &Path, mut prepare: Child) -> (PathBuf, Result<(), Failure>) {
    let log = dir.join("prepare.log");
    let status = match prepare.wait() {
        Ok(s) => s,
        Err(e) => return (log, Err(cannot("wait for `bash .ci/python prepare`", &e))),
    };
    if !status.success() {
        return (log, Err(step_failed("bash .ci/python prepare", status)));
    }
    let log = dir.join("run.log");
    let run = logged(root, &log, |cmd| {
        cmd.arg(root.join(".ci/python")).arg("run").arg(dir);
    })
    .and_then(|mut child| child.wait());
    let outcome = match run {
        Ok(s) if s.success() => Ok(()),
        Ok(s) => Err(step_failed("bash .ci/python run", s)),
        Err(e) => Err(cannot("run `bash .ci/python run`", &e)),
    };
    (log, outcome)
}

fn cannot(what: &str, e: &std::io::Error) -> Failure {
    Failure {
        message: format!("cannot {what}: {e}"),
        code: 1,
    }
}

/// Starts `bash .ci/python prepare DIR` in the background, its output into `DIR/prepare.log`.
fn spawn_prepare(root: &Path, dir: &Path) -> Result<Child, Failure> {
    std::fs::create_dir_all(dir).map_err(|e| Failure {
        message: format!("cannot create {}: {e}", dir.display()),
        code: 1,
    })?;
    logged(root, &dir.join("prepare.log"), |cmd| {
        cmd.arg(root.join(".ci/python")).arg("prepare").arg(dir);
    })
    .map_err(|e| Failure {
        message: format!("cannot prepare a Python venv in {}: {e}", dir.display()),
        code: 1,
    })
}

/// Starts `bash` with the arguments `args` adds, in `root`, its output (both streams) into `log`.
fn logged(root: &Path, log: &Path, args: impl FnOnce(&mut Command)) -> std::io::Result<Child> {
    let mut cmd = Command::new("bash");
    args(&mut cmd);
    spawn_logged(root, log, cmd)
}

/// Runs one step in `root` in the foreground; an error unless it succeeds.
fn run_step(root: &Path, mut cmd: Command, what: &str) -> Result<(), Failure> {
    let status = cmd.current_dir(root).status().map_err(|e| Failure {
        message: format!("cannot run `{what}`: {e}"),
        code: 1,
    })?;
    if status.success() {
        Ok(())
    } else {
        Err(step_failed(what, status))
    }
}

fn step_failed(what: &str, status: ExitStatus) -> Failure {
    Failure {
        message: format!("`{what}` failed ({status})"),
        code: 1,
    }
}
