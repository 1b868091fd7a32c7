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
    /// The samples' speeds and torques, in order.
    speeds: Vec<f64>,
    torques: Vec<f64>,
    /// `[lo, hi]` of the finite speeds and of the finite torques (`lo > hi` while there is none).
    range: [[f64; 2]; 2],
}

impl OperatingPointTally {
    /// A tally for `info`'s engine, `None` when the model declares none.
    pub(crate) fn new(info: &ModelInfo, samples: usize) -> Option<OperatingPointTally> {
        info.engine.clone().map(|engine| OperatingPointTally {
            engine,
            speeds: Vec::with_capacity(samples),
            torques: Vec::with_capacity(samples),
            range: [[f64::INFINITY, f64::NEG_INFINITY]; 2],
        })
    }

    /// The sample whose extra outputs are `outputs`.
    #[inline]
    pub(crate) fn push(&mut self, outputs: impl Fn(usize) -> f64) {
        let (w, t) = (outputs(self.engine.speed), outputs(self.engine.torque));
        // One sample: `extend_columns` for one value each, without its slice calls.
        self.speeds.push(w);
        self.torques.push(t);
        for (r, v) in self.range.iter_mut().zip([w, t]) {
            if v.is_finite() {
                *r = [r[0].min(v), r[1].max(v)];
            }
        }
    }

    /// Consecutive samples given as columns: every extra output's values (`columns[o][i]`) for `range`.
    pub(crate) fn extend<C: AsRef<[f64]>>(&mut self, columns: &[C], range: std::ops::Range<usize>) {
        let (w, t) = (
            &columns[self.engine.speed].as_ref()[range.clone()],
            &columns[self.engine.torque].as_ref()[range],
        );
        self.extend_columns(w, t);
    }

    fn extend_columns(&mut self, w: &[f64], t: &[f64]) {
        self.speeds.extend_from_slice(w);
        self.torques.extend_from_slice(t);
        for (r, c) in self.range.iter_mut().zip([w, t]) {
            *r = finite_range(*r, c);
        }
    }

