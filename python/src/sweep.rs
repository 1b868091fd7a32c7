//! Parameter sweeps: every variant (a set of parameter values) on every cycle, rows in variant-major order,
//! variants run in parallel with rayon. A failing run is a row with its error, never an abort of the sweep.
//!
//! [`run_sweep`] is the one function the Python side calls. Like the runtime's `Sweep`, it smooths each cycle
//! once ([`invsim_runtime::inverse::reference`]) and runs every variant on that shared reference
//! ([`invsim_runtime::inverse::simulate_shared`]); a model with modes keeps what its runs on a cycle share
//! (the smoothed cycle, the gear schedule, the zero dynamics' sub-grid) in a [`RunKeep`] per cycle. So a
//! row's summary is bit for bit that of a single run of the same variant; unlike `Sweep`, each row keeps the
//! whole summary (the JSON `--summary-json` writes).

use invsim_runtime::inverse::{reference, Reference};
use invsim_runtime::Plant;
use invsim_runtime::{Cycle, RunKeep, SimulationOptions};
use rayon::prelude::*;

use crate::engine::{Kind, Loaded};
use crate::error::Failure;
use crate::run::{cycle_file, run_failure, run_one, run_one_shared};
use invsim_runtime::lookahead::LookaheadChoice;

/// The variants of a sweep, stored column by column: `values[j][i]` is parameter `names[j]` of variant i.
#[derive(Debug, Clone)]
pub struct Variants {
    pub names: Vec<String>,
    pub values: Vec<Vec<f64>>,
}

impl Variants {
    /// Number of variants: without columns, one (the model's defaults).
    pub fn len(&self) -> usize {
        self.values.first().map_or(1, Vec::len)
    }
    /// Parameter settings of variant `i`, after the `base` settings shared by all variants.
    fn params(&self, base: &[(String, f64)], i: usize) -> Vec<(String, f64)> {
        let mut p = base.to_vec();
        p.extend(
            self.names
                .iter()
                .cloned()
                .zip(self.values.iter().map(|c| c[i])),
        );
        p
    }
}

/// One row: a variant on a cycle.
#[derive(Debug, Clone)]
pub struct Row {
    pub variant: usize,
    pub cycle: usize,
    /// The values of every model parameter in this run (the model's parameter order).
    pub params: Vec<f64>,
    /// The run's summary as JSON (what `--summary-json` writes), or why the run failed.
    pub summary: Result<String, String>,
}

/// Run every variant on every cycle; `threads` = `None` uses rayon's global pool. Rows are in the order
/// variant 0 on each cycle, variant 1 on each cycle, …
#[allow(clippy::too_many_arguments)]
pub fn run_sweep(
    model: &Loaded,
    model_path: &str,
    (cycles, specs): (&[Cycle], &[String]),
    variants: &Variants,
    base: &[(String, f64)],
    opts: &SimulationOptions,
    threads: Option<usize>,
) -> Result<Vec<Row>, Failure> {
    let jobs = variants.len() * cycles.len();
    // Each cycle's options: `auto` resolved once per cycle (the choice depends on the cycle and dt only).
    let resolved = cycles
        .iter()
        .map(|c| {
            invsim_runtime::lookahead::resolve(opts, c)
                .map_err(|e| run_failure(model_path, &c.name, e.into()))
        })
        .collect::<Result<Vec<_>, Failure>>()?;
    let references = match &model.kind {
        Kind::Single(_) => shared_references(model, cycles, base, &resolved),
        Kind::Modal(_) => Vec::new(),
    };
    // A model with modes: what the runs on a cycle share (its smoothed cycle and gear schedule, the zero
    // dynamics' sub-grid), kept per cycle as the command line's sweep keeps it.
    let keeps: Vec<RunKeep> = cycles.iter().map(|_| RunKeep::default()).collect();
    let one = |job: usize| {
        let (i, c) = (job / cycles.len(), job % cycles.len());
        let params = variants.params(base, i);
        let (opts, choice) = &resolved[c];
        let (values, summary) = match references.get(c) {
            Some(reference) => single_row(
                model,
                model_path,
                (&cycles[c], reference),
                &params,
                (opts, choice),
            ),
            None => modal_row(
                model,
                model_path,
                (&cycles[c], &specs[c], &keeps[c]),
                &params,
                (opts, choice),
            ),
        };
        Row {
            variant: i,
            cycle: c,
            params: values,
            summary: summary.map_err(|f| f.message),
        }
    };
    let run = || (0..jobs).into_par_iter().map(one).collect::<Vec<Row>>();
    match threads {
        None => Ok(run()),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(invsim_runtime::sweep::worker_threads(n, jobs))
            .build()
            .map(|pool| pool.install(run))
            .map_err(|e| Failure::msg(format!("cannot start {n} threads: {e}"))),
    }
}

