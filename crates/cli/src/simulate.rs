//! `invsim simulate`: the inverse simulation of a model along a drive cycle.

use std::path::PathBuf;

use invsim_runtime::modes::{StrategyOptions, Switching};
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
    /// Models with a [hybrid] table: the energy-management strategy that decides the mode and the decided
    /// inputs at every sample (`ecms`: the equivalent consumption minimisation strategy; `dp`: dynamic
    /// programming over a SOC grid, the charge-sustaining optimum up to the grids' error).
    #[arg(long, value_enum)]
    strategy: Option<StrategyArg>,
    /// With --strategy ecms: the equivalence factor s (W of fuel per W of battery power); default: searched
    /// so that the run ends charge-sustaining within --soc-tolerance.
    #[arg(long, value_name = "S", allow_negative_numbers = true)]
    equivalence: Option<f64>,
    /// With --strategy ecms: the charge-sustaining tolerance on |ΔSOC|, a fraction of the battery's capacity.
    #[arg(long, value_name = "TOL", default_value_t = invsim_runtime::modes::DEFAULT_SOC_TOLERANCE)]
    soc_tolerance: f64,
    /// Differentiate the summary's figures (every integral, its per-100-km figure, the headline's figures)
    /// exactly with respect to parameters: NAME,NAME,… or `all`; the summary gains a `gradient` block.
    #[arg(long, value_name = "NAME,…|all", value_delimiter = ',')]
    gradient: Option<Vec<String>>,
    /// With --strategy dp: points of the SOC grid over the SOC window (at least 2).
    #[arg(long, value_name = "N", default_value_t = invsim_runtime::modes::DEFAULT_SOC_GRID)]
    soc_grid: usize,
    /// With --strategy dp: values of the decided input's grid over its bounds (at least 2).
    #[arg(long, value_name = "M", default_value_t = invsim_runtime::modes::DEFAULT_SPLIT_GRID)]
    split_grid: usize,
    /// With --strategy dp: the SOC window's half-width w, a fraction of the capacity: the grid spans
    /// [SOC(0) − w, SOC(0) + w] clipped to [0, 1].
    #[arg(long, value_name = "W", allow_negative_numbers = true,
          default_value_t = invsim_runtime::modes::DEFAULT_SOC_WINDOW)]
    soc_window: f64,
    /// With --strategy rule-based: electric drive up to this battery power, W.
    #[arg(long, value_name = "W", allow_negative_numbers = true,
          default_value_t = invsim_runtime::modes::DEFAULT_RB_ENGINE_POWER)]
    rb_engine_power: f64,
    /// With --strategy rule-based: the engine runs whenever the charge is below SOC(0) minus this.
    #[arg(long, value_name = "DSOC", allow_negative_numbers = true,
          default_value_t = invsim_runtime::modes::DEFAULT_RB_SOC_LOW)]
    rb_soc_low: f64,
    /// With --strategy rule-based: the battery power the running engine charges with below SOC(0), W.
    #[arg(long, value_name = "W", allow_negative_numbers = true,
          default_value_t = invsim_runtime::modes::DEFAULT_RB_CHARGE_POWER)]
    rb_charge_power: f64,
}

/// `--strategy`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum StrategyArg {
    Ecms,
    Dp,
    RuleBased,
}

/// `--switching`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SwitchingArg {
    Reentry,
    QuasiStatic,
}

