//! Forward simulation of the original model along a drive cycle, closed by a driver model: the counterpart
//! of the inverse simulation that Fröberg & Nielsen (IFAC AAC 2004, Section 6, Fig. 7) validate their method
//! against, and the baseline of their claim that forward simulation is much slower.
//!
//! The model x' = f(x) + g(x)u, y = h(x) (its generated `rhs` or the interpreter) is driven along the *raw*
//! cycle y_c(t) (piecewise linear, as the regulation defines it, not the smoothed y_d) by
//!
//! ```text
//! driver (PI, anti-windup):   e = y_c(t) − h(x),   a_req = y_c'(t) + K_p e + I
//!                             I' = K_i e + Δa / T_t,   T_t = K_p/K_i        (back-calculation)
//! engine management:          ν = Σ_j C(r−1, j) ω^(r−1−j) (ref_j − ξ_(j+2)),  ref_0 = a_req, ref_j>0 = 0
//!                             u = (ν − α(ξ, η)) / β(ξ, η),   (ξ, η) = ψ(x)   (paper eq. 26)
//! input bounds:               u_a = clamp(u, u_min, u_max) (--bounds enforce) or u_a = u (ignore)
//! vehicle:                    x' = f(x) + g(x) u_a
//! ```
//!
//! The driver is a PI controller on the error to the raw cycle speed with the cycle's slope as feed-forward
//! (optional); its output is an acceleration (torque) request, which the engine management realises with a
//! first-order response of bandwidth ω (for r = 2: d/dt ẏ = ω (a_req − ẏ)), computing the input from the
//! model's normal form as a torque-based engine controller computes the throttle from an inverse air-path
//! model. A PI controller acting on the air flow directly cannot work on this model: the engine is geared
//! rigidly to the wheels, so at standstill nothing pumps the intake manifold and the plant from ṁ_at to v is a
//! double integrator, for which the closed loop s³ + β K_p s + β K_i lacks the s² term and is unstable for
//! every gain (Routh). When the clipped input cannot deliver the request, the undelivered part
//! Δa = β (u_a − u)/ω^(r−1) drives the back-calculation (Åström & Hägglund, *Advanced PID Control*, 2006, §3.5).
//!
//! Defaults ([`DRIVER_KP`], [`DRIVER_KI`], [`RESPONSE_OMEGA`]): K_p = 2 1/s and K_i = 1 1/s² give the speed loop
//! s² + K_p s + K_i a double pole at −1 1/s; ω = 10 rad/s is ten times faster than the driver and as fast as
//! the intake manifold's own pumping dynamics (1.02 v 1/s) at 35 km/h. The gains are in output units (for
//! `si_engine`: (m/s²) per m/s and per m), so they suit any model whose output is a speed.
//!
//! With the bounds enforced the vehicle may fail to follow the cycle; like FASTSim, the run reports trace
//! misses: the samples where y leaves the band of the U.S. driving-schedule tolerance (40 CFR 86.115-78:
//! ±2 mph around the highest and lowest cycle speed within ±1 s).
//!
//! Integrator: the explicit Dormand–Prince 5(4) pair with dense output ([`Dopri5`]; Hairer, Nørsett & Wanner I,
//! §II.5–6), restarted at every breakpoint of the cycle (the closed loop is smooth in between), the output grid
//! served by dense output so that it does not limit the step size. The intake manifold's eigenvalue
//! −(s_i V_d i_t / (4π V_i r_w))·v is at most −35 1/s on the NEDC at the default V_i; it would make the model
//! stiff for small V_i. Measured on the NEDC at rtol = 1e-8, Dopri5 beats the L-stable Rosenbrock 2(3) method
//! ([`Rosenbrock23`], selectable) by a factor of 2–9 in steps even at V_i/100 with the bounds enforced: the
//! tolerance, not stability, limits the step, and there a 5th-order method wins. DOPRI5's stiffness estimate is
//! reported as the number of stability-limited steps.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use invsim_model_api::{InverseModel, ModelError};
use serde::Serialize;
use thiserror::Error;

use crate::cycle::Cycle;
use crate::ode::{Dopri5, OdeStats, Rosenbrock23, StepFailure};
use crate::report::{
    integral_tables, write_input_range, write_integrals, write_intervals, Intervals,
};
use crate::simulate::{equilibrium, fmt_sig, ZeroDynamicsWorkspace, MAX_SAMPLES};

