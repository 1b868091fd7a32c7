//! Trace misses: where the vehicle leaves the driving-schedule tolerance band around the raw cycle (40 CFR
//! 86.115-78), the band computed as for the reference ([`crate::tolerance_band::Envelope`]).

use crate::cycle::Cycle;
use crate::tolerance_band::Envelope;

/// The trace tolerance band [min − tol, max + tol] of the raw cycle over [t − τ, t + τ], for increasing t.
pub(super) struct TraceBand<'a> {
    cycle: &'a Cycle,
    envelope: Envelope,
    tol: f64,
}

impl<'a> TraceBand<'a> {
    pub(super) fn new(cycle: &'a Cycle, tau: f64, tol: f64) -> Self {
        TraceBand {
            cycle,
            envelope: Envelope::new(tau),
            tol,
        }
    }

    /// The band at t (times increasing from call to call); an empty cycle has no band (nothing is a miss).
    pub(super) fn at(&mut self, t: f64) -> (f64, f64) {
        match self.envelope.at(self.cycle, t) {
            Some((lo, hi)) => (lo - self.tol, hi + self.tol),
            None => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }
}
