//! How far the smoothed reference departs from the legal trace: max and RMS |y_d − y_c| over the cycle's
//! samples, y_c the raw (piecewise-linear) cycle mapped by the model's reference map,
//! y_c = offset + scale · v_cycle, and the distance the smoothed cycle covers, ∫ (y_d − offset)/scale dt
//! (trapezoidal rule on the grid), beside the raw cycle's.
//!
//! The kernel smoother rounds the cycle's corners and starts to move up to a look-ahead early, so a reader
//! of the summary needs both: the legal trace is what a regulation drives, y_d what the inverse made the
//! model follow.

use std::fmt::Write as _;

use invsim_model_api::ReferenceMap;
use serde::Serialize;

use crate::cycle::Cycle;
use crate::report::{fmt_sig, unit_suffix};

/// The reference's departure from the cycle (JSON keys flattened into the inverse summary).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReferenceDeviation {
    /// ∫ (y_d − offset)/scale dt over the cycle, m (the distance of the smoothed cycle; `distance_m` is the
    /// raw cycle's).
    pub reference_distance_m: f64,
    /// max |y_d − y_c| over the cycle's samples, in the output's unit.
    pub reference_max_abs_deviation: f64,
    /// sqrt(mean (y_d − y_c)²) over the cycle's samples, in the output's unit.
    pub reference_rms_deviation: f64,
}

/// Accumulates [`ReferenceDeviation`] sample by sample, in increasing time.
#[derive(Debug, Clone)]
pub(crate) struct DeviationTally {
    map: ReferenceMap,
    segment: usize,
    max_abs: f64,
    sum_sq: f64,
    count: usize,
    distance: f64,
    previous: Option<f64>,
    dt: f64,
}

impl DeviationTally {
    pub(crate) fn new(map: ReferenceMap, dt: f64) -> DeviationTally {
        DeviationTally {
            map,
            segment: 0,
            max_abs: 0.0,
            sum_sq: 0.0,
            count: 0,
            distance: 0.0,
            previous: None,
            dt,
        }
    }

    /// The samples `yd` at `times` (increasing, and after those of earlier calls): segment by segment of
    /// the cycle, each sample as [`DeviationTally::push`] takes it (the same operations in the same order),
    /// in a loop without its checks.
    pub(crate) fn push_block(&mut self, cycle: &Cycle, times: &[f64], yd: &[f64]) {
        let (time, speed) = (&cycle.time, &cycle.speed);
        let n = time.len().min(speed.len());
        let mut k = 0;
        while k < times.len() {
            let t = times[k];
            // Before or at the start, at or after the end, an identity map missing: one by one.
            if !self.map.is_identity() || n < 2 || t <= time[0] || t >= time[n - 1] {
                self.push(cycle, t, yd[k]);
                k += 1;
                continue;
            }
            while self.segment + 2 < n && time[self.segment + 1] <= t {
                self.segment += 1;
            }
            let i = self.segment;
            // The samples in [time[i], time[i + 1]), before the end: y_c on one line.
            let (t_i, t_next, v_i, v_next) = (time[i], time[i + 1], speed[i], speed[i + 1]);
            let end = k + times[k..].partition_point(|&t| t < t_next.min(time[n - 1]));
            let (mut max_abs, mut sum_sq, mut distance) =
                (self.max_abs, self.sum_sq, self.distance);
            let mut previous = self.previous;
            for (&t, &y) in times[k..end].iter().zip(&yd[k..end]) {
                let w = (t - t_i) / (t_next - t_i);
                let e = y - (v_i + w * (v_next - v_i));
                max_abs = max_abs.max(e.abs());
                sum_sq += e * e;
                if let Some(p) = previous {
                    distance += 0.5 * self.dt * (p + y);
                }
                previous = Some(y);
            }
            (self.max_abs, self.sum_sq, self.distance) = (max_abs, sum_sq, distance);
            self.previous = previous;
            self.count += end - k;
            k = end;
        }
    }

    /// The sample y_d at time `t` (times increasing from call to call).
    #[inline]
    pub(crate) fn push(&mut self, cycle: &Cycle, t: f64, yd: f64) {
        let y_c = self.cycle_at(cycle, t);
        // The identity map as it is: yd − 0 = yd, yd / 1 = yd, and 0 + 1·y_c differs from y_c only in the
        // sign of a zero, which e neither shows in |e| nor in e².
        let (yc, v) = if self.map.is_identity() {
            (y_c, yd)
        } else {
            let ReferenceMap { offset, scale } = self.map;
            (offset + scale * y_c, (yd - offset) / scale)
        };
        let e = yd - yc;
        self.max_abs = self.max_abs.max(e.abs());
        self.sum_sq += e * e;
        self.count += 1;
        if let Some(p) = self.previous {
            self.distance += 0.5 * self.dt * (p + v);
        }
        self.previous = Some(v);
    }

    /// The raw cycle's speed at `t`: linear between samples, held outside (as [`Cycle::speed_at`]), with a
    /// cursor that only moves forward.
    fn cycle_at(&mut self, cycle: &Cycle, t: f64) -> f64 {
        let (time, speed) = (&cycle.time, &cycle.speed);
        let n = time.len();
        if n == 0 {
            return f64::NAN;
        }
        while self.segment + 2 < n && time[self.segment + 1] <= t {
            self.segment += 1;
        }
        let i = self.segment;
        if t <= time[0] || n == 1 {
            return speed[0];
        }
        if t >= time[n - 1] {
            return speed[n - 1];
        }
        let w = (t - time[i]) / (time[i + 1] - time[i]);
        speed[i] + w * (speed[i + 1] - speed[i])
    }

    pub(crate) fn finish(self) -> ReferenceDeviation {
        ReferenceDeviation {
            reference_distance_m: self.distance,
            reference_max_abs_deviation: self.max_abs,
            reference_rms_deviation: if self.count > 0 {
                (self.sum_sq / self.count as f64).sqrt()
            } else {
                0.0
            },
        }
    }
}

impl ReferenceDeviation {
    /// Summary text: `reference: |y_d - y_c| max 0.52 m/s, rms 0.08 m/s; distance 11012.9 m (cycle 11013.2 m)`.
    pub(crate) fn write_text(&self, s: &mut String, output_unit: Option<&str>, cycle_m: f64) {
        let u = unit_suffix(output_unit);
        let _ = writeln!(
            s,
            "reference vs cycle: |y_d - y_c| max {}{u}, rms {}{u}; distance of the reference {} m (cycle {} m)",
            fmt_sig(self.reference_max_abs_deviation, 3),
            fmt_sig(self.reference_rms_deviation, 3),
            fmt_sig(self.reference_distance_m, 6),
            fmt_sig(cycle_m, 6)
        );
    }
}
