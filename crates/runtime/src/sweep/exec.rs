//! Running a sweep: the variants × cycles in parallel (rayon), each worker with its own model.

use std::sync::atomic::{AtomicUsize, Ordering};

use invsim_model_api::InverseModel;
use rayon::prelude::*;

use super::plan::Sweep;
use super::rows::{Figures, SweepResult, SweepRow};
use crate::cycle::Cycle;
use crate::inverse::{simulate_shared, Reference};

/// A worker's model and the column buffers its runs reuse.
struct Worker {
    model: Result<Box<dyn InverseModel>, String>,
    spare: Vec<Vec<f64>>,
}

/// Set the variant's parameters on `model` and run it on `cycle` with the shared `reference`, reusing and
/// refilling the column buffers `spare`.
fn run_variant(
    sweep: &Sweep,
    model: &mut dyn InverseModel,
    spare: &mut Vec<Vec<f64>>,
    (cycle, reference): (&Cycle, &Reference),
    (params, integrals): (&[f64], &[String]),
) -> Result<Figures, String> {
    for (name, &value) in sweep.names.iter().zip(params) {
        model
            .set_param(name, value)
            .map_err(|e| format!("{name} = {value}: {e}"))?;
    }
    let buffers = std::mem::take(spare);
    let result = simulate_shared(&*model, cycle, reference, &sweep.opts, buffers)
        .map_err(|e| e.to_string())?;
    *spare = result.data;
    Ok(Figures::from_summary(&result.summary, integrals))
}

/// Row `job` (variant job / cycles, cycle job % cycles) on `worker`'s model.
fn run_one(sweep: &Sweep, worker: &mut Worker, integrals: &[String], job: usize) -> SweepRow {
    let n_cycles = sweep.cycles.len();
    let (variant, c) = (job / n_cycles, job % n_cycles);
    let (cycle, reference) = &sweep.cycles[c];
    let params = &sweep.variants[variant];
    let outcome = match &mut worker.model {
        Ok(model) => run_variant(
            sweep,
            model.as_mut(),
            &mut worker.spare,
            (cycle, reference),
            (params, integrals),
        ),
        Err(e) => Err(e.clone()),
    };
    SweepRow {
        variant,
        cycle: cycle.name.clone(),
        params: params.clone(),
        outcome,
    }
}

/// Every row of `sweep`, in order; `progress` is told the number of finished rows after each.
pub(super) fn run(sweep: &Sweep, progress: &(dyn Fn(usize) + Sync)) -> SweepResult {
    let info = &sweep.info;
    let mut integrals: Vec<String> = info
        .outputs
        .iter()
        .filter(|o| o.accumulate)
        .map(|o| o.name.clone())
        .collect();
    integrals.sort();
    let done = AtomicUsize::new(0);
    let job = |worker: &mut Worker, j: usize| {
        let row = run_one(sweep, worker, &integrals, j);
        progress(done.fetch_add(1, Ordering::Relaxed) + 1);
        row
    };
    let new_worker = || Worker {
        model: (sweep.factory)(),
        spare: Vec::new(),
    };
    let jobs = 0..sweep.len();
    let rows: Vec<SweepRow> = if sweep.threads == 1 {
        let mut worker = Worker {
            model: (sweep.factory)(),
            spare: Vec::new(),
        };
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
        model: info.name.clone(),
        engine: sweep.opts.engine.clone(),
        parameters: sweep.names.clone(),
        integrals,
        verify: sweep.opts.verify,
        rows,
    }
}
