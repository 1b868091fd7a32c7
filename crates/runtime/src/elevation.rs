//! Road grade from elevation over distance (issue 10, Deliver 1): a route profile h(s), elevation over the
//! distance travelled along the road, turned into the grade signal along the distance the run drives.
//!
//! # The computation
//!
//! A profile gives nodes (s_k, h_k), distance strictly increasing. Between them h is the cubic Hermite
//! interpolant whose node slopes are the three-point derivatives (exact for a quadratic profile)
//!
//! ```text
//! σ_k = (d₊ c₋ + d₋ c₊)/(d₋ + d₊),   c₋ = (h_k − h_(k−1))/d₋,  c₊ = (h_(k+1) − h_k)/d₊,  d∓ the segment lengths,
//! ```
//!
//! (second-order one-sided at the ends), so dh/ds is continuous and exact for a straight or parabolic profile.
//! Beyond the profile's ends the road is flat (the elevation held, as a signal holds its end values).
//!
//! s is the distance along the road (what an odometer, or ∫ v dt, measures), so dh/ds = sin θ for the road
//! angle θ, and the grade, rise over run as the models and FASTSim take it (`models/si_engine_grade.toml`
//! climbs against m g sin θ with θ = atan(grade)), is
//!
//! ```text
//! grade(t) = tan θ = σ/√(1 − σ²),   σ = dh/ds at s(t) = ∫_(t0)^t y_d dτ,
//! ```
//!
//! with y_d the smoothed reference speed (the kernel and look-ahead of the run, [`Along::Smoothed`]): the
//! distance the inverse actually drives, so the grade is consistent with the speed it tracks and the climb
//! work is m g Δh exactly. The forward simulation, which follows the raw cycle, reads the profile along the raw
//! cycle's distance ([`Along::Cycle`]). s(t) is integrated by Simpson's rule on a grid of
//! [`GRADE_SAMPLE_STEP`]; the grade is sampled on that grid and is then a raw signal like any other (linear
//! between its samples, smoothed with the reference's kernel). |σ| ≥ 1 (steeper than vertical) is an error.

use crate::cycle::Cycle;
use crate::smoother::Smoother;

/// Spacing of the grade samples (and of the distance quadrature), s.
pub const GRADE_SAMPLE_STEP: f64 = 0.1;

/// Cycle columns that give elevation over the cycle's time, with their factor to metres.
pub const ELEVATION_COLUMNS: &[(&str, f64)] = &[("elevation_m", 1.0), ("elevation_ft", 0.3048)];

/// A route profile: elevation (m) over distance along the road (m), distance strictly increasing.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    pub distance: Vec<f64>,
    pub elevation: Vec<f64>,
}

/// Along which distance a route profile is read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Along {
    /// The raw cycle's distance (the forward simulation).
    Cycle,
    /// The distance of the cycle smoothed with the kernel of half-width `lookahead` (the inverse).
    Smoothed { lookahead: f64 },
}

/// A profile steeper than vertical: |dh/ds| ≥ 1 at `distance`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "the elevation rises by {slope} m per metre travelled at {distance} m along the route; a road's \
     elevation changes by less than the distance travelled (|dh/ds| < 1; check the units)"
)]
pub struct TooSteep {
    pub distance: f64,
    pub slope: f64,
}

impl Route {
    /// The profile of a cycle's elevation samples (m, one per sample): the nodes sit at the cycle's own
    /// distance at each sample (the exact integral of its piecewise-linear speed); while the cycle stands
    /// still (the same distance) the first elevation is kept.
    pub fn of_cycle(cycle: &Cycle, elevation: &[f64]) -> Route {
        let mut route = Route {
            distance: Vec::with_capacity(cycle.time.len()),
            elevation: Vec::with_capacity(cycle.time.len()),
        };
        let mut s = 0.0;
        for (i, &h) in elevation.iter().enumerate().take(cycle.time.len()) {
            if i > 0 {
                s += 0.5
                    * (cycle.speed[i - 1] + cycle.speed[i])
                    * (cycle.time[i] - cycle.time[i - 1]);
            }
            if route.distance.last().is_some_and(|&last| s <= last) {
                continue;
            }
            route.distance.push(s);
            route.elevation.push(h);
        }
        route
    }

    /// The node slopes σ_k (see the module documentation).
    fn node_slopes(&self) -> Vec<f64> {
        let (s, h) = (&self.distance, &self.elevation);
        let n = s.len();
        if n < 2 {
            return vec![0.0; n];
        }
        let chord: Vec<f64> = (0..n - 1)
            .map(|k| (h[k + 1] - h[k]) / (s[k + 1] - s[k]))
            .collect();
        let len = |k: usize| s[k + 1] - s[k];
        let mut sigma = Vec::with_capacity(n);
        if n == 2 {
            return vec![chord[0]; 2];
        }
        // One-sided, second order: σ_0 = c_0 + (c_0 − c_1)·d_0/(d_0 + d_1), likewise at the end.
        sigma.push(chord[0] + (chord[0] - chord[1]) * len(0) / (len(0) + len(1)));
        for k in 1..n - 1 {
            let (dm, dp) = (len(k - 1), len(k));
            sigma.push((dp * chord[k - 1] + dm * chord[k]) / (dm + dp));
        }
        let (a, b) = (n - 2, n - 3);
        sigma.push(chord[a] + (chord[a] - chord[b]) * len(a) / (len(a) + len(b)));
        sigma
    }