/// The strategy's options; `--equivalence` or a changed `--soc-tolerance` without `--strategy`, and DP's
/// options without `--strategy dp`, are refused.
fn strategy(args: &SimulateArgs) -> Result<Option<StrategyOptions>, Failure> {
    use invsim_runtime::modes as m;
    let tol_given = args.soc_tolerance != m::DEFAULT_SOC_TOLERANCE;
    let dp_given = args.soc_grid != m::DEFAULT_SOC_GRID
        || args.split_grid != m::DEFAULT_SPLIT_GRID
        || args.soc_window != m::DEFAULT_SOC_WINDOW;
    if dp_given && args.strategy != Some(StrategyArg::Dp) {
        return Err(Failure::user(
            "--soc-grid, --split-grid and --soc-window apply to --strategy dp; give --strategy dp"
                .to_string(),
        ));
    }
    let rb_given = args.rb_engine_power != m::DEFAULT_RB_ENGINE_POWER
        || args.rb_soc_low != m::DEFAULT_RB_SOC_LOW
        || args.rb_charge_power != m::DEFAULT_RB_CHARGE_POWER;
    if rb_given && args.strategy != Some(StrategyArg::RuleBased) {
        return Err(Failure::user(
            "--rb-engine-power, --rb-soc-low and --rb-charge-power apply to --strategy rule-based; give \
             --strategy rule-based"
                .to_string(),
        ));
    }
    if args.equivalence.is_some()
        && matches!(
            args.strategy,
            Some(StrategyArg::Dp | StrategyArg::RuleBased)
        )
    {
        return Err(Failure::user(
            "--equivalence applies to --strategy ecms; DP and the rules have no equivalence factor"
                .to_string(),
        ));
    }
    let method =
        match args.strategy {
            None if args.equivalence.is_some() || tol_given => return Err(Failure::user(
                "--equivalence and --soc-tolerance apply to --strategy ecms; give --strategy ecms"
                    .to_string(),
            )),
            None => return Ok(None),
            Some(StrategyArg::Ecms) => m::Method::Ecms,
            Some(StrategyArg::Dp) => dp_options(args)?,
            Some(StrategyArg::RuleBased) => rule_options(args)?,
        };
    if !(args.soc_tolerance > 0.0 && args.soc_tolerance.is_finite()) {
        return Err(Failure::user(format!(
            "--soc-tolerance must be a positive number, got {}",
            args.soc_tolerance
        )));
    }
    if let Some(s) = args.equivalence.filter(|s| !s.is_finite()) {
        return Err(Failure::user(format!(
            "--equivalence must be finite, got {s}"
        )));
    }
    Ok(Some(StrategyOptions {
        method,
        equivalence: args.equivalence,
        soc_tolerance: args.soc_tolerance,
    }))
}

/// `--rb-engine-power`, `--rb-soc-low`, `--rb-charge-power`, checked.
fn rule_options(args: &SimulateArgs) -> Result<invsim_runtime::modes::Method, Failure> {
    for (name, v) in [
        ("--rb-engine-power", args.rb_engine_power),
        ("--rb-soc-low", args.rb_soc_low),
        ("--rb-charge-power", args.rb_charge_power),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(Failure::user(format!(
                "{name} must be a number ≥ 0, got {v}"
            )));
        }
    }
    Ok(invsim_runtime::modes::Method::RuleBased(
        invsim_runtime::modes::RuleOptions {
            engine_power: args.rb_engine_power,
            soc_low: args.rb_soc_low,
            charge_power: args.rb_charge_power,
        },
    ))
}

/// `--soc-grid`, `--split-grid`, `--soc-window`, checked.
fn dp_options(args: &SimulateArgs) -> Result<invsim_runtime::modes::Method, Failure> {
    if args.soc_grid < 2 {
        return Err(Failure::user(format!(
            "--soc-grid must be at least 2, got {}",
            args.soc_grid
        )));
    }
    if args.split_grid < 2 {
        return Err(Failure::user(format!(
            "--split-grid must be at least 2, got {}",
            args.split_grid
        )));
    }
    if !(args.soc_window > 0.0 && args.soc_window.is_finite()) {
        return Err(Failure::user(format!(
            "--soc-window must be a positive number, got {}",
            args.soc_window
        )));
    }
    Ok(invsim_runtime::modes::Method::Dp(
        invsim_runtime::modes::DpOptions {
            soc_grid: args.soc_grid,
            split_grid: args.split_grid,
            soc_window: args.soc_window,
        },
    ))
}

pub fn run(args: &SimulateArgs, warnings: crate::error::Warnings) -> Result<(), Failure> {
    let (outputs, mut cycle, model, data) = prepare_run(&RunRequest {
        model: &args.model,
        engine: args.engine,
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
    check_gradient(args.gradient.as_deref(), gearbox, plant.info())?;
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
    opts.strategy = strategy(args)?;
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

/// `--gradient` before the run (`simulate` and `sweep`): every name must be one of `info`'s parameters or, for
/// a model with modes (`gearbox`: its per-gear parameters), a gearbox parameter's per-gear name (`i_g[3]`).
pub(crate) fn check_gradient(
    names: Option<&[String]>,
    gearbox: Option<invsim_runtime::gradient::GearParameters<'_>>,
    info: &invsim_model_api::ModelInfo,
) -> Result<(), Failure> {
    let Some(names) = names else {
        return Ok(());
    };
    let checked = match gearbox {
        Some(g) => invsim_runtime::gradient::resolve_modal(&info.parameters, g, names).map(|_| ()),
        None => invsim_runtime::gradient::resolve(info, names).map(|_| ()),
    };
    checked.map_err(|e| Failure::user(format!("--gradient: {e}")))
}
