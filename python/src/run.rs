//! One inverse simulation, as `invsim simulate` runs it: the cycle, the options, the model with its
//! parameters set, then `invsim_runtime::simulate` (a model without modes) or the mode sequence of
//! `invsim_runtime::modes` (a model with modes).

use invsim_runtime::forward::{ForwardSummary, ModalForwardSummary};
use std::sync::Mutex;

use invsim_runtime::inverse::{simulate_shared, Reference, SimulateError};
use invsim_runtime::lookahead::LookaheadChoice;
use invsim_runtime::modes::{ModalSummary, StrategyRequest, Switching};
use invsim_runtime::signal_file::read_signal_file;
use invsim_runtime::{
    Cycle, RunFailure, RunResult, SignalInput, SignalValue, SimulationOptions, SimulationResult,
    Summary,
};

use invsim_model_api::InverseModel;

use crate::engine::Loaded;
use crate::error::Failure;

/// The summary of one run, kept as Rust data: written as JSON (what `--summary-json` writes) when asked
/// for, so that a run whose summary is not read does not pay for writing and parsing it.
#[derive(serde::Serialize)]
#[serde(untagged)]
pub enum RunSummary {
    Inverse(Summary),
    Modal(ModalSummary),
    Forward(ForwardSummary),
    ModalForward(ModalForwardSummary),
}

/// What a run returns: the summary, the column names, the columns and each column's unit (for a model
/// without modes' inverse run: none, the model's derivation gives them).
pub type Output = (
    RunSummary,
    Vec<String>,
    Vec<Vec<f64>>,
    Vec<(String, Option<String>)>,
);

/// One signal as Python gives it (`signals={name: value}`): a constant, a signal file's path (the
/// command line's `--signal NAME=FILE.csv`), or samples (times, values).
pub type PySignal = (
    String,
    Option<f64>,
    Option<String>,
    Option<(Vec<f64>, Vec<f64>)>,
);

/// The options of a run (the keyword arguments of `Model.simulate` and `Model.sweep`).
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub dt: f64,
    /// The look-ahead, s; `None`: `auto` (`invsim_runtime::lookahead`).
    pub lookahead: Option<f64>,
    pub verify: bool,
    pub causal: bool,
    pub include_extension: bool,
    pub keep_series: bool,
    /// `--signal` values.
    pub signals: Vec<PySignal>,
    /// `--initial NAME=VALUE`.
    pub initial: Vec<(String, f64)>,
    /// Models with modes: `"reentry"` or `"quasi-static"`, and the re-entry's transition time.
    pub switching: String,
    pub transition_time: Option<f64>,
    /// `--gradient`: the parameters to differentiate the summary's figures by (`["all"]`: every one).
    pub gradient: Option<Vec<String>>,
    /// `--strategy` and its options (hybrids).
    pub strategy: StrategyRequest,
}

impl RunOptions {
    /// The runtime's options, validated, for `model_path` run by `engine` on `cycle` (an invalid option is
    /// reported as the command line reports it).
    pub fn build(
        &self,
        engine: &str,
        model_path: &str,
        cycle: &str,
    ) -> Result<SimulationOptions, Failure> {
        let builder = match self.lookahead {
            Some(a) => SimulationOptions::builder().lookahead(a),
            None => SimulationOptions::builder().lookahead_auto(true),
        };
        builder
            .dt(self.dt)
            .engine(engine)
            .verify(self.verify)
            .causal(self.causal)
            .include_extension(self.include_extension)
            .keep_series(self.keep_series)
            .switching(self.switching()?)
            .transition_time(self.transition_time)
            .gradient(self.gradient.clone())
            .build()
            .map_err(|e| stopped(model_path, cycle, e))
            .and_then(|mut o| {
                o.signals = self
                    .signals
                    .iter()
                    .map(signal_input)
                    .collect::<Result<_, _>>()?;
                o.initial = self.initial.clone();
                o.strategy = self.strategy.resolve().map_err(Failure::msg)?;
                Ok(o)
            })
    }
}

impl RunOptions {
    /// How a switch of a model with modes enters the new mode.
    fn switching(&self) -> Result<Switching, Failure> {
        match self.switching.as_str() {
            "reentry" => Ok(Switching::Reentry),
            "quasi-static" => Ok(Switching::QuasiStatic),
            s => Err(Failure::msg(format!(
                "switching `{s}`: expected \"reentry\" or \"quasi-static\""
            ))),
        }
    }
}