/// One mile per hour in m/s.
pub const MPH: f64 = 0.447_04;
/// Default trace-miss speed tolerance: 2 mph (40 CFR 86.115-78), in the output's unit (m/s).
pub const TRACE_MISS_SPEED_TOL: f64 = 2.0 * MPH;
/// Default trace-miss time tolerance: 1 s (40 CFR 86.115-78).
pub const TRACE_MISS_TIME_TOL: f64 = 1.0;
/// Default proportional gain of the driver: 2 (m/s²)/(m/s), i.e. the request per unit of speed error.
pub const DRIVER_KP: f64 = 2.0;
/// Default integral gain of the driver: 1 (m/s²)/m. With K_p = 2 the speed loop s² + K_p s + K_i has a
/// double pole at −1 1/s (critically damped, a calm driver).
pub const DRIVER_KI: f64 = 1.0;
/// Default bandwidth ω of the engine management's response to the driver's request, rad/s (time constant
/// 0.1 s; the intake manifold's own time constant 1/(1.02 v) is 0.35 s at 10 km/h and 0.03 s at 120 km/h).
pub const RESPONSE_OMEGA: f64 = 10.0;

/// What the forward run does with the model's input bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Bounds {
    /// Use the driver's demand as it is, like the inverse simulation (bound violations are reported).
    Ignore,
    /// Clip the demand to the bounds (anti-windup active) and report where the vehicle misses the trace.
    Enforce,
}

impl Bounds {
    pub fn as_str(self) -> &'static str {
        match self {
            Bounds::Ignore => "ignore",
            Bounds::Enforce => "enforce",
        }
    }
}

/// The integration method of the forward run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Dormand–Prince 5(4) with dense output (the default).
    Dopri5,
    /// The L-stable Rosenbrock 2(3) method, for stiff models at loose tolerances.
    Rosenbrock23,
}

impl Method {
    pub fn as_str(self) -> &'static str {
        match self {
            Method::Dopri5 => "dopri5",
            Method::Rosenbrock23 => "rosenbrock23",
        }
    }
}

/// Options of [`forward`].
#[derive(Debug, Clone, PartialEq)]
pub struct ForwardOptions {
    /// Output step in seconds (default 0.1 s); the grid is that of the inverse simulation,
    /// t_k = t_0 + k·dt, k = 0 … round(duration/dt).
    pub dt: f64,
    /// Which implementation of the model is being driven (`"compiled"` or `"interpreted"`); only reported.
    pub engine: String,
    /// Proportional gain of the driver: request (output units/s) per unit of error (default [`DRIVER_KP`]).
    pub kp: f64,
    /// Integral gain of the driver: request (output units/s) per unit of error and second (default
    /// [`DRIVER_KI`]).
    pub ki: f64,
    /// Bandwidth ω of the engine management, rad/s (default [`RESPONSE_OMEGA`]).
    pub response: f64,
    /// Add the raw cycle's slope y_c' to the request (feed-forward; default true).
    pub feedforward: bool,
    /// Ignore (default) or enforce the model's input bounds.
    pub bounds: Bounds,
    /// Integration method (default [`Method::Dopri5`]).
    pub method: Method,
    /// Relative and absolute tolerances of the integrator (defaults 1e-8, 1e-10).
    pub rtol: f64,
    pub atol: f64,
    /// Initial state x(t_0); `None`: ψ⁻¹ of the raw cycle's start, (y_c, y_c', 0, …), with η at the
    /// equilibrium of the zero dynamics there.
    pub x0: Option<Vec<f64>>,
    /// Trace-miss band: ± this much around the cycle's extremes within ± `trace_time_tol` (defaults 2 mph, 1 s).
    pub trace_speed_tol: f64,
    pub trace_time_tol: f64,
    /// Keep the time series (default true); `false` computes every sample for the summary only.
    pub keep_series: bool,
}

impl Default for ForwardOptions {
    fn default() -> Self {
        ForwardOptions {
            dt: 0.1,
            engine: "compiled".to_string(),
            kp: DRIVER_KP,
            ki: DRIVER_KI,
            response: RESPONSE_OMEGA,
            feedforward: true,
            bounds: Bounds::Ignore,
            method: Method::Dopri5,
            rtol: 1e-8,
            atol: 1e-10,
            x0: None,
            trace_speed_tol: TRACE_MISS_SPEED_TOL,
            trace_time_tol: TRACE_MISS_TIME_TOL,
            keep_series: true,
        }
    }
}

/// Why a forward simulation could not be run or was stopped.
#[derive(Debug, Error)]
pub enum ForwardError {
    #[error("invalid output step dt = {0} s: it must be a positive, finite number of seconds")]
    InvalidDt(f64),
    #[error("invalid integrator tolerances rtol = {rtol}, atol = {atol}: both must be positive and finite")]
    InvalidTolerance { rtol: f64, atol: f64 },
    #[error(
        "invalid driver parameter {name} = {value}: it must be finite and ≥ 0 (the response > 0)"
    )]
    InvalidGain { name: &'static str, value: f64 },
    #[error(
        "invalid trace-miss tolerances {speed} (output units) and {time} s: both must be finite and ≥ 0"
    )]
    InvalidTraceTolerance { speed: f64, time: f64 },
    #[error("cannot simulate cycle `{cycle}`: {reason}")]
    InvalidCycle { cycle: String, reason: String },
    #[error(
        "{samples} output samples (duration {duration} s at dt = {dt} s) exceed the limit of {max}; use a larger \
         --dt"
    )]
    TooManySamples {
        samples: f64,
        duration: f64,
        dt: f64,
        max: usize,
    },
    #[error("invalid initial state x0: {reason}")]
    InvalidX0 { reason: String },
    #[error("cannot find the initial state at t0 = {t} s: {reason}; give x0 explicitly")]
    InitialState { t: f64, reason: String },
    #[error("the model failed at t = {t} s: {source}")]
    Model {
        t: f64,
        #[source]
        source: ModelError,
    },
    #[error("{quantity} is not finite ({value}) at t = {t} s")]
    NonFinite {
        t: f64,
        quantity: String,
        value: f64,
    },
    #[error("the forward integration failed at t = {t} s: {reason}")]
    Integration { t: f64, reason: String },
}

