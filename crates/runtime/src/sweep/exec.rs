//! Running a sweep: the variants × cycles in parallel (rayon), each worker with its own model.

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use super::plan::Sweep;
use super::rows::{Figures, SweepResult, SweepRow};
use crate::cycle::Cycle;
use crate::inverse::{simulate_shared, SimulationOptions};
use crate::plant::Plant;
use crate::run::simulate_modal;
use crate::run_keep::Shared;

/// A worker's model and the column buffers its runs reuse.
struct Worker {
    model: Result<Plant, String>,
    spare: Vec<Vec<f64>>,
}

/// Set the variant's parameters on `model` and run it on `cycle` with what its runs share, reusing and
/// refilling the column buffers `spare` (a model without modes).
fn run_variant(
    sweep: &Sweep,
    model: &mut Plant,
    spare: &mut Vec<Vec<f64>>,
    (cycle, shared, opts): (&Cycle, &Shared, &SimulationOptions),
    params: &[f64],
) -> Result<Figures, String> {
    for (name, &value) in sweep.names.iter().zip(params) {
        model
            .set_param(name, value)
            .map_err(|e| format!("{name} = {}: {e}", crate::numfmt::num(value)))?;
    }
    match (&*model, shared) {
        (Plant::Single(m), Shared::Reference(reference)) => {
            let buffers = std::mem::take(spare);
            let result = simulate_shared(m.as_ref(), cycle, reference, opts, buffers)
                .map_err(|e| e.to_string())?;
            *spare = result.data;
            Ok(Figures::from_summary(&result.summary, &sweep.integrals))
        }
        (Plant::Modal(p), Shared::Gears(gears, kept)) => {
            let wrt = opts
                .gradient
                .as_deref()
                .map(|names| crate::run::modal_gradient_params(p, opts, names))
                .transpose()
                .map_err(|e| e.to_string())?;
            let result = simulate_modal(p, (gears.clone(), Some(kept)), cycle, opts, wrt.as_ref())
                .map_err(|e| e.to_string())?;
            Ok(Figures::from_modal(&result.summary, &sweep.integrals))
        }
        _ => Err("the worker's model is not of the kind the sweep was built for".to_string()),
    }
}

/// Row `job` (variant job / cycles, cycle job % cycles) on `worker`'s model.
fn run_one(sweep: &Sweep, worker: &mut Worker, job: usize) -> SweepRow {
    let n_cycles = sweep.cycles.len();
    let (variant, c) = (job / n_cycles, job % n_cycles);
    let (cycle, shared, opts) = &sweep.cycles[c];
    let params = &sweep.variants[variant];
    let outcome = match &mut worker.model {
        Ok(model) => run_variant(
            sweep,
            model,
            &mut worker.spare,
            (cycle, shared, opts),
            params,
        ),
        Err(e) => Err(e.clone()),
    };
    SweepRow {
        variant,
        cycle: cycle.name.clone(),
        lookahead_s: opts.lookahead,
        params: params.clone(),
        outcome,
    }
}

/// Every row of `sweep`, in order; `progress` is told the number of finished rows after each.
pub(super) fn run(sweep: &Sweep, progress: &(dyn Fn(usize) + Sync)) -> SweepResult {
    let done = AtomicUsize::new(0);
    let job = |worker: &mut Worker, j: usize| {
        let row = run_one(sweep, worker, j);
        progress(done.fetch_add(1, Ordering::Relaxed) + 1);
        row
    };
    let new_worker = || Worker {
        model: (sweep.factory)(),
        spare: Vec::new(),
    };
    let jobs = 0..sweep.len();
    let rows: Vec<SweepRow> = if sweep.threads == 1 {
        let mut worker = new_worker();
        jobs.map(|j| job(&mut worker, j)).collect()
    } else {
        let all = || {
            jobs.clone()
                .into_par_iter()
                .map_init(new_worker, job)
                .collect()
        };
        match &sweep.pool {
            Some(pool) => pool.install(all),
            None => all(),
        }
    };
    SweepResult {
        model: sweep.model.clone(),
        engine: sweep.opts.engine.clone(),
        parameters: sweep.names.clone(),
        integrals: sweep.integrals.clone(),
        headline: sweep.headline.clone(),
        verify: sweep.opts.verify,
        modes: sweep.modes.clone(),
        hybrid: sweep.opts.strategy.is_some(),
        gradient: super::rows::gradient_columns(&rows),
        rows,
    }
}
