//! The `invsim` command line: `derive` prints a model's inversion, `simulate` runs it along a drive cycle,
//! `forward` runs the original model along the cycle with a PI driver, `cycles` lists the built-in drive cycles,
//! `completions` prints a shell completion script.
//!
//! Exit status (contract §3): 0 on success, 2 on a user error (bad model or cycle file, bad option, a model
//! the method cannot invert, a simulation that had to stop), with a one-paragraph message on stderr.

mod completions;
mod cycles_cmd;
mod describe;
mod engine;
mod version;

use clap::{Parser, Subcommand, ValueEnum};
use invsim_runtime::forward::{self, Bounds, ForwardOptions, Method};
use invsim_runtime::{output, plot, simulate, Cycle, SimulationOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(name = "invsim", version = version::VERSION, about = "Inverse dynamic simulation of vehicle powertrains", long_about = None)]
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
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
    },
    /// Run the inverse simulation of a model along a drive cycle.
    Simulate(SimulateArgs),
    /// Run the forward simulation of a model along a drive cycle, closed by a PI driver on the raw cycle.
    Forward(ForwardArgs),
    /// List the built-in drive cycles with their duration, distance and top speed.
    Cycles(cycles_cmd::CyclesArgs),
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell) on stdout.
    Completions(completions::CompletionsArgs),
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum Format {
    Text,
    Json,
    Markdown,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum EngineChoice {
    /// Compiled code when the model file matches a built-in model, else the interpreter.
    Auto,
    /// Compiled code; an error if the model is not built in.
    Compiled,
    /// The interpreter tape.
    Interpreted,
}

#[derive(clap::Args, Debug)]
struct SimulateArgs {
    /// The model file (TOML).
    model: PathBuf,
    /// A built-in cycle (`invsim cycles` lists them: nedc, udds, wltc3b, …) or the path of a cycle CSV file.
    #[arg(long)]
    cycle: String,
    /// Kernel half-width a in seconds: the driver's look-ahead.
    #[arg(long, default_value_t = 5.0)]
    lookahead: f64,
    /// Output step in seconds.
    #[arg(long, default_value_t = 0.1)]
    dt: f64,
    /// Override a parameter: NAME=VALUE (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// Write the time series as CSV.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the summary as JSON.
    #[arg(long)]
    summary_json: Option<PathBuf>,
    /// Draw the cycle, y_d and the input as SVG.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Replay the computed input through the original model and report the tracking error.
    #[arg(long)]
    verify: bool,
    /// Which implementation of the model to run.
    #[arg(long, value_enum, default_value_t = EngineChoice::Auto)]
    engine: EngineChoice,
    /// Integrate the zero dynamics forward even if they are unstable (default: unstable zero dynamics are
    /// inverted stably, non-causally, with pre- and post-actuation).
    #[arg(long)]
    causal: bool,
    /// Keep the pre- and post-actuation samples of a stable inversion (t before the cycle's start and after its
    /// end) in the CSV, the plot and the summary's integrals.
    #[arg(long)]
    include_extension: bool,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum BoundsChoice {
    /// Apply the driver's demand as it is, like the inverse simulation (violations are reported).
    Ignore,
    /// Clip the demand to the model's input bounds and report where the vehicle misses the trace.
    Enforce,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
enum MethodChoice {
    /// Dormand–Prince 5(4) with dense output.
    Dopri5,
    /// L-stable Rosenbrock 2(3), for stiff models at loose tolerances.
    Rosenbrock23,
}

#[derive(clap::Args, Debug)]
struct ForwardArgs {
    /// The model file (TOML).
    model: PathBuf,
    /// A built-in cycle (`invsim cycles` lists them: nedc, udds, wltc3b, …) or the path of a cycle CSV file.
    #[arg(long)]
    cycle: String,
    /// Output step in seconds.
    #[arg(long, default_value_t = 0.1)]
    dt: f64,
    /// Driver's proportional gain: requested acceleration per unit of speed error (1/s).
    #[arg(long, default_value_t = forward::DRIVER_KP, allow_negative_numbers = true)]
    kp: f64,
    /// Driver's integral gain: requested acceleration per unit of integrated speed error (1/s²).
    #[arg(long, default_value_t = forward::DRIVER_KI, allow_negative_numbers = true)]
    ki: f64,
    /// Bandwidth of the engine management's response to the driver's request (rad/s).
    #[arg(long, default_value_t = forward::RESPONSE_OMEGA, allow_negative_numbers = true)]
    response: f64,
    /// Leave out the driver's feed-forward of the cycle's slope.
    #[arg(long)]
    no_feedforward: bool,
    /// Ignore the model's input bounds (like the inverse) or enforce them.
    #[arg(long, value_enum, default_value_t = BoundsChoice::Ignore)]
    bounds: BoundsChoice,
    /// Integration method.
    #[arg(long, value_enum, default_value_t = MethodChoice::Dopri5)]
    method: MethodChoice,
    /// Relative tolerance of the integrator.
    #[arg(long, default_value_t = 1e-8)]
    rtol: f64,
    /// Absolute tolerance of the integrator.
    #[arg(long, default_value_t = 1e-10)]
    atol: f64,
    /// Override a parameter: NAME=VALUE (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// Write the time series as CSV.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write the summary as JSON.
    #[arg(long)]
    summary_json: Option<PathBuf>,
    /// Which implementation of the model to run.
    #[arg(long, value_enum, default_value_t = EngineChoice::Auto)]
    engine: EngineChoice,
}

/// A user-facing failure: the message and the exit status.
struct Failure {
    message: String,
    code: u8,
}

impl Failure {
    fn user(message: impl Into<String>) -> Failure {
        Failure {
            message: message.into(),
            code: 2,
        }
    }
    fn io(message: impl Into<String>) -> Failure {
        Failure {
            message: message.into(),
            code: 1,
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Derive { model, format } => derive(&model, format),
        Command::Simulate(args) => run_simulate(&args),
        Command::Forward(args) => run_forward(&args),
        Command::Cycles(args) => cycles_cmd::run(&args),
        Command::Completions(args) => completions::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("invsim: error: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}

fn derive(path: &Path, format: Format) -> Result<(), Failure> {
    let d = invsim_inversion::derive_file(path).map_err(|e| Failure::user(e.to_string()))?;
    let text = match format {
        Format::Text => d.to_text(),
        Format::Json => {
            let mut s = serde_json::to_string_pretty(&d.to_json())
                .map_err(|e| Failure::io(e.to_string()))?;
            s.push('\n');
            s
        }
        Format::Markdown => d.to_markdown(),
    };
    print_stdout(&text)
}

/// Parse `NAME=VALUE`.
fn parse_set(s: &str) -> Result<(String, f64), Failure> {
    let (name, value) = s.split_once('=').ok_or_else(|| {
        Failure::user(format!(
            "--set `{s}`: expected NAME=VALUE, e.g. --set m=1500"
        ))
    })?;
    let v: f64 = value
        .trim()
        .parse()
        .map_err(|_| Failure::user(format!("--set `{s}`: `{}` is not a number", value.trim())))?;
    if !v.is_finite() {
        return Err(Failure::user(format!(
            "--set `{s}`: the value must be finite"
        )));
    }
    Ok((name.trim().to_string(), v))
}

/// The cycle and the model of a run, with the `--set` overrides applied.
fn load_run(
    model: &Path,
    engine: EngineChoice,
    cycle: &str,
    sets: &[String],
) -> Result<(Cycle, engine::LoadedModel), Failure> {
    let sets: Vec<(String, f64)> = sets
        .iter()
        .map(|s| parse_set(s))
        .collect::<Result<_, _>>()?;
    let cycle = Cycle::load(cycle).map_err(|e| Failure::user(e.to_string()))?;
    let mut model = engine::load(model, engine)?;
    for (name, value) in &sets {
        model
            .set_param(name, *value)
            .map_err(|e| Failure::user(format!("--set {name}: {e}")))?;
    }
    Ok((cycle, model))
}

/// Create `path` and fill it with `write`, reporting either failure with the path.
fn write_file(
    path: &Path,
    write: impl FnOnce(std::fs::File) -> std::io::Result<()>,
) -> Result<(), Failure> {
    let file = std::fs::File::create(path)
        .map_err(|e| Failure::io(format!("cannot create {}: {e}", path.display())))?;
    write(file).map_err(|e| Failure::io(format!("cannot write {}: {e}", path.display())))
}

fn print_stdout(text: &str) -> Result<(), Failure> {
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(|e| Failure::io(format!("cannot write to stdout: {e}")))
}

fn run_simulate(args: &SimulateArgs) -> Result<(), Failure> {
    let (cycle, model) = load_run(&args.model, args.engine, &args.cycle, &args.set)?;
    let opts = SimulationOptions {
        lookahead: args.lookahead,
        dt: args.dt,
        engine: model.engine_name().to_string(),
        verify: args.verify,
        causal: args.causal,
        include_extension: args.include_extension,
        // Without --out or --plot only the summary is needed: no time series is stored.
        keep_series: args.out.is_some() || args.plot.is_some(),
        ..SimulationOptions::default()
    };
    let result = simulate(model.as_model(), &cycle, &opts).map_err(|e| {
        Failure::user(format!(
            "simulation of `{}` on `{}` stopped: {e}",
            args.model.display(),
            cycle.name
        ))
    })?;
    if let Some(path) = &args.out {
        write_file(path, |f| output::write_csv(&result, f))?;
    }
    if let Some(path) = &args.summary_json {
        write_file(path, |f| output::write_summary_json(&result.summary, f))?;
    }
    if let Some(path) = &args.plot {
        plot::plot_svg(&result, &cycle, path).map_err(|e| Failure::io(e.to_string()))?;
    }
    print_stdout(&describe::with_description(
        &result.summary.to_text(),
        &args.model,
    ))
}

fn run_forward(args: &ForwardArgs) -> Result<(), Failure> {
    let (cycle, model) = load_run(&args.model, args.engine, &args.cycle, &args.set)?;
    let opts = ForwardOptions {
        dt: args.dt,
        engine: model.engine_name().to_string(),
        kp: args.kp,
        ki: args.ki,
        response: args.response,
        feedforward: !args.no_feedforward,
        bounds: match args.bounds {
            BoundsChoice::Ignore => Bounds::Ignore,
            BoundsChoice::Enforce => Bounds::Enforce,
        },
        method: match args.method {
            MethodChoice::Dopri5 => Method::Dopri5,
            MethodChoice::Rosenbrock23 => Method::Rosenbrock23,
        },
        rtol: args.rtol,
        atol: args.atol,
        keep_series: args.out.is_some(),
        ..ForwardOptions::default()
    };
    let result = forward::forward(model.as_model(), &cycle, &opts).map_err(|e| {
        Failure::user(format!(
            "forward simulation of `{}` on `{}` stopped: {e}",
            args.model.display(),
            cycle.name
        ))
    })?;
    if let Some(path) = &args.out {
        write_file(path, |f| {
            output::write_table_csv(&result.columns, &result.data, f)
        })?;
    }
    if let Some(path) = &args.summary_json {
        write_file(path, |f| output::write_json(&result.summary, f))?;
    }
    print_stdout(&describe::with_description(
        &result.summary.to_text(),
        &args.model,
    ))
}
