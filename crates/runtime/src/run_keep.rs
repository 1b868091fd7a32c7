//! What one model's runs share from run to run on the same cycle: the smoothed reference of a model without
//! modes, the gear schedule and the smoothed cycle's tables of one with modes (`Shared`, also what a sweep's
//! runs on a cycle share). A [`RunKeep`] holds the last cycle's, and hands it to the next run on the same
//! cycle, file and options (the Python package's `Model` keeps one: a loop of runs, as an optimiser makes,
//! smooths the cycle once). The shared data depend on the cycle and the options, not on a parameter (a run
//! whose parameters move the reference's map smooths the cycle itself, `crate::inverse::simulate_shared`), so
//! a run through the keep gives the figures of a run without it, bit for bit.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use crate::cycle::Cycle;
use crate::inverse::{Reference, SimulateError, SimulationOptions};
use crate::modes::{GearSource, ReferenceCell};
use crate::plant::Plant;

/// What every run of a model on one cycle shares.
pub(crate) enum Shared {
    /// A model without modes: the smoothed reference.
    Reference(Arc<Reference>),
    /// A model with modes: the gear schedule resolved for the cycle, and the smoothed cycle its runs read
    /// (made by the first run, read by every other).
    Gears(GearSource, ReferenceCell),
}

/// Why the shared data could not be made: the reference of a model without modes, or the gear schedule of one
/// with modes for the cycle.
#[derive(Debug)]
pub(crate) enum SharedError {
    Reference(SimulateError),
    Gears(String),
}

impl Shared {
    /// What runs of `model` on `cycle` (read from `file`, `None` for a built-in one) with `opts` share.
    pub(crate) fn new(
        model: &Plant,
        cycle: &Cycle,
        file: Option<&Path>,
        opts: &SimulationOptions,
    ) -> Result<Shared, SharedError> {
        Ok(match model {
            Plant::Single(m) => Shared::Reference(Arc::new(
                crate::inverse::reference(m.as_ref(), cycle, opts)
                    .map_err(SharedError::Reference)?,
            )),
            Plant::Modal(p) => Shared::Gears(
                p.gear_source(cycle, file).map_err(SharedError::Gears)?,
                ReferenceCell::new(),
            ),
        })
    }
}

/// The last cycle's shared data of a model's runs, and what they were made for.
#[derive(Default)]
pub struct RunKeep {
    last: Mutex<Option<Kept>>,
}

struct Kept {
    cycle: Cycle,
    file: Option<PathBuf>,
    /// The options with what does not reach the shared data cleared ([`sharing`]).
    opts: SimulationOptions,
    shared: Arc<Shared>,
}

/// `opts` with the fields that do not reach the shared data (whether the series are kept, the run verified,
/// the gradient taken) set alike, so that runs differing in them share.
fn sharing(opts: &SimulationOptions) -> SimulationOptions {
    let mut o = opts.clone();
    o.keep_series = false;
    o.verify = false;
    o.gradient = None;
    o
}

impl RunKeep {
    pub fn new() -> RunKeep {
        RunKeep::default()
    }

    /// The shared data of `model`'s runs on `cycle` (read from `file`) with `opts`: the kept ones where they
    /// were made for the same cycle, file and options, else new ones, kept in their place.
    pub(crate) fn shared(
        &self,
        model: &Plant,
        cycle: &Cycle,
        file: Option<&Path>,
        opts: &SimulationOptions,
    ) -> Result<Arc<Shared>, SharedError> {
        let key = sharing(opts);
        // A run that panicked while holding the lock left nothing half-made: the entry is replaced whole.
        let kept = |last: &Option<Kept>| {
            last.as_ref()
                .filter(|k| k.cycle == *cycle && k.file.as_deref() == file && k.opts == key)
                .map(|k| k.shared.clone())
        };
        if let Some(shared) = kept(&self.last.lock().unwrap_or_else(|e| e.into_inner())) {
            return Ok(shared);
        }
        let shared = Arc::new(Shared::new(model, cycle, file, opts)?);
        *self.last.lock().unwrap_or_else(|e| e.into_inner()) = Some(Kept {
            cycle: cycle.clone(),
            file: file.map(Path::to_path_buf),
            opts: key,
            shared: shared.clone(),
        });
        Ok(shared)
    }
}
