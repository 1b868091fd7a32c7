//! The drive-cycle smoother of Fröberg & Nielsen (2004), eq. 33–35: the desired output `y_d = k * y_c` and
//! its derivatives of any order, exact for a piecewise-linear cycle and computed from the cycle's corners.
//!
//! # The mathematics
//!
//! The paper makes the cycle `y_c` as smooth as the inversion needs by convolving it with the normalised
//! C-infinity kernel `k = g/C` of half-width `a` (eq. 33–35, see [`crate::kernel`]):
//!
//! ```text
//! y_d(t) = ∫ k(t − τ) y_c(τ) dτ,        y_d^(n)(t) = ∫ k^(n)(t − τ) y_c(τ) dτ.
//! ```
//!
//! Held constant outside its range, a cycle with samples `(t_i, v_i)` is
//!
//! ```text
//! y_c(τ) = v_0 + Σ_j Δs_j (τ − t_j)₊,    Δs_j = s_j − s_{j−1}   (slope change at corner t_j),
//! ```
//!
//! with `s_j` the slope on `[t_j, t_{j+1}]` and `s = 0` before the first and after the last sample. Because
//! `∫ k = 1`, the kernel is even and `∫ k(σ)(u − σ)₊ dσ = R(u) = u K(u) − M(u)` (the smoothed ramp, with
//! `K(u) = ∫_{−a}^{u} k` and `M(u) = ∫_{−a}^{u} σ k(σ) dσ`), convolution gives
//!
//! ```text
//! y_d(t)     = y_c(t) + Σ_{|t − t_j| < a} Δs_j [R(t − t_j) − (t − t_j)₊]      (R(u) − u₊ = R(−|u|))
//! y_d'(t)    = Σ_j Δs_j K(t − t_j) = s(t − a) + Σ_{|t − t_j| < a} Δs_j K(t − t_j)
//! y_d^(n)(t) = Σ_{|t − t_j| < a} Δs_j k^(n−2)(t − t_j)                          (n ≥ 2)
//! ```
//!
//! where `s(t − a)` is the cycle's slope just after `t − a`. Only corners within `±a` of `t` contribute, so
//! `y_d = y_c` exactly wherever the cycle is linear on `[t − a, t + a]`: as the paper notes, tracking is
//! exact already at distance `a` from the corners.
//!
//! [`Smoother::new`] precomputes the corners and slope changes (dropping zero changes) and a bucket index
//! over the corners; [`Smoother::eval`] costs an O(1) look-up (a binary search within one bucket) plus work
//! proportional to the number of corners within `±a`. `y_c(t)` itself is the line through the last corner
//! at or before `t`. Nothing is differenced numerically: `K` comes from the kernel's tables (about 10⁻¹⁶
//! absolute), `R` likewise (about 10⁻¹⁶·a), the derivatives from the kernel's closed form.

mod convolve;
mod fine;
mod grid;
mod signals;

pub use fine::ZeroDynamicsReference;
pub(crate) use fine::{FineReference, FineTable};

use crate::cycle::{Cycle, CycleError};
use crate::kernel::Kernel;
use invsim_model_api::ReferenceMap;

