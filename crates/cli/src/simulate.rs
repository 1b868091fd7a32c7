//! `invsim simulate`: the inverse simulation of a model along a drive cycle.

use std::path::PathBuf;

use invsim_runtime::{inverse, output, plot, simulate, SimulateError, SimulationOptions};

use crate::engine::{load_run, EngineChoice};
use crate::error::Failure;
use crate::files::{print_stdout, write_file};

#[derive(clap::Args, Debug)]
pub struct SimulateArgs {
    /// The model file (TOML).
    pub model: PathBuf,
    /// A built-in cycle (`invsim cycles` lists them: nedc, udds, wltc3b, …) or the path of a cycle CSV file.
    #[arg(long)]
    cycle: String,
    /// Kernel half-width a in seconds: the driver's look-ahead.
    #[arg(long, default_value_t = inverse::DEFAULT_LOOKAHEAD)]
    lookahead: f64,
    /// Output step in seconds.
    #[arg(long, default_value_t = inverse::DEFAULT_DT)]
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
    #[command(flatten)]
    plot: crate::plotting::PlotArgs,
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

pub fn run(args: &SimulateArgs) -> Result<(), Failure> {
    let (cycle, model) = load_run(&args.model, args.engine, &args.cycle, &args.set)?;
    crate::plotting::check(&args.plot, model.as_model().info())?;
    let stopped = |e: SimulateError| {
        Failure::user(format!(
            "simulation of `{}` on `{}` stopped: {e}",
            args.model.display(),
            cycle.name
        ))
    };
    let opts = SimulationOptions::builder()
        .lookahead(args.lookahead)
        .dt(args.dt)
        .engine(model.engine_name())
        .verify(args.verify)
        .causal(args.causal)
        .include_extension(args.include_extension)
        // Without --out or --plot only the summary is needed: no time series is stored.
        .keep_series(args.out.is_some() || args.plot.plot.is_some())
        .build()
        .map_err(stopped)?;
    let result = simulate(model.as_model(), &cycle, &opts).map_err(stopped)?;
    if let Some(path) = &args.out {
        write_file(path, |f| output::write_csv(&result, f))?;
    }
    if let Some(path) = &args.summary_json {
        write_file(path, |f| output::write_summary_json(&result.summary, f))?;
    }
    crate::plotting::write(&args.plot, |vars| {
        plot::simulation_figure(&result, &cycle, model.as_model().info(), vars)
    })?;
    print_stdout(&crate::describe::with_description(
        &result.summary.to_text(),
        &args.model,
    ))
}