impl From<StepFailure> for ForwardError {
    fn from(f: StepFailure) -> Self {
        ForwardError::Integration {
            t: f.t,
            reason: f.reason,
        }
    }
}

/// The driver as run: gains, feed-forward, anti-windup.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DriverSummary {
    pub kp: f64,
    pub ki: f64,
    /// Bandwidth of the engine management's response, rad/s.
    pub response_rad_s: f64,
    pub feedforward: bool,
    /// Tracking time constant T_t of the back-calculation anti-windup, s (`None` without integral action).
    pub anti_windup_tracking_time_s: Option<f64>,
}

/// The integrator as run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IntegratorSummary {
    /// `dopri5` or `rosenbrock23`.
    pub method: Method,
    pub rtol: f64,
    pub atol: f64,
    #[serde(flatten)]
    pub stats: OdeStats,
}

/// What `invsim forward` prints and writes with `--summary-json`; the fields shared with
/// [`crate::Summary`] mean the same.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ForwardSummary {
    pub model: String,
    pub cycle: String,
    pub duration_s: f64,
    /// Distance of the raw cycle, m (the per-100-km figures use it, as the inverse simulation does).
    pub distance_m: f64,
    /// ∫ y dt over the run (the distance the vehicle drove, when y is its speed).
    pub distance_driven_m: f64,
    pub relative_degree: usize,
    pub engine: String,
    pub samples: usize,
    pub dt_s: f64,
    /// `ignore` or `enforce`.
    pub bounds: Bounds,
    pub driver: DriverSummary,
    pub integrator: IntegratorSummary,
    /// Accumulated output → its integral (trapezoidal rule on the output grid, as in the inverse simulation).
    pub integrals: BTreeMap<String, f64>,
    pub integrals_per_100km: BTreeMap<String, f64>,
    pub integral_units: BTreeMap<String, String>,
    pub input: String,
    /// Smallest and largest input applied.
    pub input_min: f64,
    pub input_max: f64,
    pub input_lower_bound: Option<f64>,
    pub input_upper_bound: Option<f64>,
    /// Maximal intervals [t_start, t_end] of samples where the driver's demand is outside the bounds: applied
    /// as it is (`ignore`) or clipped (`enforce`).
    pub input_bound_violations: Vec<[f64; 2]>,
    /// Maximal intervals [t_start, t_end] of samples outside the trace tolerance band.
    pub trace_misses: Vec<[f64; 2]>,
    pub trace_miss_speed_tolerance: f64,
    pub trace_miss_time_tolerance_s: f64,
    /// max |y − y_c| and rms (y − y_c) over the samples, y_c the raw cycle.
    pub max_abs_tracking_error: f64,
    pub rms_tracking_error: f64,
    pub warnings: Vec<String>,
}

impl ForwardSummary {
    /// Human-readable summary, one line per field (what `invsim forward` prints).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "model: {}", self.model);
        let _ = writeln!(s, "engine: {}", self.engine);
        let _ = writeln!(s, "cycle: {}", self.cycle);
        let _ = writeln!(s, "duration: {} s", fmt_sig(self.duration_s, 6));
        let _ = writeln!(
            s,
            "distance: {} m (driven {} m)",
            fmt_sig(self.distance_m, 6),
            fmt_sig(self.distance_driven_m, 6)
        );
        let _ = writeln!(s, "relative degree: {}", self.relative_degree);
        let _ = writeln!(s, "samples: {}", self.samples);
        let _ = writeln!(s, "dt: {} s", fmt_sig(self.dt_s, 6));
        let d = &self.driver;
        let _ = writeln!(
            s,
            "driver: PI on the error to the raw cycle, kp {}, ki {}, response {} rad/s, feed-forward {}, bounds {}",
            fmt_sig(d.kp, 4),
            fmt_sig(d.ki, 4),
            fmt_sig(d.response_rad_s, 4),
            if d.feedforward { "on" } else { "off" },
            self.bounds.as_str()
        );
        let g = &self.integrator;
        let _ = write!(
            s,
            "integrator: {} (rtol {:e}, atol {:e}), {} steps ({} limited by stability), {} rejected, {} evaluations",
            g.method.as_str(),
            g.rtol,
            g.atol,
            g.stats.accepted,
            g.stats.stability_limited,
            g.stats.rejected,
            g.stats.evaluations
        );
        s.push('\n');
        write_integrals(
            &mut s,
            &self.integrals,
            &self.integral_units,
            &self.integrals_per_100km,
        );
        write_input_range(
            &mut s,
            &self.input,
            [self.input_min, self.input_max],
            [self.input_lower_bound, self.input_upper_bound],
        );
        write_intervals(
            &mut s,
            "input bound violations",
            &self.input_bound_violations,
        );
        write_intervals(&mut s, "trace misses", &self.trace_misses);
        let _ = writeln!(
            s,
            "max abs tracking error: {}",
            fmt_sig(self.max_abs_tracking_error, 3)
        );
        let _ = writeln!(
            s,
            "rms tracking error: {}",
            fmt_sig(self.rms_tracking_error, 3)
        );
        for w in &self.warnings {
            let _ = writeln!(s, "warning: {w}");
        }
        s
    }
}