/// Errors from [`Smoother::new`].
#[derive(Debug, thiserror::Error)]
pub enum SmootherError {
    /// The look-ahead time is zero, negative, infinite or NaN.
    #[error("look-ahead time {0} s is not valid; expected a finite number of seconds > 0")]
    InvalidLookahead(f64),
    /// The cycle breaks the invariants of [`Cycle`] (only possible for cycles built by hand).
    #[error("cannot smooth the cycle: {0}")]
    InvalidCycle(#[from] CycleError),
}

/// The smoothed drive cycle `y_d` and its derivatives (eq. 33–35).
#[derive(Debug, Clone)]
pub struct Smoother {
    kernel: Kernel,
    /// `y_c` before the first corner (the cycle's first speed).
    first_value: f64,
    /// Corner times `t_j` (strictly increasing), slope changes `Δs_j ≠ 0`, and the cycle's value and
    /// slope just after each corner, from which `y_c(t) = y_c(t_j) + s_j (t − t_j)` up to the next corner.
    corners: Vec<f64>,
    jumps: Vec<f64>,
    value_at: Vec<f64>,
    slope_after: Vec<f64>,
    /// Bucket index over the corners: `bucket_start[b]` is the first corner at or after
    /// `origin + b / inv_width`, so a look-up is O(1) plus a search inside one bucket.
    origin: f64,
    inv_width: f64,
    bucket_start: Vec<usize>,
    /// The output's reference map y_d = offset + scale · (k * y_c) (identity unless
    /// [`Smoother::with_reference`] set one).
    reference: ReferenceMap,
    /// Tables of the corners' kernel terms on the grids [`Smoother::eval_grid`] has seen.
    grid_cache: grid::GridCache,
    /// The model's exogenous signals, smoothed with the same kernel (see `smoother/signals.rs`); empty
    /// for a model without signals.
    signals: Vec<Smoother>,
}

impl Smoother {
    /// Prepares the smoother for `cycle` with look-ahead (kernel half-width) `lookahead = a` seconds.
    ///
    /// Fails if `a` is not finite and positive, or if the cycle breaks its invariants ([`Cycle::validate`]).
    pub fn new(cycle: &Cycle, lookahead: f64) -> Result<Smoother, SmootherError> {
        if !(lookahead.is_finite() && lookahead > 0.0) {
            return Err(SmootherError::InvalidLookahead(lookahead));
        }
        cycle.validate()?;
        Ok(Smoother::from_samples(&cycle.time, &cycle.speed, lookahead))
    }

    /// The smoother of any piecewise-linear signal with samples (`time`, `values`) (time strictly increasing,
    /// at least one sample, every value finite: the caller has checked), held constant outside its span.
    pub(crate) fn from_samples(time: &[f64], speed: &[f64], lookahead: f64) -> Smoother {
        let n = time.len().min(speed.len());
        // s_i = slope on [t_i, t_{i+1}] (one vectorised pass); 0 after the last sample (the cycle is held
        // there).
        let mut slopes: Vec<f64> = time[..n]
            .windows(2)
            .zip(speed[..n].windows(2))
            .map(|(t, v)| (v[1] - v[0]) / (t[1] - t[0]))
            .collect();
        slopes.push(0.0);
        // Every sample is a corner but where the slope runs on unchanged; the slopes' changes, values and
        // slopes of the corners are written in place and the lengths cut to the corners kept.
        let (mut corners, mut jumps) = (vec![0.0; n], vec![0.0; n]);
        let (mut value_at, mut slope_after) = (vec![0.0; n], vec![0.0; n]);
        let mut kept = 0;
        let mut before = 0.0;
        for ((&t, &v), &after) in time[..n].iter().zip(&speed[..n]).zip(&slopes) {
            let jump = after - before;
            corners[kept] = t;
            jumps[kept] = jump;
            // + 0.0: −0 becomes +0, so that no sum of the grid evaluation starts at −0 (see
            // `convolve.rs`), the same number otherwise.
            value_at[kept] = v + 0.0;
            slope_after[kept] = after + 0.0;
            kept += usize::from(jump != 0.0);
            before = after;
        }
        for column in [&mut corners, &mut jumps, &mut value_at, &mut slope_after] {
            column.truncate(kept);
        }
        // About two buckets per corner.
        let (origin, span) = match (corners.first(), corners.last()) {
            (Some(&first), Some(&last)) => (first, last - first),
            _ => (0.0, 0.0),
        };
        let width = if span > 0.0 {
            span / (2 * corners.len()) as f64
        } else {
            1.0
        };
        let buckets = (span / width) as usize + 2;
        // bucket_start[b] = the number of corners before origin + b·width: one walk along the sorted corners
        // (the edges increase with b).
        let mut below = 0;
        let bucket_start = (0..=buckets)
            .map(|b| {
                let edge = origin + b as f64 * width;
                while below < corners.len() && corners[below] < edge {
                    below += 1;
                }
                below
            })
            .collect();
        Smoother {
            kernel: Kernel::new(lookahead),
            first_value: speed[0] + 0.0,
            corners,
            jumps,
            value_at,
            slope_after,
            origin,
            inv_width: 1.0 / width,
            bucket_start,
            reference: ReferenceMap::IDENTITY,
            grid_cache: grid::GridCache::default(),
            signals: Vec::new(),
        }
    }

