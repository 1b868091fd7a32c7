//! Trace misses: where the vehicle leaves the driving-schedule tolerance band around the raw cycle (the cycle's
//! own band, `Cycle::tolerance`: 40 CFR 86.115-78 for the EPA's cycles, UNECE for NEDC and WLTC, or the
//! user's), computed as for the reference ([`crate::tolerance_band::Envelope`]), and their warning.

use crate::cycle::{Cycle, Tolerance};
use crate::report::fmt_sig;
use crate::tolerance_band::Envelope;

/// The trace tolerance band [min − tol, max + tol] of the raw cycle over [t − τ, t + τ], for increasing t.
pub(super) struct TraceBand<'a> {
    cycle: &'a Cycle,
    envelope: Envelope,
    tol: f64,
}

impl<'a> TraceBand<'a> {
    pub(super) fn new(cycle: &'a Cycle, band: Tolerance) -> Self {
        TraceBand {
            cycle,
            envelope: Envelope::new(band.time_s),
            tol: band.speed_mps,
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

/// The warning for trace misses (none without), naming the band and its source.
pub(super) fn miss_warning(band: Tolerance, misses: &[[f64; 2]]) -> Option<String> {
    if misses.is_empty() {
        return None;
    }
    Some(format!(
        "the vehicle misses the cycle's trace (± {} m/s around the cycle within ± {} s, {} band) in {}",
        fmt_sig(band.speed_mps, 4),
        fmt_sig(band.time_s, 4),
        band.source,
        crate::report::describe_intervals(misses)
    ))
}