/// A Python signal as the runtime's input, checked as the command line checks `--signal`: a finite constant,
/// a readable signal file, or samples with strictly increasing finite times and finite values.
pub fn signal_input((name, constant, file, series): &PySignal) -> Result<SignalInput, Failure> {
    let bad = |why: String| Failure::msg(format!("signals[{name:?}]: {why}"));
    let value = match (constant, file, series) {
        (Some(v), _, _) if v.is_finite() => SignalValue::Constant(*v),
        (Some(v), _, _) => return Err(bad(format!("the value {v} is not finite"))),
        (None, Some(path), _) => read_signal_file(path.as_ref(), name)
            .map_err(|e| Failure::in_file(format!("signal {name}: {e}"), path.clone()))?,
        (None, None, Some((time, values))) => samples(time, values).map_err(bad)?,
        (None, None, None) => {
            return Err(bad("give a number, a file path or (times, values)".into()))
        }
    };
    Ok(SignalInput {
        name: name.clone(),
        value,
    })
}

/// Samples given as two sequences: equal lengths, at least one, times finite and strictly increasing, values
/// finite.
fn samples(time: &[f64], values: &[f64]) -> Result<SignalValue, String> {
    if time.len() != values.len() || time.is_empty() {
        return Err(format!(
            "(times, values) must have equal, nonzero lengths, not {} and {}",
            time.len(),
            values.len()
        ));
    }
    if let Some(i) = time.iter().position(|t| !t.is_finite()) {
        return Err(format!("time {i} is not finite"));
    }
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(format!("value {i} (at t = {}) is not finite", time[i]));
    }
    if let Some(i) = time.windows(2).position(|w| w[1] <= w[0]) {
        return Err(format!(
            "times must increase strictly: {} is followed by {}",
            time[i],
            time[i + 1]
        ));
    }
    Ok(SignalValue::Series {
        file: "(Python samples)".to_string(),
        time: time.to_vec(),
        values: values.to_vec(),
    })
}

/// The cycle file `spec` names (`None` for a built-in cycle): a gearbox may take its gear from a column there.
pub fn cycle_file(spec: &str) -> Option<&std::path::Path> {
    Cycle::builtin(spec)
        .is_none()
        .then(|| std::path::Path::new(spec))
}

/// A built-in cycle by name or a cycle file by path; a file's errors name the file.
pub fn load_cycle(spec: &str) -> Result<Cycle, Failure> {
    load_cycle_checked(spec).map(|(cycle, _)| cycle)
}

/// [`load_cycle`] with the file's plausibility warnings (a speed column in the wrong unit, a time column in
/// ms: `invsim_runtime::cycle::Implausible`), as the command line reads it.
pub fn load_cycle_checked(spec: &str) -> Result<(Cycle, Vec<String>), Failure> {
    let (cycle, found) = Cycle::load_checked(spec, invsim_runtime::cycle::MAX_CYCLE_BYTES)
        .map_err(|e| {
            if Cycle::builtin(spec).is_some() {
                Failure::msg(e.to_string())
            } else {
                Failure::in_file(e.to_string(), spec)
            }
        })?;
    Ok((cycle, found.iter().map(ToString::to_string).collect()))
}

/// Run the model instance `m` on `cycle`: the message of a stopped run is the command line's.
pub fn run_one(
    m: &dyn InverseModel,
    model_path: &str,
    cycle: &Cycle,
    opts: &SimulationOptions,
) -> Result<SimulationResult, Failure> {
    invsim_runtime::simulate(m, cycle, opts).map_err(|e| stopped(model_path, &cycle.name, e))
}

/// [`run_one`] on a reference smoothed beforehand (the numbers are bit for bit those of [`run_one`]).
pub fn run_one_shared(
    m: &dyn InverseModel,
    model_path: &str,
    cycle: &Cycle,
    reference: &Reference,
    opts: &SimulationOptions,
) -> Result<SimulationResult, Failure> {
    simulate_shared(m, cycle, reference, opts, Vec::new())
        .map_err(|e| stopped(model_path, &cycle.name, e))
}

