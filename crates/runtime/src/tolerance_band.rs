//! Whether the smoothed reference stays inside the cycle's tolerance band (see [`crate::cycle::Tolerance`]):
//! at each output sample t, the excess
//!
//! ```text
//! e(t) = max( v_d(t) − upper(t),  lower(t) − v_d(t),  0 ),
//! upper(t) = max_{|s − t| ≤ Δt} v_c(s) + Δv,   lower(t) = min_{|s − t| ≤ Δt} v_c(s) − Δv,
//! ```
//!
//! with v_d the reference as a speed ((y_d − offset)/scale) and v_c the trace, linear between its samples and
//! held outside them. On a linear piece the extremes lie at an end, so the envelope over the window is the
//! extreme of the trace at t ± Δt and of the samples strictly inside: a monotone queue over the samples
//! keeps it in O(1) amortised per output sample (the window only moves forward).

use std::collections::VecDeque;

use serde::Serialize;

use crate::cycle::{Cycle, Tolerance};

/// An excess below this (m/s) is rounding, not a departure: with Δv = 0 the reference equals the trace
/// exactly only up to the last bits.
const EXCESS_FLOOR_MPS: f64 = 1e-9;

/// How far the reference leaves the tolerance band (the summary's `tolerance_band` block).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BandExcess {
    /// Δv of the band, m/s.
    pub speed_tolerance_mps: f64,
    /// Δt of the band, s.
    pub time_tolerance_s: f64,
    /// `EPA`, `UNECE` or `user`.
    pub source: &'static str,
    /// Output samples checked (those from the cycle's start to its end).
    pub samples_checked: usize,
    /// Output samples where the reference lies outside the band.
    pub samples_outside: usize,
    /// The largest excess e(t), m/s (0 inside everywhere).
    pub max_excess_mps: f64,
    /// The time of the largest excess, s (absent inside everywhere).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_time_s: Option<f64>,
}

/// The trace's extremes over [t − Δt, t + Δt] for increasing t (the envelope of the band before its ±Δv):
/// the one place the band of a regulation is computed, for the reference ([`BandTally`]) and for the speed a
/// forward run drives (its trace misses).
#[derive(Debug, Clone)]
pub(crate) struct Envelope {
    time_s: f64,
    /// The first sample not yet queued (time ≥ t + Δt at the last t).
    next: usize,
    /// The first sample after t − Δt at the last t.
    first: usize,
    /// Sample indices inside the window, speeds decreasing (front: the largest) and increasing (front: the
    /// smallest).
    maxima: VecDeque<usize>,
    minima: VecDeque<usize>,
    last_t: f64,
    piece: Option<Piece>,
}

/// Accumulates [`BandExcess`] sample by sample, in increasing time.
#[derive(Debug, Clone)]
pub(crate) struct BandTally {
    tolerance: Tolerance,
    envelope: Envelope,
    result: BandExcess,
}

/// The trace at τ = t + `shift` as a line in t, `(a, b)` with v_c = a + b·t, on the piece where `i` is the
/// first sample after τ (or the count): the line through samples i − 1 and i, held before the first sample
/// and after the last.
fn trace_line(time: &[f64], speed: &[f64], i: usize, shift: f64) -> (f64, f64) {
    match (i.checked_sub(1), time.get(i)) {
        (None, _) => (speed.first().copied().unwrap_or(0.0), 0.0),
        (Some(p), None) => (speed.get(p).copied().unwrap_or(0.0), 0.0),
        (Some(p), Some(&t1)) => {
            let b = (speed[i] - speed[p]) / (t1 - time[p]);
            (speed[p] - b * (time[p] - shift), b)
        }
    }
}

/// The envelope while the window holds the same samples: the extremes of the samples inside, and the trace
/// at the window's two ends as lines in t.
#[derive(Debug, Clone, Copy)]
struct Piece {
    /// (first, next) it was built for.
    key: (usize, usize),
    inner: (f64, f64),
    ends: [(f64, f64); 2],
}

impl BandTally {
    pub(crate) fn new(tolerance: Tolerance) -> BandTally {
        BandTally {
            tolerance,
            envelope: Envelope::new(tolerance.time_s),
            result: BandExcess {
                speed_tolerance_mps: tolerance.speed_mps,
                time_tolerance_s: tolerance.time_s,
                source: tolerance.source,
                samples_checked: 0,
                samples_outside: 0,
                max_excess_mps: 0.0,
                worst_time_s: None,
            },
        }
    }