    /// The same smoother delivering the reference of an output that is not the cycle's speed itself:
    /// y_d = offset + scale · (k * y_c), y_d^(n) = scale · (k * y_c)^(n) for n ≥ 1 (exact, like the rest).
    pub fn with_reference(mut self, reference: ReferenceMap) -> Smoother {
        self.reference = reference;
        self
    }

    /// The reference map in use (the identity by default).
    pub fn reference(&self) -> ReferenceMap {
        self.reference
    }

    /// Apply the reference map to y_d, y_d', … in `out` (nothing to do for the identity).
    #[inline]
    fn map_reference(&self, out: &mut [f64]) {
        if self.reference.is_identity() {
            return;
        }
        let ReferenceMap { offset, scale } = self.reference;
        if let Some((y, rest)) = out.split_first_mut() {
            *y = offset + scale * *y;
            for d in rest {
                *d *= scale;
            }
        }
    }

    /// Index of the first corner after `x` (`t_j > x`).
    #[inline]
    fn first_corner_after(&self, x: f64) -> usize {
        let n = self.corners.len();
        let pos = (x - self.origin) * self.inv_width;
        if pos.is_nan() || pos < 0.0 {
            return 0; // x before every corner
        }
        // Truncation is the intended floor; the float-to-int cast saturates for huge x.
        let b = (pos as usize).min(self.bucket_start.len() - 2);
        let (lo, hi) = (self.bucket_start[b], self.bucket_start[b + 1]);
        let mut i = lo + self.corners[lo..hi].partition_point(|&c| c <= x);
        // Rounding in the bucket index can be off by one bucket: settle the boundary exactly.
        while i > 0 && self.corners[i - 1] > x {
            i -= 1;
        }
        while i < n && self.corners[i] <= x {
            i += 1;
        }
        i
    }

    /// The look-ahead time `a` (kernel half-width) in seconds.
    pub fn lookahead(&self) -> f64 {
        self.kernel.half_width()
    }

    /// The kernel used.
    pub fn kernel(&self) -> &Kernel {
        &self.kernel
    }

    /// Corner times `t_j` of the cycle (where the slope changes, including its first and last sample when
    /// the speed is not flat there) and the slope changes `Δs_j` (m/s²).
    pub fn corners(&self) -> (&[f64], &[f64]) {
        (&self.corners, &self.jumps)
    }

    /// Whether it is a constant (no corner: a signal left at its default), the same value and zero
    /// derivatives at every time.
    pub(crate) fn is_constant(&self) -> bool {
        self.corners.is_empty()
    }

    /// Whether `y_d` and every smoothed signal are constant on [t0, t1]: no corner within the kernel's reach
    /// (t0 − a, t1 + a) and a flat stretch there (`y_d = y_c` wherever the cycle is linear on [t − a, t + a];
    /// see the module docs), so every derivative is exactly 0 there.
    pub(crate) fn still_on(&self, t0: f64, t1: f64) -> bool {
        let a = self.lookahead();
        let i = self.corners.partition_point(|&c| c <= t0 - a);
        self.still_after(i, t0, t1)
    }

    /// [`Smoother::still_on`] with the first corner past t0 − a found by a walk from `hint` (where the last
    /// call found it; updated): the zero dynamics ask interval after interval, a corner or two apart.
    pub(crate) fn still_on_from(&self, hint: &mut usize, t0: f64, t1: f64) -> bool {
        let (a, corners) = (self.lookahead(), &self.corners);
        let mut i = (*hint).min(corners.len());
        while i > 0 && corners[i - 1] > t0 - a {
            i -= 1;
        }
        while i < corners.len() && corners[i] <= t0 - a {
            i += 1;
        }
        *hint = i;
        self.still_after(i, t0, t1)
    }