/// The command line's message for a run that could not start or had to stop.
fn stopped(model_path: &str, cycle: &str, e: impl std::fmt::Display) -> Failure {
    Failure::msg(format!(
        "simulation of `{model_path}` on `{cycle}` stopped: {e}"
    ))
}

/// The command line's message for a run of the model at `model_path` on `cycle` that failed.
pub fn run_failure(model_path: &str, cycle: &str, e: RunFailure) -> Failure {
    match e {
        RunFailure::Gears(e) => Failure::in_file(format!("{model_path}: {e}"), model_path),
        e => stopped(model_path, cycle, e),
    }
}

/// Cycles whose `--lookahead auto` choice is remembered (the most recent ones).
const REMEMBERED_CHOICES: usize = 16;

/// `opts` with `auto` resolved for `cycle` ([`invsim_runtime::lookahead::resolve`]), the choice remembered
/// for the last [`REMEMBERED_CHOICES`] (cycle, dt): a script runs the same cycle many times, and the choice
/// depends on the cycle (its samples and tolerance) and dt only, so a repeated run gets the same choice
/// without the search.
fn resolve_remembered(
    opts: &SimulationOptions,
    cycle: &Cycle,
) -> Result<(SimulationOptions, Option<LookaheadChoice>), SimulateError> {
    type Memo = Vec<(Cycle, u64, LookaheadChoice)>;
    static MEMO: Mutex<Memo> = Mutex::new(Vec::new());
    if !opts.lookahead_auto {
        return Ok((opts.clone(), None));
    }
    let dt = opts.dt.to_bits();
    let known = MEMO.lock().ok().and_then(|m| {
        m.iter()
            .find(|(c, d, _)| *d == dt && c == cycle)
            .map(|(_, _, choice)| choice.clone())
    });
    let choice = match known {
        Some(choice) => choice,
        None => {
            let (_, choice) = invsim_runtime::lookahead::resolve(opts, cycle)?;
            let Some(choice) = choice else {
                return Ok((opts.clone(), None));
            };
            if let Ok(mut m) = MEMO.lock() {
                if m.len() >= REMEMBERED_CHOICES {
                    m.remove(0);
                }
                m.push((cycle.clone(), dt, choice.clone()));
            }
            choice
        }
    };
    Ok((
        invsim_runtime::lookahead::with_choice(opts, &choice),
        Some(choice),
    ))
}

/// One inverse run of `model` with `params` set on `cycle_spec`, as `invsim simulate` runs it.
pub fn simulate_any(
    (model, model_path, keep): (&Loaded, &str, &invsim_runtime::RunKeep),
    cycle_spec: &str,
    params: &[(String, f64)],
    opts: &RunOptions,
) -> Result<Output, Failure> {
    let (cycle, cycle_warnings) = load_cycle_checked(cycle_spec)?;
    let sim_opts = opts.build(model.engine_name(), model_path, &cycle.name)?;
    let (sim_opts, choice) =
        resolve_remembered(&sim_opts, &cycle).map_err(|e| stopped(model_path, &cycle.name, e))?;
    let file = cycle_file(cycle_spec);
    let mut result = model.with_plant(params, |plant| {
        plant
            .simulate_keeping(&cycle, file, &sim_opts, Some(keep))
            .map_err(|e| match e {
                RunFailure::Gears(e) => Failure::in_file(format!("{model_path}: {e}"), model_path),
                e => stopped(model_path, &cycle.name, e),
            })
    })?;
    if let Some(choice) = choice {
        result.set_lookahead_choice(choice);
    }
    result.warnings_mut().splice(0..0, cycle_warnings);
    Ok(match result {
        RunResult::Single(r) => (
            RunSummary::Inverse(r.summary),
            r.columns,
            r.data,
            Vec::new(),
        ),
        RunResult::Modal(r, _) => {
            let r = *r;
            let units = r.columns.iter().cloned().zip(r.units).collect();
            let (columns, data) = match opts.keep_series {
                true => (r.columns, r.data),
                false => (Vec::new(), Vec::new()),
            };
            (RunSummary::Modal(r.summary), columns, data, units)
        }
        _ => return Err(Failure::msg("an inverse run gave a forward result")),
    })
}
