//! Options of the forward simulation, their defaults (the driver's gains, the trace-miss band, the
//! integrator's tolerances) and their builder.

use serde::Serialize;

use super::error::ForwardError;
use crate::grid::check_dt;

/// One mile per hour in m/s.
pub const MPH: f64 = 0.447_04;
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

/// Default output step, s (`--dt`), that of the inverse simulation.
pub const DEFAULT_DT: f64 = crate::inverse::DEFAULT_DT;
/// Default relative tolerance of the integrator (`--rtol`).
pub const DEFAULT_RTOL: f64 = 1e-8;
/// Default absolute tolerance of the integrator (`--atol`).
pub const DEFAULT_ATOL: f64 = 1e-10;

/// Step budget of the forward integration per second of the cycle (accepted plus rejected steps; `max_steps`
/// overrides it): the default run of `si_engine` on the NEDC takes about 10 steps per second, a stiff variant
/// (V_i/100, bounds enforced) about 100, so 2000 leaves room for any sensible model while a loop made stiff by
/// absurd gains (`--kp 1e9`: about 150 000 steps per second) stops within a second or so of computing.
pub const STEPS_PER_CYCLE_SECOND: f64 = 2000.0;
/// The smallest default step budget, for short cycles.
pub const MIN_STEP_BUDGET: usize = 100_000;

/// The default step budget for a cycle of `duration` seconds: [`STEPS_PER_CYCLE_SECOND`] per second, at least
/// [`MIN_STEP_BUDGET`].
pub fn default_step_budget(duration: f64) -> usize {
    let scaled = (STEPS_PER_CYCLE_SECOND * duration).min(usize::MAX as f64 / 2.0);
    (scaled as usize).max(MIN_STEP_BUDGET)
}

/// Options of [`forward()`](super::forward()).
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
    /// Trace-miss band: ± Δv around the cycle's extremes within ± Δt; `None` (default): the cycle's own band
    /// ([`Cycle::tolerance`](crate::cycle::Cycle): EPA ±2 mph, ±1 s for UDDS, HWFET and cycle files, UNECE
    /// ±2 km/h, ±1 s for NEDC and WLTC, or what `--tolerance` set), as for the inverse's reference.
    pub trace_tolerance: Option<crate::cycle::Tolerance>,
    /// Keep the time series (default true); `false` computes every sample for the summary only.
    pub keep_series: bool,
    /// Step budget: the run stops with [`ForwardError::StepBudget`] after this many integrator steps (accepted
    /// and rejected); `None` (default): [`default_step_budget`] of the cycle's duration.
    pub max_steps: Option<usize>,
    /// Wall-clock limit in seconds (for sweeps): the run stops with [`ForwardError::TimeLimit`] once it has
    /// computed this long; `None` (default): no limit.
    pub time_limit_s: Option<f64>,
    /// Called with the fraction of the run done every few hundred samples (default: none).
    pub progress: crate::progress::Progress,
    /// Signal values given on the command line (`--signal`); the others come from the cycle or the model's
    /// defaults. The forward run uses the RAW signals (linear between samples).
    pub signals: Vec<crate::signals::SignalInput>,
    /// Start values of states given on the command line (`--initial NAME=VALUE`), over the model file's
    /// `initial`: the internal states start there instead of at the equilibrium of the zero dynamics.
    pub initial: Vec<(String, f64)>,
}

impl Default for ForwardOptions {
    fn default() -> Self {
        ForwardOptions {
            dt: DEFAULT_DT,
            engine: "compiled".to_string(),
            kp: DRIVER_KP,
            ki: DRIVER_KI,
            response: RESPONSE_OMEGA,
            feedforward: true,
            bounds: Bounds::Ignore,
            method: Method::Dopri5,
            rtol: DEFAULT_RTOL,
            atol: DEFAULT_ATOL,
            x0: None,
            trace_tolerance: None,
            keep_series: true,
            max_steps: None,
            time_limit_s: None,
            progress: crate::progress::Progress::none(),
            signals: Vec::new(),
            initial: Vec::new(),
        }
    }
}

impl ForwardOptions {
    /// A builder starting from the defaults; [`ForwardOptionsBuilder::build`] validates the values once.
    pub fn builder() -> ForwardOptionsBuilder {
        ForwardOptionsBuilder(ForwardOptions::default())
    }

    /// Check the values that do not depend on the model or the cycle (every run checks them again, since the
    /// fields are public).
    pub fn validate(&self) -> Result<(), ForwardError> {
        check_dt(self.dt)?;
        let tol_ok = |v: f64| v > 0.0 && v.is_finite();
        if !(tol_ok(self.rtol) && tol_ok(self.atol)) {
            return Err(ForwardError::InvalidTolerance {
                rtol: self.rtol,
                atol: self.atol,
            });
        }
        for (name, v) in [
            ("kp", self.kp),
            ("ki", self.ki),
            ("response", self.response),
        ] {
            if !(v.is_finite() && v >= 0.0) || (name == "response" && v == 0.0) {
                return Err(ForwardError::InvalidGain { name, value: v });
            }
        }
        if self.max_steps == Some(0) {
            return Err(ForwardError::InvalidBudget {
                what: "step budget max_steps",
                value: 0.0,
            });
        }
        if let Some(limit) = self.time_limit_s {
            if !(limit > 0.0 && limit.is_finite()) {
                return Err(ForwardError::InvalidBudget {
                    what: "time limit time_limit_s",
                    value: limit,
                });
            }
        }
        if let Some(t) = self.trace_tolerance {
            let ok = |v: f64| v.is_finite() && v >= 0.0;
            if !(ok(t.speed_mps) && ok(t.time_s)) {
                return Err(ForwardError::InvalidTraceTolerance {
                    speed: t.speed_mps,
                    time: t.time_s,
                });
            }
        }
        Ok(())
    }

    /// The trace-miss band of a run on `cycle`: the option's, else the cycle's own.
    pub fn trace_band(&self, cycle: &crate::cycle::Cycle) -> crate::cycle::Tolerance {
        self.trace_tolerance.unwrap_or(cycle.tolerance)
    }
}

/// Builds [`ForwardOptions`] (see [`ForwardOptions::builder`]); each setter sets the field of the same name.
#[derive(Debug, Clone)]
pub struct ForwardOptionsBuilder(ForwardOptions);

macro_rules! setters {
    ($($name:ident: $ty:ty),* $(,)?) => {
        impl ForwardOptionsBuilder {
            $(
                #[doc = concat!("Set `", stringify!($name), "`.")]
                pub fn $name(mut self, value: $ty) -> Self {
                    self.0.$name = value;
                    self
                }
            )*
        }
    };
}

setters! {
    dt: f64, kp: f64, ki: f64, response: f64, feedforward: bool, bounds: Bounds, method: Method, rtol: f64,
    atol: f64, x0: Option<Vec<f64>>, trace_tolerance: Option<crate::cycle::Tolerance>, keep_series: bool,
    max_steps: Option<usize>, time_limit_s: Option<f64>,
    progress: crate::progress::Progress,
}

impl ForwardOptionsBuilder {
    /// Which implementation of the model is driven (only reported).
    pub fn engine(mut self, engine: impl Into<String>) -> Self {
        self.0.engine = engine.into();
        self
    }

    /// The options, validated ([`ForwardOptions::validate`]).
    pub fn build(self) -> Result<ForwardOptions, ForwardError> {
        self.0.validate()?;
        Ok(self.0)
    }
}