    /// [`Smoother::still_on`] where corner i is the first past t0 − a.
    fn still_after(&self, i: usize, t0: f64, t1: f64) -> bool {
        let a = self.lookahead();
        let none_within = self.corners.get(i).is_none_or(|&c| c >= t1 + a);
        let slope = if i == 0 { 0.0 } else { self.slope_after[i - 1] };
        none_within && slope == 0.0 && self.signals.iter().all(|s| s.still_on(t0, t1))
    }

    /// Time span outside which `y_d` is constant: from the first corner − `a` to the last corner + `a`
    /// (`None` for a constant cycle).
    pub fn support(&self) -> Option<(f64, f64)> {
        let a = self.lookahead();
        match (self.corners.first(), self.corners.last()) {
            (Some(&first), Some(&last)) => Some((first - a, last + a)),
            _ => None,
        }
    }

    /// Writes `out[n] = y_d^(n)(t)` for `n = 0..out.len()`: the smoothed speed (m/s), acceleration (m/s²),
    /// jerk, … Outside the cycle `y_d` tends to the held first/last speed; NaN `t` gives NaN.
    ///
    /// Any length is accepted. `y_d` and `y_d'` are accurate to rounding; `y_d^(n)` for `n ≥ 2` inherits
    /// the accuracy of `k^(n−2)` (see [`Kernel::derivative`]: about 10⁻¹³ of the peak value at `n = 10`).
    pub fn eval(&self, t: f64, out: &mut [f64]) {
        let Some((value, higher)) = out.split_first_mut() else {
            return;
        };
        if t.is_nan() {
            *value = f64::NAN;
            higher.fill(f64::NAN);
            return;
        }
        if self.corners.is_empty() {
            // A constant (a signal left at its default): the same numbers as the sums below, without them.
            *value = self.first_value;
            higher.fill(0.0);
            self.map_reference(out);
            return;
        }
        let a = self.kernel.half_width();
        // Corners with |t − t_j| < a: an O(1) bucket look-up for the first, then a scan that also finds
        // the last corner at or before t (for y_c).
        let lo = self.first_corner_after(t - a);
        let mut hi = lo;
        let mut last_passed = lo; // one past the last corner ≤ t
        while hi < self.corners.len() && self.corners[hi] < t + a {
            if self.corners[hi] <= t {
                last_passed = hi + 1;
            }
            hi += 1;
        }
        let mut y = match last_passed.checked_sub(1) {
            // (the slope after the last corner is 0; skipping it keeps y finite for t = ±∞)
            Some(i) if self.slope_after[i] == 0.0 => self.value_at[i],
            Some(i) => self.value_at[i] + self.slope_after[i] * (t - self.corners[i]),
            None => self.first_value,
        };
        let mut dy = if lo == 0 {
            0.0
        } else {
            self.slope_after[lo - 1]
        };
        let (first_derivative, derivs) = match higher.split_first_mut() {
            Some((d, rest)) => (Some(d), rest),
            None => (None, &mut [][..]),
        };
        derivs.fill(0.0);
        for j in lo..hi {
            let u = t - self.corners[j];
            let jump = self.jumps[j];
            let (k, r) = self.kernel.integral_and_ramp_offset(u);
            y += jump * r;
            dy += jump * k;
            self.kernel.add_derivatives(u, jump, derivs);
        }
        *value = y;
        if let Some(d) = first_derivative {
            *d = dy;
        }
        self.map_reference(out);
    }

