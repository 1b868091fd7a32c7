//! The engine's operating points over a run: a time-weighted histogram of engine speed × torque, for models
//! that declare their engine (`[engine] speed = "…", torque = "…"`, naming two `[outputs]` entries).
//!
//! Each sample k of the grid stands for the time w_k it represents under the trapezoidal rule (dt, and dt/2
//! at the first and the last sample), so the histogram's times add up to the span of the samples, (N − 1)·dt —
//! the cycle's duration for a grid that divides it. Bins are equal, of a "nice" width (1, 2 or 5 × 10^k)
//! chosen for about [`BINS`] bins over the range the run reached.

use std::fmt::Write as _;

use invsim_model_api::{EngineInfo, ModelInfo};
use serde::Serialize;

use crate::report::{fmt_sig, unit_suffix};

/// About this many bins per axis.
pub const BINS: usize = 20;

/// The time-weighted speed × torque histogram of a run (JSON `engine_operating_points`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OperatingPoints {
    /// The `[outputs]` entries that give the engine speed and torque, and their units.
    pub speed: String,
    pub speed_unit: Option<String>,
    pub torque: String,
    pub torque_unit: Option<String>,
    /// Bin edges, increasing: speed bin i is [speed_edges[i], speed_edges[i+1]) (the last bin closed).
    pub speed_edges: Vec<f64>,
    pub torque_edges: Vec<f64>,
    /// time_s[i][j]: seconds spent in speed bin i and torque bin j.
    pub time_s: Vec<Vec<f64>>,
    /// Σ time_s, s.
    pub total_time_s: f64,
}

/// Collects (speed, torque) of every sample of a run, and the range of the finite ones.
#[derive(Debug, Clone)]
pub(crate) struct OperatingPointTally {
    engine: EngineInfo,
    points: Vec<[f64; 2]>,
    /// `[lo, hi]` of the finite speeds and of the finite torques (`lo > hi` while there is none).
    range: [[f64; 2]; 2],
}

impl OperatingPointTally {
    /// A tally for `info`'s engine, `None` when the model declares none.
    pub(crate) fn new(info: &ModelInfo, samples: usize) -> Option<OperatingPointTally> {
        info.engine.map(|engine| OperatingPointTally {
            engine,
            points: Vec::with_capacity(samples),
            range: [[f64::INFINITY, f64::NEG_INFINITY]; 2],
        })
    }

    /// The sample whose extra outputs are `outputs`.
    #[inline]
    pub(crate) fn push(&mut self, outputs: impl Fn(usize) -> f64) {
        self.add([outputs(self.engine.speed), outputs(self.engine.torque)]);
    }

    /// Consecutive samples given as columns: every extra output's values (`columns[o][i]`) for `range`.
    pub(crate) fn extend(&mut self, columns: &[&mut [f64]], range: std::ops::Range<usize>) {
        let (w, t) = (
            &columns[self.engine.speed][range.clone()],
            &columns[self.engine.torque][range],
        );
        self.points.reserve(w.len());
        for (&w, &t) in w.iter().zip(t) {
            self.add([w, t]);
        }
    }

    #[inline]
    fn add(&mut self, p: [f64; 2]) {
        for (r, &v) in self.range.iter_mut().zip(&p) {
            if v.is_finite() {
                *r = [r[0].min(v), r[1].max(v)];
            }
        }
        self.points.push(p);
    }

    /// The histogram of the samples, taken dt apart.
    pub(crate) fn finish(self, info: &ModelInfo, dt: f64) -> OperatingPoints {
        let speed_edges = nice_edges(self.range[0]);
        let torque_edges = nice_edges(self.range[1]);
        let mut time_s = vec![vec![0.0; torque_edges.len() - 1]; speed_edges.len() - 1];
        let last = self.points.len().saturating_sub(1);
        for (k, &[w, t]) in self.points.iter().enumerate() {
            // Trapezoidal weights: dt/2 at either end of the run, dt inside.
            let weight = if k == 0 || k == last { 0.5 * dt } else { dt };
            time_s[bin(&speed_edges, w)][bin(&torque_edges, t)] += weight;
        }
        let total_time_s = time_s.iter().flatten().sum();
        let name = |i: usize| info.outputs[i].name.clone();
        let unit = |i: usize| info.outputs[i].unit.clone();
        OperatingPoints {
            speed: name(self.engine.speed),
            speed_unit: unit(self.engine.speed),
            torque: name(self.engine.torque),
            torque_unit: unit(self.engine.torque),
            speed_edges,
            torque_edges,
            time_s,
            total_time_s,
        }
    }
}