/// Result of a forward run: the summary and the time series, column by column.
#[derive(Debug, Clone, PartialEq)]
pub struct ForwardResult {
    pub summary: ForwardSummary,
    /// `t`, `yc` (the raw cycle), the output's name (unless it is a state of the same name), the input's
    /// name (the input applied), the states, the model's `[outputs]`.
    pub columns: Vec<String>,
    pub data: Vec<Vec<f64>>,
    pub input_column: usize,
}

impl ForwardResult {
    /// The column called `name`, if any.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .position(|c| c == name)
            .map(|i| self.data[i].as_slice())
    }
    /// Sample times.
    pub fn time(&self) -> &[f64] {
        &self.data[0]
    }
    /// The raw cycle at the samples.
    pub fn cycle_speed(&self) -> &[f64] {
        &self.data[1]
    }
    /// The input applied at the samples.
    pub fn input(&self) -> &[f64] {
        &self.data[self.input_column]
    }
    /// Number of stored samples.
    pub fn len(&self) -> usize {
        self.data[0].len()
    }
    /// True if no samples are stored.
    pub fn is_empty(&self) -> bool {
        self.data[0].is_empty()
    }
}

// --- the raw cycle, segment by segment --------------------------------------------------------------------

/// The raw cycle as segments: segment j < m − 1 is [T_j, T_{j+1}] with y_c = V_j + s_j (t − T_j); segment
/// m − 1 holds the last speed for ever. Within a segment the formula is used also slightly outside it (an
/// integrator's stages), so the closed loop is smooth in t there.
struct RawCycle<'a> {
    time: &'a [f64],
    speed: &'a [f64],
    slope: Vec<f64>,
}

impl<'a> RawCycle<'a> {
    fn new(cycle: &'a Cycle) -> Self {
        let (time, speed) = (&cycle.time[..], &cycle.speed[..]);
        let mut slope: Vec<f64> = time
            .windows(2)
            .zip(speed.windows(2))
            .map(|(t, v)| (v[1] - v[0]) / (t[1] - t[0]))
            .collect();
        slope.push(0.0);
        RawCycle { time, speed, slope }
    }
    fn segments(&self) -> usize {
        self.slope.len()
    }
    /// The segment of t, right-continuous (a corner belongs to the segment it starts).
    fn segment(&self, t: f64) -> usize {
        self.time
            .partition_point(|&x| x <= t)
            .saturating_sub(1)
            .min(self.segments() - 1)
    }
    /// End of segment j (∞ for the last).
    fn end(&self, j: usize) -> f64 {
        if j + 1 < self.time.len() {
            self.time[j + 1]
        } else {
            f64::INFINITY
        }
    }
    fn value(&self, j: usize, t: f64) -> f64 {
        self.speed[j] + self.slope[j] * (t - self.time[j])
    }
}

/// The closed loop: model, driver, engine management and the raw cycle, with scratch space.
struct Loop<'a, M: InverseModel + ?Sized> {
    model: &'a M,
    raw: RawCycle<'a>,
    kp: f64,
    ki: f64,
    /// 1/T_t of the back-calculation.
    k_aw: f64,
    /// ω of the engine management's response.
    omega: f64,
    /// Coefficients C(r−1, j)·ω^(r−1−j), j = 0 … r − 2, of the inner loop.
    inner: Vec<f64>,
    feedforward: bool,
    enforce: bool,
    lo: f64,
    hi: f64,
    n: usize,
    xi: Vec<f64>,
    eta: Vec<f64>,
    guess: Vec<f64>,
}

/// The driver's and the engine management's output at one point.
#[derive(Debug, Clone, Copy)]
struct Drive {
    /// The raw cycle y_c(t).
    yc: f64,
    /// y = h(x).
    y: f64,
    /// The input the engine management computes (before clipping).
    demand: f64,
    /// The input applied u_a.
    applied: f64,
}