    /// y_d and its derivatives on a whole grid of increasing times: `out[n][k] = y_d^(n)(times[k])` for
    /// n = 0 … out.len() − 1. Same values as [`Smoother::eval`] at each time (to rounding), computed corner
    /// by corner instead of time by time:
    ///
    /// ```text
    /// y_d(t)     = y_c(t) + Σ_{|u|<a} Δs_j [R(u) − u₊],   y_d'(t) = s(t) + Σ_{|u|<a} Δs_j [K(u) − H(u)],
    /// y_d^(n)(t) = Σ_{|u|<a} Δs_j k^(n−2)(u),             u = t − t_j,  H(u) = 1 for u ≥ 0,
    /// ```
    ///
    /// with s(t) the slope of the cycle at t. When `dt` is given and the grid is regular
    /// (`times[k] = times[0] + k·dt` to rounding), the kernel terms of every corner come from a table over
    /// ±a per phase of the corners on the grid (`(t_j − times[0])/dt` modulo 1: 0 for all corners of a 1 Hz
    /// cycle when dt divides 1 s), built once and kept for later calls on the same grid (a simulation
    /// evaluates its grid block by block); each corner then costs a few multiply-adds per sample of its
    /// window instead of a kernel evaluation. See `smoother/grid.rs`.
    pub fn eval_grid(&self, times: &[f64], dt: Option<f64>, out: &mut [&mut [f64]]) {
        if out.is_empty() || times.is_empty() {
            return;
        }
        for col in out.iter_mut() {
            assert!(
                col.len() >= times.len(),
                "output column shorter than the grid"
            );
        }
        let n = times.len();
        let mut cols: Vec<&mut [f64]> = out.iter_mut().map(|c| &mut c[..n]).collect();
        self.base_on_grid(times, &mut cols);
        grid::add_corners(
            &self.kernel,
            &self.grid_cache,
            (&self.corners, &self.jumps),
            times,
            dt,
            &mut cols,
        );
        if !self.reference.is_identity() {
            let ReferenceMap { offset, scale } = self.reference;
            for (n, col) in cols.iter_mut().enumerate() {
                for v in col.iter_mut() {
                    *v = if n == 0 {
                        offset + scale * *v
                    } else {
                        scale * *v
                    };
                }
            }
        }
    }

    /// `out[0][k] = y_c(times[k])`, `out[1][k] = s(times[k])` (the slope after the last corner at or before
    /// the time), higher orders 0: segment by segment between the corners along the increasing grid.
    fn base_on_grid(&self, times: &[f64], out: &mut [&mut [f64]]) {
        for col in out.iter_mut().skip(2) {
            col.fill(0.0);
        }
        let next = self.corners.partition_point(|&c| c <= times[0]);
        let t_end = times[times.len() - 1];
        if 4 * (self.corners.partition_point(|&c| c <= t_end) - next) >= times.len() {
            self.base_by_sample(times, next, out);
        } else {
            self.base_by_segment(times, next, out);
        }
    }

    /// Orders 0 and 1 of [`Self::base_on_grid`] segment by segment between the corners (`next` the number of
    /// corners at or before `times[0]`).
    fn base_by_segment(&self, times: &[f64], mut next: usize, out: &mut [&mut [f64]]) {
        let orders = out.len();
        let mut k = 0;
        // corners[next − 1] ≤ t < corners[next] on the current segment
        while k < times.len() {
            let end = match self.corners.get(next) {
                Some(&c) => first_not_before(times, k, c),
                None => times.len(),
            };
            let (y, s) = (&mut out[0][k..end], k..end);
            match next.checked_sub(1) {
                Some(i) if self.slope_after[i] == 0.0 => {
                    y.fill(self.value_at[i]);
                }
                Some(i) => {
                    let (v, slope, tj) = (self.value_at[i], self.slope_after[i], self.corners[i]);
                    for (o, &t) in y.iter_mut().zip(&times[k..end]) {
                        *o = v + slope * (t - tj);
                    }
                }
                None => y.fill(self.first_value),
            }
            if orders > 1 {
                let slope = next.checked_sub(1).map_or(0.0, |i| self.slope_after[i]);
                out[1][s].fill(slope);
            }
            k = end;
            next += 1;
        }
    }

