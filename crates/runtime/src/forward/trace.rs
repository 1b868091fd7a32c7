//! Trace misses: where the vehicle leaves the U.S. driving-schedule tolerance band around the raw cycle.

use crate::cycle::Cycle;

/// The trace tolerance band [min − tol, max + tol] of the raw cycle over [t − τ, t + τ] (40 CFR 86.115-78),
/// for increasing t: two pointers into the breakpoints, O(1) per sample.
pub(super) struct TraceBand<'a> {
    time: &'a [f64],
    speed: &'a [f64],
    tau: f64,
    tol: f64,
    /// First breakpoint after t − τ, and after t + τ.
    lo: usize,
    hi: usize,
}

impl<'a> TraceBand<'a> {
    pub(super) fn new(cycle: &'a Cycle, tau: f64, tol: f64) -> Self {
        TraceBand {
            time: &cycle.time,
            speed: &cycle.speed,
            tau,
            tol,
            lo: 0,
            hi: 0,
        }
    }

    /// The raw cycle at s, given the index of the first breakpoint after s.
    fn value(&self, i: usize, s: f64) -> f64 {
        match i {
            0 => self.speed[0],
            i if i >= self.time.len() => self.speed[self.time.len() - 1],
            i => {
                let (t0, t1) = (self.time[i - 1], self.time[i]);
                let (v0, v1) = (self.speed[i - 1], self.speed[i]);
                v0 + (v1 - v0) * (s - t0) / (t1 - t0)
            }
        }
    }

    pub(super) fn at(&mut self, t: f64) -> (f64, f64) {
        let (a, b) = (t - self.tau, t + self.tau);
        while self.lo < self.time.len() && self.time[self.lo] <= a {
            self.lo += 1;
        }
        while self.hi < self.time.len() && self.time[self.hi] <= b {
            self.hi += 1;
        }
        let (va, vb) = (self.value(self.lo, a), self.value(self.hi, b));
        let (mut lo, mut hi) = (va.min(vb), va.max(vb));
        for &v in &self.speed[self.lo..self.hi.max(self.lo)] {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        (lo - self.tol, hi + self.tol)
    }
}