    /// The reference speed `v` at time `t` (after the times of earlier calls), `e` = v − v_c(t) its distance
    /// from the trace there. The window holds t, so upper(t) ≥ v_c(t) + Δv and lower(t) ≤ v_c(t) − Δv: a
    /// sample with |e| ≤ Δv is inside without the envelope, which is only built (the queues brought up to t)
    /// for the others.
    #[inline(always)]
    pub(crate) fn push(&mut self, cycle: &Cycle, t: f64, v: f64, e: f64) {
        if e.abs() > self.tolerance.speed_mps {
            self.envelope_check(cycle, t, v);
        }
    }

    /// Δv, m/s: a caller with many samples compares |e| with it itself and calls
    /// [`BandTally::envelope_check`] only above it (as [`BandTally::push`] does).
    pub(crate) fn speed_tolerance(&self) -> f64 {
        self.tolerance.speed_mps
    }

    /// The excess at `t` from the envelope of the trace over [t − Δt, t + Δt].
    #[inline(never)]
    pub(crate) fn envelope_check(&mut self, cycle: &Cycle, t: f64, v: f64) {
        let Some((bottom, top)) = self.envelope.at(cycle, t) else {
            return;
        };
        let dv = self.tolerance.speed_mps;
        let excess = (v - (top + dv)).max((bottom - dv) - v);
        if excess > EXCESS_FLOOR_MPS {
            let r = &mut self.result;
            r.samples_outside += 1;
            if excess > r.max_excess_mps {
                r.max_excess_mps = excess;
                r.worst_time_s = Some(t);
            }
        }
    }

    /// The result after `samples` output samples were pushed.
    pub(crate) fn finish(self, samples: usize) -> BandExcess {
        BandExcess {
            samples_checked: samples,
            ..self.result
        }
    }
}

impl Envelope {
    pub(crate) fn new(time_s: f64) -> Envelope {
        Envelope {
            time_s,
            next: 0,
            first: 0,
            maxima: VecDeque::new(),
            minima: VecDeque::new(),
            last_t: f64::NEG_INFINITY,
            piece: None,
        }
    }

    /// (min, max) of the trace over [t − Δt, t + Δt] (`None` for an empty cycle or a NaN time). On a
    /// linear piece the extremes lie at an end, so they are those of the trace at t ± Δt and of the samples
    /// strictly inside: a monotone queue over the samples gives the latter in O(1) amortised (the window only
    /// moves forward; a t before the last starts it afresh), and while the window holds the same samples the
    /// ends are lines in t, kept.
    pub(crate) fn at(&mut self, cycle: &Cycle, t: f64) -> Option<(f64, f64)> {
        let (time, speed) = (&cycle.time[..], &cycle.speed[..]);
        let n = time.len().min(speed.len());
        if n == 0 || t.is_nan() {
            return None;
        }
        if t < self.last_t {
            *self = Envelope::new(self.time_s);
        }
        self.last_t = t;
        let (lo_t, hi_t) = (t - self.time_s, t + self.time_s);
        while self.next < n && time[self.next] < hi_t {
            let (i, s) = (self.next, speed[self.next]);
            while self.maxima.back().is_some_and(|&j| speed[j] <= s) {
                self.maxima.pop_back();
            }
            while self.minima.back().is_some_and(|&j| speed[j] >= s) {
                self.minima.pop_back();
            }
            self.maxima.push_back(i);
            self.minima.push_back(i);
            self.next += 1;
        }
        for q in [&mut self.maxima, &mut self.minima] {
            while q.front().is_some_and(|&j| time[j] <= lo_t) {
                q.pop_front();
            }
        }
        while self.first < self.next && time[self.first] <= lo_t {
            self.first += 1;
        }
        let key = (self.first, self.next);
        let piece = match self.piece {
            Some(p) if p.key == key => p,
            _ => {
                let front = |q: &VecDeque<usize>, none| q.front().map_or(none, |&j| speed[j]);
                let p = Piece {
                    key,
                    inner: (
                        front(&self.maxima, f64::NEG_INFINITY),
                        front(&self.minima, f64::INFINITY),
                    ),
                    ends: [
                        trace_line(time, speed, self.first, -self.time_s),
                        trace_line(time, speed, self.next, self.time_s),
                    ],
                };
                self.piece = Some(p);
                p
            }
        };
        let [(a0, b0), (a1, b1)] = piece.ends;
        let (e0, e1) = (a0 + b0 * t, a1 + b1 * t);
        Some((e0.min(e1).min(piece.inner.1), e0.max(e1).max(piece.inner.0)))
    }
}

impl BandExcess {
    /// The warning of a run whose reference leaves the band (none inside).
    pub(crate) fn warning(&self) -> Option<String> {
        let t = self.worst_time_s?;
        Some(format!(
            "the smoothed reference leaves the cycle's tolerance band ({}) at {} of {} samples, by up to {} \
             m/s ({} km/h) at t = {} s: a shorter --lookahead keeps it closer to the trace",
            self.describe(),
            self.samples_outside,
            self.samples_checked,
            crate::numfmt::num(self.max_excess_mps),
            crate::numfmt::num(self.max_excess_mps * 3.6),
            crate::numfmt::num(t),
        ))
    }

