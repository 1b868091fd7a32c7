//! `--engine`, `--set` and the common start of a run: the model loaded by `invsim_loader::load` (compiled code
//! for a built-in model whose file matches, else the interpreter tape built from the model file; a model with
//! modes the same way for each mode), the cycle, the overrides and the planned outputs.

use std::path::Path;

use clap::ValueEnum;
use invsim_loader::Loaded;
use invsim_runtime::Cycle;

use crate::error::{Failure, Warnings};

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum EngineChoice {
    /// Compiled code when the model file matches a built-in model, else the interpreter.
    Auto,
    /// Compiled code; an error if the model is not built in.
    Compiled,
    /// The interpreter tape.
    Interpreted,
}

impl From<EngineChoice> for invsim_loader::EngineChoice {
    fn from(c: EngineChoice) -> Self {
        match c {
            EngineChoice::Auto => invsim_loader::EngineChoice::Auto,
            EngineChoice::Compiled => invsim_loader::EngineChoice::Compiled,
            EngineChoice::Interpreted => invsim_loader::EngineChoice::Interpreted,
        }
    }
}

/// Load `path` with the requested engine (`invsim_loader::load_to`: compiled code for a file that is byte for
/// byte a built-in model's, without deriving it; any other file read and derived first, with the gradient's
/// closed-form Jacobians where the run is `differentiated`, so a bad file gives the same error whichever
/// engine was asked for).
pub fn load(path: &Path, choice: EngineChoice, differentiated: bool) -> Result<Loaded, Failure> {
    let extent = if differentiated {
        invsim_loader::Extent::Full
    } else {
        invsim_loader::Extent::Run
    };
    invsim_loader::load_to(path, choice.into(), extent).map_err(|e| match e {
        e @ invsim_loader::LoadError::NotBuiltIn { .. } => Failure::user(format!(
            "{e}; use --engine interpreted, or --engine auto to fall back to the interpreter"
        )),
        e => Failure::user(e.to_string()),
    })
}

/// Parse `NAME=VALUE`.
pub fn parse_set(s: &str) -> Result<(String, f64), Failure> {
    let (name, value) = s.split_once('=').ok_or_else(|| {
        Failure::user(format!(
            "--set `{s}`: expected NAME=VALUE, e.g. --set m=1500"
        ))
    })?;
    let v = crate::number_arg::parse_number(value).map_err(|e| match e {
        crate::number_arg::NumberError::NotFinite => {
            Failure::user(format!("--set `{s}`: the value must be finite"))
        }
        e => Failure::user(format!("--set `{s}`: {}", e.describe(value.trim()))),
    })?;
    Ok((name.trim().to_string(), v))
}

/// `--set NAME=VALUE` refused (`NAME: why`).
pub fn set_failure(e: invsim_loader::LoadError) -> Failure {
    Failure::user(format!("--set {e}"))
}

/// The cycle `spec` (read through the size cap) and its plausibility warnings, printed on stderr before the
/// run (a run the wrong units make fail still shows them), or with `--strict` the failure.
pub fn load_cycle(
    spec: &str,
    max_cycle_bytes: u64,
    warnings: Warnings,
) -> Result<(Cycle, Vec<String>), Failure> {
    let (cycle, found) =
        Cycle::load_checked(spec, max_cycle_bytes).map_err(|e| Failure::user(e.to_string()))?;
    let found: Vec<String> = found.iter().map(ToString::to_string).collect();
    warnings.emit(&found)?;
    Ok((cycle, found))
}

/// The cycle (read through the size cap) with its plausibility warnings and the model of a run, with the
/// `--set` overrides applied.
fn load_run(req: &RunRequest<'_>) -> Result<((Cycle, Vec<String>), Loaded), Failure> {
    let sets: Vec<(String, f64)> = req
        .set
        .iter()
        .map(|s| parse_set(s))
        .collect::<Result<_, _>>()?;
    let cycle = load_cycle(req.cycle, req.max_cycle_bytes, req.warnings)?;
    let mut model = load(req.model, req.engine, req.differentiated)?;
    for (name, value) in &sets {
        model.set_param(name, *value).map_err(set_failure)?;
    }
    Ok((cycle, model))
}