/// One row of a model without modes: every parameter's value and the summary JSON.
fn single_row(
    model: &Loaded,
    model_path: &str,
    (cycle, reference): (&Cycle, &Option<Reference>),
    params: &[(String, f64)],
    (opts, choice): (&SimulationOptions, &Option<LookaheadChoice>),
) -> (Vec<f64>, Result<String, Failure>) {
    let instance = model.single(params);
    let values = instance
        .as_ref()
        .map(|m| m.params().to_vec())
        .unwrap_or_default();
    let summary = instance
        .and_then(|m| match reference {
            Some(r) => run_one_shared(m.as_ref(), model_path, cycle, r, opts),
            None => run_one(m.as_ref(), model_path, cycle, opts),
        })
        .and_then(|mut r| {
            r.summary.lookahead_choice = choice.clone();
            serde_json::to_string(&r.summary).map_err(|e| Failure::msg(e.to_string()))
        });
    (values, summary)
}

/// One row of a model with modes (`simulate` of its variant on `cycle`, read from `spec`, with what the
/// cycle's runs share in `keep`): every parameter's value (the first mode's) and the summary JSON.
fn modal_row(
    model: &Loaded,
    model_path: &str,
    (cycle, spec, keep): (&Cycle, &str, &RunKeep),
    params: &[(String, f64)],
    (opts, choice): (&SimulationOptions, &Option<LookaheadChoice>),
) -> (Vec<f64>, Result<String, Failure>) {
    let plant = model.plant(params);
    let values = match &plant {
        Ok(Plant::Modal(p)) => p.first().params().to_vec(),
        Ok(Plant::Single(m)) => m.params().to_vec(),
        Err(_) => Vec::new(),
    };
    let summary = plant.and_then(|p| {
        let file = cycle_file(spec);
        let mut r = p
            .simulate_keeping(cycle, file, opts, Some(keep))
            .map_err(|e| run_failure(model_path, &cycle.name, e))?;
        if let Some(c) = choice {
            r.set_lookahead_choice(c.clone());
        }
        let mut json = Vec::new();
        r.write_summary_json(&mut json)
            .map_err(|e| Failure::msg(e.to_string()))?;
        String::from_utf8(json).map_err(|e| Failure::msg(e.to_string()))
    });
    (values, summary)
}

/// The smoothed reference of every cycle, made once with the `base` settings. A variant whose parameters move
/// the reference map (an output offset or scale that is a parameter) does not fit it and smooths its cycle
/// itself (see `simulate_shared`), so sharing never changes a figure. Where no reference can be made (bad
/// base settings, a cycle the options refuse), `None`: the rows run alone and carry the error themselves.
fn shared_references(
    model: &Loaded,
    cycles: &[Cycle],
    base: &[(String, f64)],
    resolved: &[(SimulationOptions, Option<LookaheadChoice>)],
) -> Vec<Option<Reference>> {
    let m = model.single(base).ok();
    cycles
        .iter()
        .zip(resolved)
        .map(|(c, (opts, _))| m.as_ref().and_then(|m| reference(m.as_ref(), c, opts).ok()))
        .collect()
}