    /// [`Self::base_on_grid`] for corners about as many as the samples, whose segments are a sample or two
    /// long: sample by sample, merging the grid with the corners (`next` the number of corners at or before
    /// `times[0]`), the same numbers.
    fn base_by_sample(&self, times: &[f64], mut next: usize, out: &mut [&mut [f64]]) {
        let (y, rest) = out.split_at_mut(1);
        let (y, mut slope_col) = (&mut y[0][..times.len()], rest.first_mut());
        let c = &self.corners;
        for (k, (&t, y)) in times.iter().zip(y.iter_mut()).enumerate() {
            while next < c.len() && c[next] <= t {
                next += 1;
            }
            let (v, slope) = match next.checked_sub(1) {
                Some(i) if self.slope_after[i] == 0.0 => (self.value_at[i], self.slope_after[i]),
                Some(i) => {
                    let (v, slope, tj) = (self.value_at[i], self.slope_after[i], c[i]);
                    (v + slope * (t - tj), slope)
                }
                None => (self.first_value, 0.0),
            };
            *y = v;
            if let Some(s) = slope_col.as_mut() {
                s[k] = slope;
            }
        }
    }

    /// `y_d^(order)(t)` alone; see [`Smoother::eval`].
    pub fn derivative(&self, order: usize, t: f64) -> f64 {
        let mut buf = [0.0; 8];
        if order < buf.len() {
            self.eval(t, &mut buf[..=order]);
            buf[order]
        } else {
            let mut v = vec![0.0; order + 1];
            self.eval(t, &mut v);
            v[order]
        }
    }
}

/// The first index `i ≥ from` with `times[i] ≥ c` (`times.len()` if none), `times` increasing: the answer of
/// `from + times[from..].partition_point(|&t| t < c)`, found by galloping from `from` (spans 1, 2, 4, …) and
/// a binary search inside the span that holds it. The segments between corners are mostly a few samples
/// long, so this costs a few comparisons where a binary search over the rest of the grid costs log₂ n
/// dependent loads per segment.
fn first_not_before(times: &[f64], from: usize, c: f64) -> usize {
    let mut lo = from;
    let mut span = 1;
    while lo < times.len() {
        let hi = (lo + span).min(times.len());
        if times[hi - 1] >= c {
            return lo + times[lo..hi].partition_point(|&t| t < c);
        }
        // times[lo..hi] < c: the answer lies beyond.
        lo = hi;
        span *= 2;
    }
    lo
}

#[cfg(test)]
mod tests {
    use super::*;

    /// still_on: a stop, a ramp and a cruise with a = 5 s; where it says still, y_d and its derivatives are
    /// the same at every time of the interval (derivatives exactly 0), and a signal with a corner in reach
    /// makes the interval move.
    #[test]
    fn still_where_no_corner_is_in_reach_of_a_flat_stretch() {
        let (time, speed) = (
            [0.0, 20.0, 30.0, 60.0, 70.0, 100.0],
            [0.0, 0.0, 10.0, 10.0, 0.0, 0.0],
        );
        let s = Smoother::from_samples(&time, &speed, 5.0);
        for (t0, t1, still) in [
            (5.0, 10.0, true),
            (0.0, 15.0, true),
            (14.0, 16.0, false),
            (22.0, 23.0, false),
            (35.0, 55.0, true),
            (34.0, 36.0, false),
            (80.0, 100.0, true),
        ] {
            assert_eq!(s.still_on(t0, t1), still, "[{t0}, {t1}]");
            for mut hint in [0, 1, usize::MAX] {
                assert_eq!(
                    s.still_on_from(&mut hint, t0, t1),
                    still,
                    "[{t0}, {t1}] from {hint}"
                );
            }
            if still {
                let (mut first, mut other) = ([0.0; 4], [0.0; 4]);
                s.eval(t0, &mut first);
                for k in 1..=10 {
                    s.eval(t0 + (t1 - t0) * k as f64 / 10.0, &mut other);
                    assert_eq!(first, other, "[{t0}, {t1}]");
                }
                assert_eq!(&first[1..], &[0.0; 3]);
            }
        }
        let grade = Smoother::from_samples(&[0.0, 12.0, 100.0], &[0.0, 0.0, 0.05], 5.0);
        let with = Smoother::from_samples(&time, &speed, 5.0).with_signals(vec![grade]);
        assert!(
            !with.still_on(5.0, 10.0),
            "the signal's corner at 12 s is in reach"
        );
        assert!(with.still_on(0.0, 6.0));
    }

