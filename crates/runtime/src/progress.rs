//! A progress callback for long runs: the fraction of the run done, 0 … 1, reported now and then (once per
//! block of samples of an inverse run, every few hundred samples of a forward run). Absent by default, and
//! then it costs one branch per report.

use std::fmt;
use std::sync::Arc;

/// An optional `Fn(fraction)` called as a run proceeds; cloning shares the callback.
#[derive(Clone, Default)]
pub struct Progress(Option<Arc<dyn Fn(f64) + Send + Sync>>);

impl Progress {
    /// No callback.
    pub fn none() -> Progress {
        Progress(None)
    }

    /// Call `f` with the fraction of the run done.
    pub fn new(f: impl Fn(f64) + Send + Sync + 'static) -> Progress {
        Progress(Some(Arc::new(f)))
    }

    /// Report `done` of `total` (nothing without a callback).
    #[inline]
    pub fn report(&self, done: usize, total: usize) {
        if let Some(f) = &self.0 {
            f(if total == 0 {
                1.0
            } else {
                (done as f64 / total as f64).min(1.0)
            });
        }
    }
}

impl fmt::Debug for Progress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.0.is_some() {
            "Progress(callback)"
        } else {
            "Progress(none)"
        })
    }
}

/// Progress reporting does not change a run: any two are equal.
impl PartialEq for Progress {
    fn eq(&self, _: &Progress) -> bool {
        true
    }
}
