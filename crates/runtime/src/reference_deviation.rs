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

use crate::cycle::{Cycle, Tolerance};
use crate::report::{fmt_sig, unit_suffix};
use crate::tolerance_band::{BandExcess, BandTally};

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
    /// Where the reference leaves the cycle's tolerance band ([`crate::tolerance_band`]).
    pub tolerance_band: BandExcess,
}

/// Accumulates [`ReferenceDeviation`] sample by sample, in increasing time.
#[derive(Debug, Clone)]
pub(crate) struct DeviationTally {
    map: ReferenceMap,
    segment: usize,
    sums: Sums,
    dt: f64,
    band: BandTally,
}

/// The running sums of [`DeviationTally`].
#[derive(Debug, Clone, Copy)]
struct Sums {
    max_abs: f64,
    sum_sq: f64,
    count: usize,
    distance: f64,
    previous: Option<f64>,
}

impl Sums {
    /// One sample: deviation `e` = y_d − y_c, `v` = (y_d − offset)/scale; the trapezoid of v over `dt`.
    #[inline(always)]
    fn add(&mut self, e: f64, v: f64, dt: f64) {
        self.max_abs = self.max_abs.max(e.abs());
        self.sum_sq += e * e;
        self.count += 1;
        if let Some(p) = self.previous {
            self.distance += 0.5 * dt * (p + v);
        }
        self.previous = Some(v);
    }
}

impl DeviationTally {
    pub(crate) fn new(map: ReferenceMap, dt: f64, tolerance: Tolerance) -> DeviationTally {
        DeviationTally {
            band: BandTally::new(tolerance),
            map,
            segment: 0,
            sums: Sums {
                max_abs: 0.0,
                sum_sq: 0.0,
                count: 0,
                distance: 0.0,
                previous: None,
            },
            dt,
        }
    }

    /// The samples `yd` at `times` (increasing, and after those of earlier calls): each as
    /// [`DeviationTally::push`] takes it (the same operations in the same order), the sums and the cycle's
    /// cursor in locals; where the cycle's segments hold many samples (a fine grid), segment by segment,
    /// without the per-sample checks.
    pub(crate) fn push_block(&mut self, cycle: &Cycle, times: &[f64], yd: &[f64]) {
        let (time, speed) = (&cycle.time, &cycle.speed);
        let n = time.len().min(speed.len());
        if !self.map.is_identity() || n < 2 {
            for (&t, &y) in times.iter().zip(yd) {
                self.push(cycle, t, y);
            }
            return;
        }
        let (Some(&first), Some(&last)) = (times.first(), times.last()) else {
            return;
        };
        let segments = time.partition_point(|&c| c <= last) - time.partition_point(|&c| c < first);
        let (mut sums, mut segment) = (self.sums, self.segment);
        let (dv, dt) = (self.band.speed_tolerance(), self.dt);
        let mut k = 0;
        while k < times.len().min(yd.len()) {
            let t = times[k];
            // `cycle_at`, with the identity map (see `push`).
            while segment + 2 < n && time[segment + 1] <= t {
                segment += 1;
            }
            let i = segment;
            if t <= time[0] || t >= time[n - 1] || times.len() < 4 * segments {
                // At or beyond an end, or segments of a sample or two (a coarse grid): this sample.
                let yc = if t <= time[0] {
                    speed[0]
                } else if t >= time[n - 1] {
                    speed[n - 1]
                } else {
                    speed[i] + (t - time[i]) / (time[i + 1] - time[i]) * (speed[i + 1] - speed[i])
                };
                sums.add(yd[k] - yc, yd[k], dt);
                if (yd[k] - yc).abs() > dv {
                    self.band.envelope_check(cycle, t, yd[k]);
                }
                k += 1;
                continue;
            }
            // The samples in [time[i], time[i + 1]), before the end: y_c on one line. (A scan: the binary
            // search is not cheaper for a segment's worth of samples.)
            let (t_i, t_next, v_i, v_next) = (time[i], time[i + 1], speed[i], speed[i + 1]);
            let end = k + times[k..].iter().take_while(|&&t| t < t_next).count();
            for (&t, &y) in times[k..end].iter().zip(&yd[k..end]) {
                let w = (t - t_i) / (t_next - t_i);
                let e = y - (v_i + w * (v_next - v_i));
                sums.add(e, y, dt);
                if e.abs() > dv {
                    self.band.envelope_check(cycle, t, y);
                }
            }
            k = end;
        }
        (self.sums, self.segment) = (sums, segment);
    }

    /// The sample y_d at time `t` (times increasing from call to call).
    #[inline(always)]
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
        self.sums.add(yd - yc, v, self.dt);
        self.band.push(cycle, t, v, v - y_c);
    }

    /// The raw cycle's speed at `t`: linear between samples, held outside (as [`Cycle::speed_at`]), with a
    /// cursor that only moves forward.
    #[inline(always)]
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
        let s = self.sums;
        ReferenceDeviation {
            reference_distance_m: s.distance,
            reference_max_abs_deviation: s.max_abs,
            reference_rms_deviation: if s.count > 0 {
                (s.sum_sq / s.count as f64).sqrt()
            } else {
                0.0
            },
            tolerance_band: self.band.finish(s.count),
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
        let _ = writeln!(s, "{}", self.tolerance_band.text());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn finish_bits(t: DeviationTally) -> [u64; 3] {
        let d = t.finish();
        [
            d.reference_distance_m.to_bits(),
            d.reference_max_abs_deviation.to_bits(),
            d.reference_rms_deviation.to_bits(),
        ]
    }

    /// Blocks of samples give the sample-by-sample tally bit for bit: fine and coarse grids, grids that
    /// start before and end after the cycle, the identity map and another.
    #[test]
    fn blocks_equal_samples() {
        let udds = Cycle::builtin("udds").unwrap();
        let maps = [
            ReferenceMap::IDENTITY,
            ReferenceMap {
                offset: 0.3,
                scale: 2.5,
            },
        ];
        for map in maps {
            for (h, t0, n) in [
                (0.01, -3.0, 140_000),
                (1.0, 0.0, 1370),
                (2.5, -7.0, 560),
                (0.1, 5.0, 9000),
            ] {
                let times: Vec<f64> = (0..n).map(|k| t0 + k as f64 * h).collect();
                let yd: Vec<f64> = times
                    .iter()
                    .map(|&t| map.offset + map.scale * (udds.speed_at(t) + 0.01 * (t * 0.37).sin()))
                    .collect();
                let mut one = DeviationTally::new(map, h, udds.tolerance);
                for (&t, &y) in times.iter().zip(&yd) {
                    one.push(&udds, t, y);
                }
                let mut blocks = DeviationTally::new(map, h, udds.tolerance);
                for (t, y) in times.chunks(4096).zip(yd.chunks(4096)) {
                    blocks.push_block(&udds, t, y);
                }
                assert_eq!(one.sums.count, blocks.sums.count);
                assert_eq!(finish_bits(one), finish_bits(blocks), "h = {h}");
            }
        }
    }
}