    /// The bucket look-up agrees with a plain binary search everywhere, including at and next to every
    /// corner and every bucket boundary, where rounding of the bucket index matters.
    #[test]
    fn bucket_lookup_matches_binary_search() {
        let mut time = vec![10.0];
        let mut speed = vec![0.0];
        // Irregular spacing: clusters of close samples and long gaps, alternating slopes.
        let mut t: f64 = 10.0;
        for i in 1..400 {
            t += match i % 7 {
                0 => 37.3,
                1 | 2 => 1e-3,
                3 => 0.1,
                _ => 1.7,
            };
            time.push(t);
            speed.push(((i * 37) % 11) as f64);
        }
        let cycle = Cycle {
            tolerance: crate::cycle::Tolerance::EPA,
            name: "irregular".into(),
            time,
            speed,
            grade: None,
            columns: Vec::new(),
        };
        let s = Smoother::new(&cycle, 1.0).unwrap();
        let width = 1.0 / s.inv_width;
        let mut probes: Vec<f64> = vec![-1e300, -1.0, 1e300, f64::INFINITY, f64::NEG_INFINITY];
        let boundaries = (0..s.bucket_start.len()).map(|b| s.origin + b as f64 * width);
        for x in s.corners.iter().copied().chain(boundaries) {
            // neighbouring doubles (all probes here are positive and finite)
            let up = f64::from_bits(x.to_bits() + 1);
            let down = f64::from_bits(x.to_bits() - 1);
            probes.extend([x, up, down, x + 1e-9, x - 1e-9]);
        }
        for x in probes {
            let expected = s.corners.partition_point(|&c| c <= x);
            assert_eq!(s.first_corner_after(x), expected, "x = {x}");
        }
    }

    /// The galloping search gives the binary search's index for every start and every probe: before, at,
    /// between and after the samples, with runs of equal samples.
    #[test]
    fn gallop_matches_partition_point() {
        let times: Vec<f64> = (0..300)
            .map(|i| (i / 3) as f64 + if i % 5 == 0 { 0.25 } else { 0.0 })
            .scan(f64::NEG_INFINITY, |last, t: f64| {
                *last = t.max(*last);
                Some(*last)
            })
            .collect();
        let probes = (-4..420).map(|i| i as f64 * 0.25 - 1.0);
        for c in probes {
            for from in 0..=times.len() {
                let expected = from + times[from..].partition_point(|&t| t < c);
                assert_eq!(
                    first_not_before(&times, from, c),
                    expected,
                    "c = {c}, from = {from}"
                );
            }
        }
    }

    /// The grid evaluation of `s` on `times` (step `h`) in blocks of `block` samples, `orders` orders.
    fn on_grid(s: &Smoother, times: &[f64], h: f64, orders: usize, block: usize) -> Vec<Vec<f64>> {
        let mut cols = vec![vec![0.0; times.len()]; orders];
        for (b, chunk) in times.chunks(block).enumerate() {
            let mut views: Vec<&mut [f64]> = cols
                .iter_mut()
                .map(|c| &mut c[b * block..b * block + chunk.len()])
                .collect();
            s.eval_grid(chunk, Some(h), &mut views);
        }
        cols
    }