impl<M: InverseModel + ?Sized> Loop<'_, M> {
    /// Driver: a_req = y_c' + K_p e + I. Engine management: ν = Σ_j C(r−1, j) ω^(r−1−j) (ref_j − ξ_(j+2)),
    /// ref_0 = a_req, ref_j = 0 otherwise (ν = a_req for r = 1), and u = (ν − α(ψ(x)))/β(ψ(x)) (paper eq. 26
    /// with the normal-form coordinates of the vehicle's state).
    fn drive(&mut self, seg: usize, t: f64, z: &[f64]) -> Result<Drive, ForwardError> {
        let (x, integral) = (&z[..self.n], z[self.n]);
        let yc = self.raw.value(seg, t);
        self.model.psi(x, &mut self.xi, &mut self.eta);
        let y = self.xi[0];
        let ff = if self.feedforward {
            self.raw.slope[seg]
        } else {
            0.0
        };
        let request = ff + self.kp * (yc - y) + integral;
        let nu = if self.inner.is_empty() {
            request
        } else {
            let mut nu = self.inner[0] * (request - self.xi[1]);
            for (c, xi) in self.inner[1..].iter().zip(&self.xi[2..]) {
                nu -= c * xi;
            }
            nu
        };
        self.guess.copy_from_slice(x);
        let demand = self
            .model
            .invert(&self.xi, &self.eta, nu, &mut self.guess)
            .map_err(|source| ForwardError::Model { t, source })?;
        let applied = if self.enforce {
            demand.max(self.lo).min(self.hi)
        } else {
            demand
        };
        Ok(Drive {
            yc,
            y,
            demand,
            applied,
        })
    }

    /// dz/dt of the closed loop, z = (x, I): x' = f(x) + g(x) u_a and I' = K_i e + (Δa)/T_t, Δa = β (u_a − u)
    /// / ω^(r−1) the part of the request the clipped input cannot deliver (back-calculation).
    fn rhs(&mut self, seg: usize, t: f64, z: &[f64], dz: &mut [f64]) -> Result<(), ForwardError> {
        let d = self.drive(seg, t, z)?;
        let (dx, di) = dz.split_at_mut(self.n);
        self.model.rhs(&z[..self.n], d.applied, dx);
        let mut windup = 0.0;
        if d.applied != d.demand && self.k_aw > 0.0 {
            let beta = self.model.beta(&self.xi, &self.eta);
            windup = self.k_aw * beta * (d.applied - d.demand)
                / self.omega.powi(self.inner.len() as i32);
        }
        di[0] = self.ki * (d.yc - d.y) + windup;
        Ok(())
    }
}

/// The integrator in use.
enum Stepper {
    Explicit(Box<Dopri5>),
    Implicit(Box<Rosenbrock23>),
}

impl Stepper {
    fn step_to<F>(
        &mut self,
        t: f64,
        t_end: f64,
        z: &mut [f64],
        f: &mut F,
    ) -> Result<f64, ForwardError>
    where
        F: FnMut(f64, &[f64], &mut [f64]) -> Result<(), ForwardError>,
    {
        match self {
            Stepper::Explicit(s) => s.step_to(t, t_end, z, f),
            Stepper::Implicit(s) => s.step_to(t, t_end, z, f),
        }
    }
    fn dense(&self, t: f64, out: &mut [f64]) {
        match self {
            Stepper::Explicit(s) => s.dense(t, out),
            Stepper::Implicit(s) => s.dense(t, out),
        }
    }
    fn restart(&mut self) {
        match self {
            Stepper::Explicit(s) => s.restart(),
            Stepper::Implicit(s) => s.restart(),
        }
    }
    fn stats(&self) -> OdeStats {
        match self {
            Stepper::Explicit(s) => s.stats,
            Stepper::Implicit(s) => s.stats,
        }
    }
}

/// The output grid t_k = t_0 + k·dt (k = 0 … n), as in the inverse simulation: with 1/dt an integer,
/// t_k = t_0 + k/(1/dt), the correctly rounded value.
struct Grid {
    t0: f64,
    dt: f64,
    n: usize,
    per_second: Option<f64>,
}

impl Grid {
    fn time(&self, k: usize) -> f64 {
        match self.per_second {
            Some(m) => self.t0 + k as f64 / m,
            None => self.t0 + k as f64 * self.dt,
        }
    }
}

/// The trace tolerance band [min − tol, max + tol] of the raw cycle over [t − τ, t + τ] (40 CFR 86.115-78),
/// for increasing t: two pointers into the breakpoints, O(1) per sample.
struct TraceBand<'a> {
    time: &'a [f64],
    speed: &'a [f64],
    tau: f64,
    tol: f64,
    /// First breakpoint after t − τ, and after t + τ.
    lo: usize,
    hi: usize,
}

