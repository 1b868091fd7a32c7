//! `invsim forward`: the forward simulation of a model (with or without modes) along a drive cycle, closed by a
//! PI driver.

use std::path::PathBuf;

use clap::ValueEnum;
use invsim_runtime::forward::{self, Bounds, ForwardError, ForwardOptions, Method};
use invsim_runtime::RunFailure;

use crate::engine::{prepare_run, EngineChoice, RunRequest};
use crate::error::Failure;
use crate::provenance;

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum BoundsChoice {
    /// Apply the driver's demand as it is, like the inverse simulation (violations are reported).
    Ignore,
    /// Clip the demand to the model's input bounds and report where the vehicle misses the trace.
    Enforce,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodChoice {
    /// Dormand–Prince 5(4) with dense output.
    Dopri5,
    /// L-stable Rosenbrock 2(3), for stiff models at loose tolerances.
    Rosenbrock23,
}

// Serialised (by command-line name) into the summary's provenance. No doc comment: clap would
// make it the command's about, over the one `main.rs` gives it (its arguments are built when the command runs).
#[derive(clap::Args, Debug, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub struct ForwardArgs {
    /// The model file (TOML).
    pub model: PathBuf,
    /// A built-in cycle (`invsim cycles` lists them: nedc, udds, wltc3b, …) or the path of a cycle CSV file.
    #[arg(long)]
    pub(crate) cycle: String,
    /// Largest cycle file read, in bytes (default 64 MiB).
    #[arg(long, value_name = "BYTES", default_value_t = invsim_runtime::cycle::MAX_CYCLE_BYTES)]
    pub(crate) max_cycle_bytes: u64,
    /// The cycle's speed-tolerance band for the trace misses, SPEED_KMH,TIME_S (default: its regulation's, EPA
    /// ±2 mph, ±1 s for UDDS, HWFET and cycle files, UNECE ±2 km/h, ±1 s for the NEDC and the WLTC).
    #[arg(long, value_name = "SPEED_KMH,TIME_S")]
    pub(crate) tolerance: Option<String>,
    /// Output step in seconds.
    #[arg(long, default_value_t = forward::DEFAULT_DT, allow_negative_numbers = true)]
    pub(crate) dt: f64,
    /// Driver's proportional gain: requested acceleration per unit of speed error (1/s).
    #[arg(long, default_value_t = forward::DRIVER_KP, allow_negative_numbers = true)]
    pub(crate) kp: f64,
    /// Driver's integral gain: requested acceleration per unit of integrated speed error (1/s²).
    #[arg(long, default_value_t = forward::DRIVER_KI, allow_negative_numbers = true)]
    pub(crate) ki: f64,
    /// Bandwidth of the engine management's response to the driver's request (rad/s).
    #[arg(long, default_value_t = forward::RESPONSE_OMEGA, allow_negative_numbers = true)]
    pub(crate) response: f64,
    /// Leave out the driver's feed-forward of the cycle's slope.
    #[arg(long)]
    pub(crate) no_feedforward: bool,
    /// Ignore the model's input bounds (like the inverse) or enforce them.
    #[arg(long, value_enum, default_value_t = BoundsChoice::Ignore)]
    pub(crate) bounds: BoundsChoice,
    /// Integration method.
    #[arg(long, value_enum, default_value_t = MethodChoice::Dopri5)]
    pub(crate) method: MethodChoice,
    /// Relative tolerance of the integrator.
    #[arg(long, default_value_t = forward::DEFAULT_RTOL, allow_negative_numbers = true)]
    pub(crate) rtol: f64,
    /// Absolute tolerance of the integrator.
    #[arg(long, default_value_t = forward::DEFAULT_ATOL, allow_negative_numbers = true)]
    pub(crate) atol: f64,
    /// Stop after this many integrator steps (default: 2000 per second of the cycle, at least 100 000).
    #[arg(long, value_name = "N")]
    pub(crate) max_steps: Option<usize>,
    /// Stop once the integration has run this many seconds of wall-clock time (default: no limit).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub(crate) time_limit: Option<f64>,
    /// Override a parameter: NAME=VALUE (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub(crate) set: Vec<String>,
    #[command(flatten)]
    #[serde(flatten)]
    pub(crate) data: crate::data_args::DataArgs,
    /// Write the time series as CSV.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Write the summary as JSON.
    #[arg(long)]
    pub(crate) summary_json: Option<PathBuf>,
    /// Which implementation of the model to run.
    #[arg(long, value_enum, default_value_t = EngineChoice::Auto)]
    pub(crate) engine: EngineChoice,
    #[command(flatten)]
    pub(crate) plot: crate::plotting::PlotArgs,
}

/// The forward options of the command line (`engine`: the implementation run, only reported).
pub(crate) fn options(
    args: &ForwardArgs,
    engine: &str,
    progress: invsim_runtime::Progress,
) -> Result<ForwardOptions, ForwardError> {
    ForwardOptions::builder()
        .progress(progress)
        .dt(args.dt)
        .engine(engine)
        .kp(args.kp)
        .ki(args.ki)
        .response(args.response)
        .feedforward(!args.no_feedforward)
        .bounds(match args.bounds {
            BoundsChoice::Ignore => Bounds::Ignore,
            BoundsChoice::Enforce => Bounds::Enforce,
        })
        .method(match args.method {
            MethodChoice::Dopri5 => Method::Dopri5,
            MethodChoice::Rosenbrock23 => Method::Rosenbrock23,
        })
        .rtol(args.rtol)
        .atol(args.atol)
        .keep_series(args.out.is_some() || args.plot.plot.is_some())
        .max_steps(args.max_steps)
        .time_limit_s(args.time_limit)
        .build()
}

/// `invsim forward` of any model.
pub fn run(args: &ForwardArgs, warnings: crate::error::Warnings) -> Result<(), Failure> {
    let (outputs, mut cycle, model, data) = prepare_run(&RunRequest {
        model: &args.model,
        engine: args.engine,
        differentiated: false,
        cycle: &args.cycle,
        max_cycle_bytes: args.max_cycle_bytes,
        set: &args.set,
        out: args.out.as_deref(),
        summary_json: args.summary_json.as_deref(),
        plot: &args.plot,
        data: &args.data,
        warnings,
    })?;
    crate::cycle_spec::apply_tolerance(&mut cycle, args.tolerance.as_deref())?;
    let stopped = |e: &dyn std::fmt::Display| {
        Failure::user(format!(
            "forward simulation of `{}` on `{}` stopped: {e}",
            args.model.display(),
            cycle.name
        ))
    };
    let (progress, bar) = crate::progress::start("forward");
    let mut opts = options(args, model.engine_name(), progress).map_err(|e| stopped(&e))?;
    opts.signals = data.signals;
    opts.initial = data.initial;
    let plant = model.into_plant();
    let file = crate::engine::cycle_file(&args.cycle);
    let result = plant.forward(&cycle, file, &opts);
    bar.finish();
    let mut result = result.map_err(|e| match e {
        RunFailure::Gears(e) => Failure::user(format!("{}: {e}", args.model.display())),
        e => stopped(&e),
    })?;
    result.set_provenance(provenance::record(provenance::RunRecord {
        command: "forward",
        model: &args.model,
        info: plant.info(),
        cycle_spec: &args.cycle,
        cycle: &cycle,
        sets: &args.set,
        options: provenance::options_of(args),
    })?);
    result.warnings_mut().splice(0..0, data.cycle_warnings);
    crate::engine::write_run((&args.plot, warnings), outputs, (&plant, &cycle), &result)
}