    /// Corners filling the grid (a 1 Hz cycle on a 1 s grid, phase 0 or ½) go through the convolution of
    /// `convolve.rs` on a whole grid and through the corner-by-corner scatter on blocks too short for it
    /// (15 samples): the two agree bit for bit in every order, and with the sample-by-sample evaluation to
    /// rounding.
    #[test]
    fn convolution_is_the_scatter_bit_for_bit() {
        let udds = Cycle::builtin("udds").unwrap();
        let half = Cycle {
            name: "udds shifted by half a step".into(),
            time: udds.time.iter().map(|t| t + 0.5).collect(),
            ..udds.clone()
        };
        // Samples 0.1 s apart as i·0.1 on a grid of k/10: the two roundings differ, so the first-order
        // corrections of the highest orders are not zero.
        let tenth = Cycle {
            name: "10 Hz".into(),
            time: (0..600).map(|i| i as f64 * 0.1).collect(),
            speed: (0..600).map(|i| ((i * 37) % 23) as f64 * 0.5).collect(),
            ..udds.clone()
        };
        let cases = [
            (&udds, 5.0, 1.0),
            (&udds, 1.0, 1.0),
            (&half, 2.0, 1.0),
            (&udds, 0.7, 1.0),
            (&tenth, 0.5, 0.1),
        ];
        for (cycle, lookahead, h) in cases {
            let s = Smoother::new(cycle, lookahead).unwrap();
            let times: Vec<f64> = (0..1400).map(|k| (k as f64 - 10.0) * h).collect();
            let times: Vec<f64> = if h == 0.1 {
                (0..640).map(|k| (k as f64 - 20.0) / 10.0).collect()
            } else {
                times
            };
            let orders = 5;
            let whole = on_grid(&s, &times, h, orders, 4096);
            let blocks = on_grid(&s, &times, h, orders, 15);
            for n in 0..orders {
                for (k, (a, b)) in whole[n].iter().zip(&blocks[n]).enumerate() {
                    assert_eq!(
                        a.to_bits(),
                        b.to_bits(),
                        "order {n}, t = {}: {a} vs {b}",
                        times[k]
                    );
                }
            }
            let mut y = vec![0.0; orders];
            for (k, &t) in times.iter().enumerate().step_by(7) {
                s.eval(t, &mut y);
                for n in 0..orders {
                    let scale = 1.0 + y[n].abs();
                    assert!(
                        (whole[n][k] - y[n]).abs() <= 1e-9 * scale,
                        "order {n}, t = {t}"
                    );
                }
            }
        }
    }

    /// The base sample by sample and segment by segment: the same numbers, on grids finer and coarser than
    /// the corners and shifted against them.
    #[test]
    fn base_by_sample_is_base_by_segment() {
        let udds = Cycle::builtin("udds").unwrap();
        let s = Smoother::new(&udds, 2.0).unwrap();
        for (h, shift) in [
            (1.0, 0.0),
            (0.5, 0.25),
            (3.0, 0.1),
            (0.1, 0.0),
            (1.0, -20.0),
        ] {
            let times: Vec<f64> = (0..1500).map(|k| k as f64 * h + shift).collect();
            let next = s.corners.partition_point(|&c| c <= times[0]);
            let mut a = vec![vec![0.0; times.len()]; 2];
            let mut b = a.clone();
            let mut va: Vec<&mut [f64]> = a.iter_mut().map(|c| &mut c[..]).collect();
            let mut vb: Vec<&mut [f64]> = b.iter_mut().map(|c| &mut c[..]).collect();
            s.base_by_sample(&times, next, &mut va);
            s.base_by_segment(&times, next, &mut vb);
            for (ca, cb) in a.iter().zip(&b) {
                for (x, y) in ca.iter().zip(cb) {
                    assert_eq!(x.to_bits(), y.to_bits(), "h = {h}");
                }
            }
        }
    }

    /// On a 1 Hz cycle and a grid whose step divides 1 s every corner has phase 0: the whole grid, block by
    /// block, uses one table; a corner phase of its own adds one.
    #[test]
    fn one_table_per_phase() {
        let nedc = Cycle::builtin("nedc").unwrap();
        let s = Smoother::new(&nedc, 5.0).unwrap();
        let times: Vec<f64> = (0..11_801).map(|k| k as f64 / 10.0).collect();
        let mut cols = vec![vec![0.0; 4096]; 3];
        for block in times.chunks(4096) {
            let mut views: Vec<&mut [f64]> =
                cols.iter_mut().map(|c| &mut c[..block.len()]).collect();
            s.eval_grid(block, Some(0.1), &mut views);
        }
        assert_eq!(s.grid_cache.len(), 1);
        let shifted: Vec<f64> = times.iter().map(|t| t + 0.05).collect();
        let mut views: Vec<&mut [f64]> = cols.iter_mut().map(|c| &mut c[..4096]).collect();
        s.eval_grid(&shifted[..4096], Some(0.1), &mut views);
        assert_eq!(s.grid_cache.len(), 2);
    }
}