impl<'a> TraceBand<'a> {
    fn new(cycle: &'a Cycle, tau: f64, tol: f64) -> Self {
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

    fn at(&mut self, t: f64) -> (f64, f64) {
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

/// Simulate `model` forward along the raw `cycle`, closed by the PI driver (see the module docs).
pub fn forward<M: InverseModel + ?Sized>(
    model: &M,
    cycle: &Cycle,
    opts: &ForwardOptions,
) -> Result<ForwardResult, ForwardError> {
    // --- validation -------------------------------------------------------------------------------------
    if !(opts.dt > 0.0 && opts.dt.is_finite()) {
        return Err(ForwardError::InvalidDt(opts.dt));
    }
    let tol_ok = |v: f64| v > 0.0 && v.is_finite();
    if !(tol_ok(opts.rtol) && tol_ok(opts.atol)) {
        return Err(ForwardError::InvalidTolerance {
            rtol: opts.rtol,
            atol: opts.atol,
        });
    }
    for (name, v) in [
        ("kp", opts.kp),
        ("ki", opts.ki),
        ("response", opts.response),
    ] {
        if !(v.is_finite() && v >= 0.0) || (name == "response" && v == 0.0) {
            return Err(ForwardError::InvalidGain { name, value: v });
        }
    }
    let (speed_tol, time_tol) = (opts.trace_speed_tol, opts.trace_time_tol);
    if !(speed_tol.is_finite() && speed_tol >= 0.0 && time_tol.is_finite() && time_tol >= 0.0) {
        return Err(ForwardError::InvalidTraceTolerance {
            speed: speed_tol,
            time: time_tol,
        });
    }
    if let Err(e) = cycle.validate() {
        return Err(ForwardError::InvalidCycle {
            cycle: cycle.name.clone(),
            reason: e.to_string(),
        });
    }
    let info = model.info();
    let (n, r, ne) = (info.n_states(), info.relative_degree, info.n_eta);
    let no = info.outputs.len();
    let t0 = cycle.time[0];
    let duration = cycle.duration();
    let steps = (duration / opts.dt).round();
    if steps + 1.0 > MAX_SAMPLES as f64 {
        return Err(ForwardError::TooManySamples {
            samples: steps + 1.0,
            duration,
            dt: opts.dt,
            max: MAX_SAMPLES,
        });
    }
    let per_second = {
        let m = (1.0 / opts.dt).round();
        (m >= 1.0 && (1.0 / opts.dt - m).abs() <= 1e-9 * m).then_some(m)
    };
    let grid = Grid {
        t0,
        dt: opts.dt,
        n: steps as usize,
        per_second,
    };
    let raw = RawCycle::new(cycle);

    // --- initial state: ψ⁻¹ of the raw cycle's start --------------------------------------------------------
    let seg0 = raw.segment(t0);
    let mut xi0 = vec![0.0; r];
    if r > 0 {
        xi0[0] = raw.value(seg0, t0);
    }
    if r > 1 {
        xi0[1] = raw.slope[seg0];
    }
    let yr0 = if r == 1 { raw.slope[seg0] } else { 0.0 };
    let mut eta0 = vec![0.0; ne];
    let x0 = match &opts.x0 {
        Some(x) if x.len() != n => {
            return Err(ForwardError::InvalidX0 {
                reason: format!(
                    "model `{}` has {n} states, {} values were given",
                    info.name,
                    x.len()
                ),
            })
        }
        Some(x) if x.iter().any(|v| !v.is_finite()) => {
            return Err(ForwardError::InvalidX0 {
                reason: format!("values must be finite, got {x:?}"),
            })
        }
        Some(x) => {
            let mut xi = vec![0.0; r];
            model.psi(x, &mut xi, &mut eta0);
            x.clone()
        }
        None => {
            if ne > 0 {
                let mut ws = ZeroDynamicsWorkspace::new(ne);
                equilibrium(model, &xi0, yr0, &mut eta0, &mut ws)
                    .map_err(|reason| ForwardError::InitialState { t: t0, reason })?;
            }
            let mut x = vec![0.0; n];
            model
                .psi_inv(&xi0, &eta0, &mut x)
                .map_err(|source| ForwardError::Model { t: t0, source })?;
            if let Some(j) = x.iter().position(|v| !v.is_finite()) {
                return Err(ForwardError::InitialState {
                    t: t0,
                    reason: format!("ψ⁻¹ gives {} = {}", info.states[j], x[j]),
                });
            }
            x
        }
    };

    // --- driver and engine management ---------------------------------------------------------------------
    let (kp, ki) = (opts.kp, opts.ki);
    // T_t = T_i = K_p/K_i (Åström & Hägglund §3.5); with K_p = 0, T_t = 1 s.
    let k_aw = if ki > 0.0 {
        if kp > 0.0 {
            ki / kp
        } else {
            1.0
        }
    } else {
        0.0
    };
    let enforce = opts.bounds == Bounds::Enforce;
    let (lo, hi) = (
        info.input_min.unwrap_or(f64::NEG_INFINITY),
        info.input_max.unwrap_or(f64::INFINITY),
    );
    // (s + ω)^(r−1) = Σ_j C(r−1, j) ω^(r−1−j) s^j.
    let inner: Vec<f64> = (0..r.saturating_sub(1))
        .map(|j| binomial(r - 1, j) * opts.response.powi((r - 1 - j) as i32))
        .collect();
    let mut lp = Loop {
        model,
        raw,
        kp,
        ki,
        k_aw,
        omega: opts.response,
        inner,
        feedforward: opts.feedforward,
        enforce,
        lo,
        hi,
        n,
        xi: vec![0.0; r],
        eta: vec![0.0; ne],
        guess: vec![0.0; n],
    };
    // Start in equilibrium: without feed-forward the integral carries the cycle's initial slope.
    let mut z = x0.clone();
    z.push(if opts.feedforward || ki == 0.0 {
        0.0
    } else {
        lp.raw.slope[seg0]
    });

    // --- columns --------------------------------------------------------------------------------------------
    let mut columns = vec!["t".to_string(), "yc".to_string()];
    let output_is_state = info
        .states
        .iter()
        .position(|s| *s == info.output)
        .is_some_and(|j| {
            // The output column is left out when it would repeat a state column of the same name.
            let mut probe = x0.clone();
            (0..3).all(|p| {
                for (i, v) in probe.iter_mut().enumerate() {
                    *v = x0[i] * (1.0 + 0.1 * p as f64) + 0.01 * (p * (i + 1)) as f64;
                }
                model.h(&probe) == probe[j]
            })
        });
    if !output_is_state {
        columns.push(info.output.clone());
    }
    let input_column = columns.len();
    columns.push(info.input.clone());
    let state_column = columns.len();
    columns.extend(info.states.iter().cloned());
    let output_column = columns.len();
    columns.extend(info.outputs.iter().map(|o| o.name.clone()));
    let samples = grid.n + 1;
    let stored = if opts.keep_series { samples } else { 0 };
    let mut data: Vec<Vec<f64>> = vec![Vec::with_capacity(stored); columns.len()];

    // --- bookkeeping ------------------------------------------------------------------------------------
    let accumulate: Vec<usize> = (0..no).filter(|&i| info.outputs[i].accumulate).collect();
    let mut integrals = vec![0.0; accumulate.len()];
    let mut previous = vec![0.0; accumulate.len()];
    let (mut distance_driven, mut y_prev) = (0.0, 0.0);
    let (mut u_min, mut u_max) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut violations = Intervals::default();
    let mut misses = Intervals::default();
    let (mut max_err, mut sum_sq) = (0.0_f64, 0.0);
    let mut outs = vec![0.0; no];
    let mut band = TraceBand::new(cycle, time_tol, speed_tol);
    // Excursions below 1e-6 of the bounds' range (or of the bound's magnitude) are rounding, not violations
    // (a vehicle at rest holds u = 0 ± 1e-11 here).
    let u_tol = 1e-6
        * match (info.input_min, info.input_max) {
            (Some(a), Some(b)) => b - a,
            (Some(a), None) | (None, Some(a)) => a.abs(),
            (None, None) => 0.0,
        };
    let mut emit = |k: usize, t: f64, z: &[f64], d: Drive| -> Result<(), ForwardError> {
        let x = &z[..n];
        model.outputs(x, d.applied, &mut outs);
        let bad = |quantity: String, value: f64| ForwardError::NonFinite { t, quantity, value };
        if let Some(j) = x.iter().position(|v| !v.is_finite()) {
            return Err(bad(info.states[j].clone(), x[j]));
        }
        if !d.applied.is_finite() {
            return Err(bad(info.input.clone(), d.applied));
        }
        if let Some(j) = outs.iter().position(|v| !v.is_finite()) {
            return Err(bad(info.outputs[j].name.clone(), outs[j]));
        }
        if opts.keep_series {
            data[0].push(t);
            data[1].push(d.yc);
            if !output_is_state {
                data[2].push(d.y);
            }
            data[input_column].push(d.applied);
            for (j, &v) in x.iter().enumerate() {
                data[state_column + j].push(v);
            }
            for (j, &v) in outs.iter().enumerate() {
                data[output_column + j].push(v);
            }
        }
        // Trapezoidal rule over the grid, as in the inverse simulation.
        for ((acc, prev), &o) in integrals.iter_mut().zip(&mut previous).zip(&accumulate) {
            if k > 0 {
                *acc += 0.5 * grid.dt * (*prev + outs[o]);
            }
            *prev = outs[o];
        }
        if k > 0 {
            distance_driven += 0.5 * grid.dt * (y_prev + d.y);
        }
        y_prev = d.y;
        u_min = u_min.min(d.applied);
        u_max = u_max.max(d.applied);
        violations.push(t, d.demand < lo - u_tol || d.demand > hi + u_tol);
        let (band_lo, band_hi) = band.at(t);
        misses.push(t, d.y < band_lo || d.y > band_hi);
        let e = d.y - d.yc;
        max_err = max_err.max(e.abs());
        sum_sq += e * e;
        Ok(())
    };

    // --- the run: segment by segment, one accepted step at a time, the grid served by dense output -------
    let h0 = opts.dt.min(0.01);
    let mut stepper = match opts.method {
        Method::Rosenbrock23 => {
            Stepper::Implicit(Box::new(Rosenbrock23::new(n + 1, opts.rtol, opts.atol, h0)))
        }
        Method::Dopri5 => Stepper::Explicit(Box::new(Dopri5::new(n + 1, opts.rtol, opts.atol, h0))),
    };
    let d0 = lp.drive(seg0, t0, &z)?;
    emit(0, t0, &z, d0)?;
    let t_last = grid.time(grid.n);
    let mut zk = z.clone();
    let (mut t, mut seg, mut k) = (t0, seg0, 1);
    while k <= grid.n {
        let seg_end = lp.raw.end(seg);
        let target = seg_end.min(t_last);
        if t >= target {
            seg = (seg + 1).min(lp.raw.segments() - 1);
            stepper.restart();
            continue;
        }
        let t_new = stepper.step_to(t, target, &mut z, &mut |s, zz: &[f64], dz: &mut [f64]| {
            lp.rhs(seg, s, zz, dz)
        })?;
        // The grid samples t_k ≤ t_new, from the dense output; a sample on the segment's end belongs to the
        // next segment (the raw cycle's slope is taken from the right).
        while k <= grid.n {
            let tk = grid.time(k);
            if tk > t_new {
                break;
            }
            stepper.dense(tk, &mut zk);
            let seg_k = if tk >= seg_end {
                (seg + 1).min(lp.raw.segments() - 1)
            } else {
                seg
            };
            let d = lp.drive(seg_k, tk, &zk)?;
            emit(k, tk, &zk, d)?;
            k += 1;
        }
        t = t_new;
    }

    // --- summary ---------------------------------------------------------------------------------------
    let violations = violations.finish();
    let trace_misses = misses.finish();
    let stats = stepper.stats();
    let distance = cycle.distance();
    let tables = integral_tables(info, &accumulate, &integrals, distance);
    let mut warnings = Vec::new();
    if enforce && info.input_min.is_none() && info.input_max.is_none() {
        warnings.push(format!(
            "model `{}` declares no input bounds: there is nothing to enforce",
            info.name
        ));
    }
    if !violations.is_empty() {
        let total: f64 = violations.iter().map(|[a, b]| b - a).sum();
        let what = if enforce {
            "clipped"
        } else {
            "applied as demanded, not clipped"
        };
        warnings.push(format!(
            "the driver's demand for {} leaves its bounds in {} interval(s), {} s in total; {what}",
            info.input,
            violations.len(),
            fmt_sig(total, 4)
        ));
    }
    if !trace_misses.is_empty() {
        let total: f64 = trace_misses.iter().map(|[a, b]| b - a).sum();
        warnings.push(format!(
            "the vehicle misses the cycle's trace (± {} around the cycle within ± {} s) in {} interval(s), {} s in \
             total",
            fmt_sig(speed_tol, 4),
            fmt_sig(time_tol, 4),
            trace_misses.len(),
            fmt_sig(total, 4)
        ));
    }
    if cycle
        .grade
        .as_ref()
        .is_some_and(|g| g.iter().any(|&v| v != 0.0))
    {
        warnings
            .push("the cycle's road grade is ignored (the model has no grade input)".to_string());
    }
    let summary = ForwardSummary {
        model: info.name.clone(),
        cycle: cycle.name.clone(),
        duration_s: duration,
        distance_m: distance,
        distance_driven_m: distance_driven,
        relative_degree: r,
        engine: opts.engine.clone(),
        samples,
        dt_s: opts.dt,
        bounds: opts.bounds,
        driver: DriverSummary {
            kp,
            ki,
            response_rad_s: opts.response,
            feedforward: opts.feedforward,
            anti_windup_tracking_time_s: (k_aw > 0.0).then(|| 1.0 / k_aw),
        },
        integrator: IntegratorSummary {
            method: opts.method,
            rtol: opts.rtol,
            atol: opts.atol,
            stats,
        },
        integrals: tables.integrals,
        integrals_per_100km: tables.per_100km,
        integral_units: tables.units,
        input: info.input.clone(),
        input_min: u_min,
        input_max: u_max,
        input_lower_bound: info.input_min,
        input_upper_bound: info.input_max,
        input_bound_violations: violations,
        trace_misses,
        trace_miss_speed_tolerance: speed_tol,
        trace_miss_time_tolerance_s: time_tol,
        max_abs_tracking_error: max_err,
        rms_tracking_error: (sum_sq / samples as f64).sqrt(),
        warnings,
    };
    Ok(ForwardResult {
        summary,
        columns,
        data,
        input_column,
    })
}

/// The binomial coefficient C(n, k) as a float.
fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |c, i| c * (n - i) as f64 / (i + 1) as f64)
}