    /// dh/ds at distance `s`: the derivative of the cubic Hermite interpolant; 0 beyond the ends (a
    /// distance within 1e-9 of the profile's length of an end, the quadrature's rounding, is at the end).
    fn slope_at(&self, sigma: &[f64], s: f64) -> f64 {
        let d = &self.distance;
        let n = d.len();
        if n < 2 {
            return 0.0;
        }
        let tol = 1e-9 * (d[n - 1] - d[0]);
        if !(s >= d[0] - tol && s <= d[n - 1] + tol) {
            return 0.0;
        }
        let s = s.clamp(d[0], d[n - 1]);
        let k = d.partition_point(|&x| x <= s).clamp(1, n - 1) - 1;
        let len = d[k + 1] - d[k];
        let tau = (s - d[k]) / len;
        let (h0, h1) = (self.elevation[k], self.elevation[k + 1]);
        // p'(s) = [ (6τ² − 6τ)(h0 − h1)/len + (3τ² − 4τ + 1) σ0 + (3τ² − 2τ) σ1 ].
        (6.0 * tau * tau - 6.0 * tau) * (h0 - h1) / len
            + (3.0 * tau * tau - 4.0 * tau + 1.0) * sigma[k]
            + (3.0 * tau * tau - 2.0 * tau) * sigma[k + 1]
    }

    /// The grade samples (time, grade) over the cycle's span, read along `along` (module documentation).
    pub fn grade_over_time(
        &self,
        cycle: &Cycle,
        along: Along,
    ) -> Result<(Vec<f64>, Vec<f64>), TooSteep> {
        let (t0, t1) = (cycle.time[0], cycle.time[cycle.time.len() - 1]);
        let n = ((t1 - t0) / GRADE_SAMPLE_STEP).ceil().max(1.0) as usize;
        let time: Vec<f64> = (0..=n)
            .map(|j| t0 + (t1 - t0) * j as f64 / n as f64)
            .collect();
        let distance = match along {
            Along::Cycle => cycle_distance(cycle, &time),
            Along::Smoothed { lookahead } => {
                let smoother = Smoother::from_samples(&cycle.time, &cycle.speed, lookahead);
                distance_over(&time, |t| smoother.derivative(0, t))
            }
        };
        let sigma = self.node_slopes();
        let mut grade = Vec::with_capacity(time.len());
        for &s in &distance {
            let slope = self.slope_at(&sigma, s);
            if slope.abs() >= 1.0 || slope.is_nan() {
                return Err(TooSteep { distance: s, slope });
            }
            grade.push(slope / (1.0 - slope * slope).sqrt());
        }
        Ok((time, grade))
    }
}

/// The raw cycle's distance at the increasing `times` from its start: the exact integral of its
/// piecewise-linear speed, s(t) = s_i + (t − t_i)(v_i + v(t))/2 on [t_i, t_(i+1)].
fn cycle_distance(cycle: &Cycle, times: &[f64]) -> Vec<f64> {
    let (ct, cv) = (&cycle.time, &cycle.speed);
    let (mut i, mut s_i) = (0usize, 0.0);
    times
        .iter()
        .map(|&t| {
            while i + 1 < ct.len() && ct[i + 1] <= t {
                s_i += 0.5 * (cv[i] + cv[i + 1]) * (ct[i + 1] - ct[i]);
                i += 1;
            }
            let dt = (t - ct[i]).max(0.0);
            s_i + 0.5 * dt * (cv[i] + cycle.speed_at(t))
        })
        .collect()
}

/// s(t_j) = ∫_(t_0)^(t_j) v dt on the grid `time`, Simpson's rule on each interval (with its midpoint).
fn distance_over(time: &[f64], v: impl Fn(f64) -> f64) -> Vec<f64> {
    let mut s = Vec::with_capacity(time.len());
    let mut acc = 0.0;
    let mut prev = time.first().map(|&t| v(t)).unwrap_or(0.0);
    for (j, &t) in time.iter().enumerate() {
        if j > 0 {
            let h = t - time[j - 1];
            let (mid, end) = (v(time[j - 1] + 0.5 * h), v(t));
            acc += h / 6.0 * (prev + 4.0 * mid + end);
            prev = end;
        }
        s.push(acc);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parabola_has_exact_slopes_everywhere() {
        // h = 0.001 s² + 0.01 s on uneven nodes: dh/ds = 0.002 s + 0.01 exactly (Hermite with exact slopes).
        let distance = vec![0.0, 3.0, 10.0, 11.0, 30.0];
        let elevation = distance.iter().map(|s| 0.001 * s * s + 0.01 * s).collect();
        let route = Route {
            distance,
            elevation,
        };
        let sigma = route.node_slopes();
        for s in [0.0, 1.5, 4.0, 10.5, 29.0, 30.0] {
            let want = 0.002 * s + 0.01;
            assert!((route.slope_at(&sigma, s) - want).abs() < 1e-14, "s = {s}");
        }
        assert_eq!(route.slope_at(&sigma, 31.0), 0.0);
    }
}