    fn describe(&self) -> String {
        Tolerance {
            speed_mps: self.speed_tolerance_mps,
            time_s: self.time_tolerance_s,
            source: self.source,
        }
        .describe()
    }

    /// Summary text: `tolerance band EPA ±2 mph, ±1 s: inside at every sample`.
    pub(crate) fn text(&self) -> String {
        match self.worst_time_s {
            None => format!("tolerance band {}: inside at every sample", self.describe()),
            Some(t) => format!(
                "tolerance band {}: left at {} sample(s), by up to {} m/s at t = {} s",
                self.describe(),
                self.samples_outside,
                crate::numfmt::num(self.max_excess_mps),
                crate::numfmt::num(t)
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The band by brute force: the trace's extremes over [t − Δt, t + Δt] sampled finely (with the
    /// window's ends and the samples inside, which is where a piecewise-linear trace has them).
    fn brute(cycle: &Cycle, tol: Tolerance, t: f64, v: f64) -> f64 {
        let mut pts: Vec<f64> = vec![t - tol.time_s, t + tol.time_s];
        pts.extend(
            cycle
                .time
                .iter()
                .filter(|&&s| (s - t).abs() < tol.time_s)
                .copied(),
        );
        let vals: Vec<f64> = pts.iter().map(|&s| cycle.speed_at(s)).collect();
        let top = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let bottom = vals.iter().copied().fold(f64::INFINITY, f64::min);
        (v - top - tol.speed_mps).max(bottom - tol.speed_mps - v)
    }

    /// The queue gives the brute-force excess at every sample of fine, coarse and offset grids, for a
    /// reference that wanders in and out of the band.
    #[test]
    fn queue_equals_brute_force() {
        let udds = Cycle::builtin("udds").unwrap();
        for tol in [
            Tolerance::EPA,
            Tolerance::new(1.0, 0.3).unwrap(),
            Tolerance::new(0.0, 2.5).unwrap(),
        ] {
            for (h, t0, n) in [(0.05, -2.0, 28_000), (1.0, 0.0, 1370), (0.7, 3.3, 1900)] {
                // The tally as the runs use it, and one that builds the envelope at every sample.
                let (mut tally, mut every) = (BandTally::new(tol), BandTally::new(tol));
                let (mut count, mut worst, mut at) = (0, 0.0, None);
                for k in 0..n {
                    let t = t0 + k as f64 * h;
                    let v = udds.speed_at(t) + 1.5 * (t * 0.21).sin();
                    tally.push(&udds, t, v, v - udds.speed_at(t));
                    every.push(&udds, t, v, f64::INFINITY);
                    let e = brute(&udds, tol, t, v);
                    if e > EXCESS_FLOOR_MPS {
                        count += 1;
                        if e > worst {
                            (worst, at) = (e, Some(t));
                        }
                    }
                }
                for r in [tally.finish(n), every.finish(n)] {
                    assert_eq!(r.samples_outside, count, "h = {h}");
                    assert!((r.max_excess_mps - worst).abs() < 1e-12, "h = {h}");
                    assert_eq!(r.worst_time_s, at);
                }
                assert!(count > 0 && count < n);
            }
        }
    }

    /// The trace itself is inside its band, even with Δv = 0.
    #[test]
    fn the_trace_is_inside() {
        let nedc = Cycle::builtin("nedc").unwrap();
        let mut tally = BandTally::new(Tolerance::new(0.0, 1.0).unwrap());
        for k in 0..11_800 {
            let t = k as f64 * 0.1;
            // e = 1 takes every sample through the envelope.
            tally.push(&nedc, t, nedc.speed_at(t), 1.0);
        }
        assert_eq!(tally.finish(11_800).samples_outside, 0);
    }

    /// A speed 2.5 km/h above a constant trace exceeds a ±2 km/h band by 0.5 km/h.
    #[test]
    fn excess_of_a_constant_offset() {
        let nedc = Cycle::builtin("nedc").unwrap();
        let mut tally = BandTally::new(Tolerance::UNECE);
        // 32 km/h from 61 s to 85 s in the first ECE: t = 70 s is more than 1 s from either end.
        tally.push(&nedc, 70.0, 34.5 / 3.6, 2.5 / 3.6);
        let r = tally.finish(1);
        assert_eq!(r.samples_outside, 1);
        assert!((r.max_excess_mps - 0.5 / 3.6).abs() < 1e-12);
    }
}
