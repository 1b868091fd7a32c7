//! Running a sweep: the variants × cycles in parallel (rayon), each worker with its own model.

use std::sync::atomic::{AtomicUsize, Ordering};

use invsim_model_api::InverseModel;
use rayon::prelude::*;

use super::rows::{Figures, SweepResult, SweepRow};
use super::Sweep;
use crate::inverse::simulate_shared;

/// A worker's model and the column buffers its runs reuse.
struct Worker {
    model: Box<dyn InverseModel>,
    spare: Vec<Vec<f64>>,
}

/// Row `job` (variant job / cycles, cycle job % cycles) on `worker`'s model.
fn run_one(sweep: &Sweep, worker: &mut Worker, integrals: &[String], job: usize) -> SweepRow {
    let n_cycles = sweep.cycles.len();
    let (variant, c) = (job / n_cycles, job % n_cycles);
    let (cycle, reference) = &sweep.cycles[c];
    let params = &sweep.variants[variant];
    let mut outcome = Ok(());
    for (name, &value) in sweep.names.iter().zip(params) {
        if let Err(e) = worker.model.set_param(name, value) {
            outcome = Err(format!("--set {name}={value}: {e}"));
            break;
        }
    }
    let outcome = outcome.and_then(|()| {
        let spare = std::mem::take(&mut worker.spare);
        let model = worker.model.as_ref();
        match simulate_shared(model, cycle, reference, &sweep.opts, spare) {
            Ok(result) => {
                let figures = Figures::from_summary(&result.summary, integrals);
                worker.spare = result.data;
                Ok(figures)
            }
            Err(e) => Err(e.to_string()),
        }
    });
    SweepRow {
        variant,
        cycle: cycle.name.clone(),
        params: params.clone(),
        outcome,
    }
}

/// Every row of `sweep`, in order; `progress` is told the number of finished rows after each.
pub(super) fn run(sweep: &Sweep, progress: &(dyn Fn(usize) + Sync)) -> SweepResult {
    let base = (sweep.factory)();
    let info = base.info().clone();
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
            model: base,
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