impl OperatingPoints {
    /// Summary text: the ranges, the number of bins and the bin where the engine spent the most time.
    pub(crate) fn write_text(&self, s: &mut String) {
        let (su, tu) = (
            unit_suffix(self.speed_unit.as_deref()),
            unit_suffix(self.torque_unit.as_deref()),
        );
        let (ns, nt) = (self.speed_edges.len() - 1, self.torque_edges.len() - 1);
        let range = |e: &[f64]| format!("[{}, {}]", fmt_sig(e[0], 4), fmt_sig(e[e.len() - 1], 4));
        let _ = write!(
            s,
            "engine operating points: {ns} x {nt} bins of {} {}{su} x {} {}{tu} (histogram in the JSON)",
            self.speed,
            range(&self.speed_edges),
            self.torque,
            range(&self.torque_edges)
        );
        let mut best = (0, 0, 0.0);
        for (i, row) in self.time_s.iter().enumerate() {
            for (j, &v) in row.iter().enumerate() {
                if v > best.2 {
                    best = (i, j, v);
                }
            }
        }
        let (i, j, v) = best;
        if v > 0.0 {
            let _ = write!(
                s,
                ", most time ({} s) at {} {}…{}{su}, {} {}…{}{tu}",
                fmt_sig(v, 4),
                self.speed,
                fmt_sig(self.speed_edges[i], 4),
                fmt_sig(self.speed_edges[i + 1], 4),
                self.torque,
                fmt_sig(self.torque_edges[j], 4),
                fmt_sig(self.torque_edges[j + 1], 4)
            );
        }
        s.push('\n');
    }
}

/// Equal bins of a nice width over the range of `values` (finite ones; at least one bin).
fn nice_edges([lo, hi]: [f64; 2]) -> Vec<f64> {
    if lo > hi {
        return vec![0.0, 1.0];
    }
    let width = nice_width((hi - lo) / BINS as f64, lo.abs().max(hi.abs()));
    let start = (lo / width).floor() * width;
    let n = (((hi - start) / width).floor() as usize + 1).clamp(1, 4 * BINS);
    (0..=n).map(|i| start + i as f64 * width).collect()
}

/// 1, 2 or 5 × 10^k at or above `raw` (a unit bin for a range of zero width around `scale`).
fn nice_width(raw: f64, scale: f64) -> f64 {
    let raw = if raw > 0.0 {
        raw
    } else {
        (scale * 0.05).max(1e-9)
    };
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|&w| w >= raw * (1.0 - 1e-12))
        .unwrap_or(10.0 * p)
}

/// Index of the bin of `v` (values outside, or not finite, go to the nearest end bin).
fn bin(edges: &[f64], v: f64) -> usize {
    let n = edges.len() - 1;
    if v.is_nan() || v < edges[0] {
        return 0;
    }
    let width = edges[1] - edges[0];
    // (v − e₀)/width ≥ 0 here, so truncation is the floor (and +∞ saturates).
    (((v - edges[0]) / width) as usize).min(n - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_bins_cover_the_range() {
        let e = nice_edges([0.0, 99.0]);
        assert_eq!(e[0], 0.0);
        assert!(*e.last().unwrap() > 99.0);
        assert_eq!(e[1] - e[0], 5.0);
        assert_eq!(bin(&e, 99.0), e.len() - 2);
        assert_eq!(bin(&e, 0.0), 0);
        let flat = nice_edges([2.0, 2.0]);
        assert!(flat[0] <= 2.0 && 2.0 < flat[1]);
    }
}