    /// The histogram of the samples, taken dt apart: sample k weighs dt, dt/2 at either end of the run
    /// (the trapezoidal rule), so a bin holds dt·(n − e/2) for its n samples of which e are ends — one
    /// rounding, where adding the weights one by one would round at every sample.
    pub(crate) fn finish(self, info: &ModelInfo, dt: f64) -> OperatingPoints {
        let speed_edges = nice_edges(self.range[0]);
        let torque_edges = nice_edges(self.range[1]);
        let (si, ti) = (Bins::new(&speed_edges), Bins::new(&torque_edges));
        let nt = ti.n;
        // Samples per bin, and the ends: run by run of equal bins, as integers (exact in any order); the
        // bins a chunk at a time.
        let mut count = vec![0_u64; si.n * nt];
        let mut ends = vec![0_u64; si.n * nt];
        let mut run = (usize::MAX, 0_u64);
        const CHUNK: usize = 1024;
        let (mut bw, mut bt) = ([0_u32; CHUNK], [0_u32; CHUNK]);
        for (w, t) in self.speeds.chunks(CHUNK).zip(self.torques.chunks(CHUNK)) {
            si.indices(w, &mut bw);
            ti.indices(t, &mut bt);
            for (&i, &j) in bw[..w.len()].iter().zip(&bt[..w.len()]) {
                let b = i as usize * nt + j as usize;
                if b == run.0 {
                    run.1 += 1;
                } else {
                    if let Some(c) = count.get_mut(run.0) {
                        *c += run.1;
                    }
                    run = (b, 1);
                }
            }
        }
        if let Some(c) = count.get_mut(run.0) {
            *c += run.1;
        }
        let bin_of = |k: usize| si.index(self.speeds[k]) * nt + ti.index(self.torques[k]);
        if let Some(last) = self.speeds.len().checked_sub(1) {
            ends[bin_of(0)] += 1;
            ends[bin_of(last)] += 1;
        }
        let time_s: Vec<Vec<f64>> = count
            .chunks(nt)
            .zip(ends.chunks(nt))
            .map(|(c, e)| {
                c.iter()
                    .zip(e)
                    .map(|(&c, &e)| dt * (c as f64 - 0.5 * e as f64))
                    .collect()
            })
            .collect();
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

/// `[lo, hi]` widened by the finite values of `c`.
fn finite_range(range: [f64; 2], c: &[f64]) -> [f64; 2] {
    c.iter()
        .filter(|v| v.is_finite())
        .fold(range, |[lo, hi], &v| [lo.min(v), hi.max(v)])
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

/// Equal bins from their edges: the bins of values.
struct Bins {
    e0: f64,
    width: f64,
    /// Number of bins.
    n: usize,
}

impl Bins {
    fn new(edges: &[f64]) -> Bins {
        Bins {
            e0: edges[0],
            width: edges[1] - edges[0],
            n: edges.len() - 1,
        }
    }

    /// `out[k]` = the bin of `values[k]`: ⌊(v − e₀)/width⌋, values below the bins or NaN in the first, above
    /// them in the last (the floor taken after clamping to the last bin's number, which is the same for
    /// q ≥ 0). No branch: the compiler vectorises the division and the rest.
    fn indices(&self, values: &[f64], out: &mut [u32]) {
        let last = (self.n - 1) as f64;
        for (o, &v) in out.iter_mut().zip(values) {
            let q = (v - self.e0) / self.width;
            let q = if v >= self.e0 { q.min(last) } else { 0.0 };
            // SAFETY: q is in [0, n − 1] (v ≥ e₀ gives q ≥ 0 or +∞, clamped to n − 1; NaN takes 0), and
            // n − 1 < 2³¹ (at most 4·BINS bins), so the conversion is exact and in range.
            *o = unsafe { q.to_int_unchecked::<i32>() } as u32;
        }
    }

    /// The bin of one value (see [`Bins::indices`]).
    fn index(&self, v: f64) -> usize {
        let mut out = [0];
        self.indices(&[v], &mut out);
        out[0] as usize
    }
}

/// Index of the bin of `v` (values outside, or not finite, go to the nearest end bin).
#[cfg(test)]
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

    /// The vectorised bins are the scalar division's, at and next to every edge and at random
    /// values, for nice widths that are not powers of two.
    #[test]
    fn bins_are_the_division_s() {
        for range in [
            [0.0, 99.0],
            [-3.7, 512.3],
            [1e-3, 7.9e-3],
            [800.0, 6500.0],
            [-250.0, 180.0],
        ] {
            let e = nice_edges(range);
            let bins = Bins::new(&e);
            let mut probes: Vec<f64> =
                vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -1e300, 1e300];
            for &x in &e {
                probes.extend([x, x.next_up(), x.next_down()]);
            }
            let mut r: u64 = 12345;
            for _ in 0..20_000 {
                r = r
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let f = (r >> 11) as f64 / (1u64 << 53) as f64;
                probes.push(range[0] - 1.0 + f * (range[1] - range[0] + 2.0));
            }
            for v in probes {
                assert_eq!(bins.index(v), bin(&e, v), "v = {v}, edges {e:?}");
            }
        }
    }

    /// The histogram holds dt per sample and dt/2 at the two ends, in the samples' bins.
    #[test]
    fn histogram_counts_the_samples() {
        let info = ModelInfo {
            outputs: ["n_e", "T_e"]
                .map(|name| invsim_model_api::OutputInfo {
                    name: name.into(),
                    ..Default::default()
                })
                .to_vec(),
            engine: Some(EngineInfo {
                speed: 0,
                torque: 1,
                map: None,
            }),
            ..ModelInfo::default()
        };
        let mut tally = OperatingPointTally::new(&info, 8).unwrap();
        let w = [1000.0, 1000.0, 3000.0, 1000.0, 3000.0, 3000.0];
        let t = [50.0, 50.0, 50.0, 150.0, 50.0, 50.0];
        let mut cols = [w.to_vec(), t.to_vec()];
        let views: Vec<&mut [f64]> = cols.iter_mut().map(|c| &mut c[..]).collect();
        tally.extend(&views, 0..6);
        let op = tally.finish(&info, 0.5);
        let at = |w: f64, t: f64| {
            let (bw, bt) = (Bins::new(&op.speed_edges), Bins::new(&op.torque_edges));
            op.time_s[bw.index(w)][bt.index(t)]
        };
        // (1000, 50): samples 0 (an end) and 1; (3000, 50): 2, 4 and 5 (an end); (1000, 150): 3.
        assert_eq!(at(1000.0, 50.0), 0.75);
        assert_eq!(at(3000.0, 50.0), 1.25);
        assert_eq!(at(1000.0, 150.0), 0.5);
        assert_eq!(op.total_time_s, 2.5);
    }

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
