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
//! `y_d = y_c` exactly wherever the cycle is linear on `[t − a, t + a]` (the paper's "exact tracking at
//! distance a from corners"). [`Smoother::new`] precomputes the corners and slope changes (dropping zero
//! changes); [`Smoother::eval`] costs a binary search plus work proportional to the number of corners
//! within `±a`. Nothing is differenced numerically: `K` and `R` come from the kernel's tables (accurate to
//! about 10⁻¹⁶ relative to `a`), the derivatives from its closed form.

use crate::cycle::{interpolate, Cycle, CycleError};
use crate::kernel::Kernel;

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
    /// The cycle's samples, for `y_c(t)` itself.
    time: Vec<f64>,
    speed: Vec<f64>,
    /// Corner times `t_j` (increasing), slope changes `Δs_j ≠ 0` and the slope just after each corner.
    corners: Vec<f64>,
    jumps: Vec<f64>,
    slope_after: Vec<f64>,
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
        let time = cycle.time.clone();
        let speed = cycle.speed.clone();
        let n = time.len();
        // s_i = slope on [t_i, t_{i+1}]; 0 after the last sample (the cycle is held there).
        let slope = |i: usize| {
            if i + 1 < n {
                (speed[i + 1] - speed[i]) / (time[i + 1] - time[i])
            } else {
                0.0
            }
        };
        let mut corners = Vec::new();
        let mut jumps = Vec::new();
        let mut slope_after = Vec::new();
        let mut before = 0.0;
        for (i, &t) in time.iter().enumerate() {
            let after = slope(i);
            let jump = after - before;
            if jump != 0.0 {
                corners.push(t);
                jumps.push(jump);
                slope_after.push(after);
            }
            before = after;
        }
        Ok(Smoother {
            kernel: Kernel::new(lookahead),
            time,
            speed,
            corners,
            jumps,
            slope_after,
        })
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

    /// Time span `[first, last]` over which `y_d` differs from a constant: the cycle widened by `a`.
    pub fn support(&self) -> (f64, f64) {
        let a = self.lookahead();
        match (self.corners.first(), self.corners.last()) {
            (Some(&first), Some(&last)) => (first - a, last + a),
            _ => (self.time[0], self.time[self.time.len() - 1]),
        }
    }

    /// Writes `out[n] = y_d^(n)(t)` for `n = 0..out.len()`: the smoothed speed (m/s), acceleration (m/s²),
    /// jerk, … Any length is accepted (orders up to 34 use tabulated kernel polynomials). Outside the
    /// cycle, `y_d` tends to the held first/last speed; NaN `t` gives NaN.
    pub fn eval(&self, t: f64, out: &mut [f64]) {
        let Some((value, higher)) = out.split_first_mut() else {
            return;
        };
        if t.is_nan() {
            *value = f64::NAN;
            higher.fill(f64::NAN);
            return;
        }
        let a = self.kernel.half_width();
        // Corners with |t − t_j| < a: a binary search for the first, then a scan.
        let lo = self.corners.partition_point(|&c| c <= t - a);
        let hi = lo + self.corners[lo..].iter().take_while(|&&c| c < t + a).count();

        let mut y = interpolate(&self.time, &self.speed, t);
        let mut dy = if lo == 0 { 0.0 } else { self.slope_after[lo - 1] };
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