/// What `simulate` and `forward` ask for before a run: the input files, the engine, the overrides and the three
/// outputs.
pub struct RunRequest<'a> {
    pub model: &'a Path,
    pub engine: EngineChoice,
    /// The run is differentiated (`--gradient`): the model is derived with the gradient's Jacobians.
    pub differentiated: bool,
    pub cycle: &'a str,
    pub max_cycle_bytes: u64,
    pub set: &'a [String],
    pub out: Option<&'a Path>,
    pub summary_json: Option<&'a Path>,
    pub plot: &'a crate::plotting::PlotArgs,
    pub data: &'a crate::data_args::DataArgs,
    /// `--strict` or not.
    pub warnings: Warnings,
}

/// The parsed `--signal` and `--initial` values of a run, for its options.
pub struct RunData {
    pub signals: Vec<invsim_runtime::SignalInput>,
    pub initial: Vec<(String, f64)>,
    /// The cycle file's plausibility warnings (printed already; the summary records them too).
    pub cycle_warnings: Vec<String>,
}

/// The common start of `simulate` and `forward`: the outputs checked against every input file
/// ([`crate::inputs`]) and each other ([`crate::outputs::Outputs::plan`]), the cycle and the model loaded with the overrides (`--set`, `--map`),
/// the plot options checked against the model, `--signal` and `--initial` parsed — all before the run.
pub fn prepare_run(
    req: &RunRequest<'_>,
) -> Result<(crate::outputs::Outputs, Cycle, Loaded, RunData), Failure> {
    let inputs = crate::inputs::Inputs::new()
        .model(req.model)
        .cycle(req.cycle)
        .data(req.data);
    let outputs = crate::outputs::Outputs::plan(
        &inputs,
        &[
            ("--out", req.out),
            ("--summary-json", req.summary_json),
            ("--plot", req.plot.plot.as_deref()),
        ],
    )?;
    let ((cycle, cycle_warnings), mut model) = load_run(req)?;
    match &model {
        Loaded::Single(m) => {
            crate::plotting::check(req.plot, m.as_model().info(), crate::plotting::span(&cycle))?
        }
        Loaded::Modal(m) => crate::plotting::check_modal(
            req.plot,
            &m.plant.spec(invsim_runtime::modes::GearSource::Fixed),
            crate::plotting::span(&cycle),
        )?,
    }
    crate::map_args::apply(&req.data.map, |name, data| model.set_map(name, data))?;
    let data = RunData {
        signals: crate::signal_args::parse_signals(&req.data.signal)?,
        initial: crate::initial_args::parse_initial(&req.data.initial)?,
        cycle_warnings,
    };
    Ok((outputs, cycle, model, data))
}

/// The cycle file a run reads (`None` for a built-in cycle): a gearbox may take its gear from a column there.
pub fn cycle_file(spec: &str) -> Option<&Path> {
    (!crate::cycle_spec::is_builtin(spec)).then(|| Path::new(spec))
}

/// The end of `simulate` and `forward`: the finished run of `plant` on `cycle` written to `--out`,
/// `--summary-json` and `--plot` (through `outputs`), and its summary printed; with `--strict` a run with
/// warnings fails instead, writing nothing.
pub fn write_run(
    (plot, warnings): (&crate::plotting::PlotArgs, Warnings),
    mut outputs: crate::outputs::Outputs,
    (plant, cycle): (&invsim_runtime::Plant, &Cycle),
    result: &invsim_runtime::RunResult,
) -> Result<(), Failure> {
    warnings.check(result.warnings())?;
    outputs.write("--out", |f| result.write_csv(f))?;
    outputs.write("--summary-json", |f| result.write_summary_json(f))?;
    let headline = || {
        let mut json = Vec::new();
        result.write_summary_json(&mut json).ok()?;
        match serde_json::from_slice(&json).ok()? {
            serde_json::Value::Object(m) => crate::run_summary::headline(&m),
            _ => None,
        }
    };
    crate::plotting::write(
        plot,
        &mut outputs,
        |vars| plant.figure(result, cycle, vars),
        headline,
    )?;
    outputs.commit()?;
    crate::files::print_stdout(&result.summary_text())
}
