//! `invsim simulate`: the inverse simulation of a model along a drive cycle.

use std::path::PathBuf;

use invsim_runtime::modes::Switching;
use invsim_runtime::{inverse, RunFailure, SimulationOptions};

use crate::engine::{prepare_run, EngineChoice, RunRequest};
use crate::error::Failure;
use crate::lookahead_arg::LookaheadArg;
use crate::provenance;

// Serialised (by command-line name) into the summary's provenance. No doc comment: clap would
// make it the command's about, over the one `main.rs` gives it (its arguments are built when the command runs).
#[derive(clap::Args, Debug, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub struct SimulateArgs {
    /// The model file (TOML).
    pub model: PathBuf,
    /// A built-in cycle (`invsim cycles` lists them: nedc, udds, wltc3b, …) or the path of a cycle CSV file.
    #[arg(long)]
    cycle: String,
    /// Largest cycle file read, in bytes (default 64 MiB).
    #[arg(long, value_name = "BYTES", default_value_t = invsim_runtime::cycle::MAX_CYCLE_BYTES)]
    max_cycle_bytes: u64,
    /// The cycle's speed-tolerance band, SPEED_KMH,TIME_S (default: its regulation's, EPA ±2 mph, ±1 s for
    /// UDDS, HWFET and cycle files, UNECE ±2 km/h, ±1 s for the NEDC and the WLTC).
    #[arg(long, value_name = "SPEED_KMH,TIME_S")]
    tolerance: Option<String>,
    /// Kernel half-width a in seconds: the driver's look-ahead; `auto` chooses the longest that keeps the
    /// reference inside the cycle's tolerance band with its cycle energy within 1 % of the trace's.
    #[arg(long, value_name = "A|auto", allow_negative_numbers = true,
          default_value_t = LookaheadArg::DEFAULT)]
    lookahead: LookaheadArg,
    /// Output step in seconds.
    #[arg(long, default_value_t = inverse::DEFAULT_DT, allow_negative_numbers = true)]
    dt: f64,
    /// Override a parameter: NAME=VALUE (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    #[command(flatten)]
    #[serde(flatten)]
    data: crate::data_args::DataArgs,
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
    /// Models with modes: how a switch enters the new mode (`reentry`: the reference blends from the state
    /// into the cycle; `quasi-static`: the state jumps by an impulse of the free input).
    #[arg(long, value_enum, default_value_t = SwitchingArg::Reentry)]
    switching: SwitchingArg,
    /// Models with modes: the re-entry's transition time in seconds (default: the look-ahead).
    #[arg(long)]
    transition_time: Option<f64>,
    /// Keep the pre- and post-actuation samples of a stable inversion (t before the cycle's start and after its
    /// end) in the CSV, the plot and the summary's integrals.
    #[arg(long)]
    include_extension: bool,
    /// Differentiate the summary's figures (every integral, its per-100-km figure, the headline's figures)
    /// exactly with respect to parameters: NAME,NAME,… or `all`, and a map's grid values, MAP[i], MAP[i,j] or
    /// MAP (every value; not in `all`); the summary gains a `gradient` block.
    #[arg(long, value_name = "NAME,…|all", value_delimiter = ',')]
    gradient: Option<Vec<String>>,
    #[command(flatten)]
    #[serde(flatten)]
    strategy: crate::strategy_args::StrategyArgs,
}

/// `--switching`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SwitchingArg {
    Reentry,
    QuasiStatic,
}

pub fn run(args: &SimulateArgs, warnings: crate::error::Warnings) -> Result<(), Failure> {
    let (outputs, mut cycle, model, data) = prepare_run(&RunRequest {
        model: &args.model,
        engine: args.engine,
        differentiated: args.gradient.is_some(),
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
            "simulation of `{}` on `{}` stopped: {e}",
            args.model.display(),
            cycle.name
        ))
    };
    let engine = model.engine_name();
    let plant = model.into_plant();
    let gearbox = match &plant {
        invsim_runtime::plant::Plant::Modal(p) => Some(p.gear_parameters()),
        _ => None,
    };
    check_gradient(
        args.gradient.as_deref(),
        gearbox,
        (plant.info(), &plant.maps()),
    )?;
    let (progress, bar) = crate::progress::start("simulate");
    let mut opts = args
        .lookahead
        .apply(SimulationOptions::builder())
        .progress(progress)
        .dt(args.dt)
        .engine(engine)
        .verify(args.verify)
        .causal(args.causal)
        .include_extension(args.include_extension)
        // Without --out or --plot only the summary is needed: no time series is stored.
        .keep_series(args.out.is_some() || args.plot.plot.is_some())
        .switching(match args.switching {
            SwitchingArg::Reentry => Switching::Reentry,
            SwitchingArg::QuasiStatic => Switching::QuasiStatic,
        })
        .transition_time(args.transition_time)
        .gradient(args.gradient.clone())
        .build()
        .map_err(|e| stopped(&e))?;
    opts.signals = data.signals;
    opts.initial = data.initial;
    opts.strategy = args.strategy.options()?;
    let file = crate::engine::cycle_file(&args.cycle);
    let result = plant.simulate(&cycle, file, &opts);
    bar.finish();
    let mut result = result.map_err(|e| match e {
        RunFailure::Gears(e) => Failure::user(format!("{}: {e}", args.model.display())),
        RunFailure::Inverse(invsim_runtime::SimulateError::Gradient(e)) => {
            Failure::user(format!("--gradient: {e}"))
        }
        e => stopped(&e),
    })?;
    result.set_provenance(provenance::record(provenance::RunRecord {
        command: "simulate",
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

/// `--gradient` before the run (`simulate` and `sweep`): every name must be one of `info`'s parameters, a grid
/// value of one of `maps` (`bsfc[3,4]`, `bsfc`) or, for a model with modes (`gearbox`: its per-gear
/// parameters), a gearbox parameter's per-gear name (`i_g[3]`).
pub(crate) fn check_gradient(
    names: Option<&[String]>,
    gearbox: Option<invsim_runtime::gradient::GearParameters<'_>>,
    (info, maps): (&invsim_model_api::ModelInfo, &[&invsim_model_api::map::Map]),
) -> Result<(), Failure> {
    let Some(names) = names else {
        return Ok(());
    };
    let checked = match gearbox {
        Some(g) => {
            invsim_runtime::gradient::resolve_modal_with_maps((&info.parameters, g), maps, names)
                .map(|_| ())
        }
        None => invsim_runtime::gradient::resolve(info, maps, names).map(|_| ()),
    };
    checked.map_err(|e| Failure::user(format!("--gradient: {e}")))
}
