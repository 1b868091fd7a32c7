//! The inverse-simulation driver: the model's input and state along a smoothed drive cycle (Fröberg & Nielsen
//! 2004, eq. 24–32; Isidori, *Nonlinear Control Systems*, §4.1 and §4.3).
//!
//! For x' = f(x) + g(x)u, y = h(x) with relative degree r the normal form is
//!
//! ```text
//! ξ̇_i = ξ_{i+1} (i < r),   y^(r) = α(ξ, η) + β(ξ, η) u,   η̇ = q(ξ, η, y^(r)),   x = ψ⁻¹(ξ, η)
//! ```
//!
//! so with the reference y_d and its exact derivatives from the [`Smoother`] (paper eq. 33–35),
//! ξ = (y_d, ẏ_d, …, y_d^(r−1)) and the input that makes y follow y_d is u = (y_d^(r) − α) / β (eq. 26).
//! If r < n the internal coordinates η follow the zero dynamics η̇ = q(ξ(t), η, y_d^(r)(t)), which are
//! integrated here with an adaptive, error-controlled Dormand–Prince 5(4) method. This causal inversion is only
//! possible for minimum-phase systems (stable zero dynamics). When the zero dynamics have unstable eigenvalues
//! at the equilibria the reference passes (non-minimum phase or mixed), η is instead computed non-causally as
//! the bounded solution of the zero dynamics over a time grid extended by pre- and post-actuation
//! ([`crate::stable`]: Devasia, Chen & Paden 1996); [`SimulationOptions::causal`] forces forward integration,
//! which then stops with [`SimulateError::UnstableZeroDynamics`].

use std::collections::BTreeMap;
use std::fmt::Write as _;

use invsim_model_api::{InverseModel, ModelError};
use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use thiserror::Error;

use crate::cycle::Cycle;
use crate::ode::Dopri5;
use crate::report::{
    integral_tables, write_input_range, write_integrals, write_intervals, Intervals,
};
use crate::smoother::{Smoother, SmootherError};
use crate::stable::{self, ZeroDynamicsClass};
use invsim_model_api::linearize::{eigenvalues, JacobianWork};

/// How many derivatives (orders 0 … 9) the smoother delivers per evaluation; bounds the relative degree (≤ 9).
pub const MAX_DERIVATIVES: usize = 10;

/// |η| above this means the internal dynamics have blown up.
pub const ETA_BLOWUP: f64 = 1e12;

/// Samples per block of the run (see `run`).
const BLOCK: usize = 4096;

/// Largest number of output samples a run may produce (guards against absurd `--dt`).
pub const MAX_SAMPLES: usize = 50_000_000;

/// Options of [`simulate`].
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationOptions {
    /// Kernel half-width a in seconds, the driver's look-ahead (paper eq. 33; default 5 s).
    pub lookahead: f64,
    /// Output step in seconds (default 0.1 s). The grid is t_k = t_0 + k·dt, k = 0 … round(duration/dt).
    pub dt: f64,
    /// Which implementation of the model is being driven (`"compiled"` or `"interpreted"`); only reported.
    pub engine: String,
    /// Initial internal state η(t_0), used as given. `None`: the equilibrium q(ξ(t_0), η, y_d^(r)(t_0)) = 0,
    /// found by Newton's method from η = 0.
    pub eta0: Option<Vec<f64>>,
    /// Relative tolerance of the zero-dynamics integrator (default 1e-10).
    pub rtol: f64,
    /// Absolute tolerance of the zero-dynamics integrator (default 1e-12).
    pub atol: f64,
    /// Seconds between two checks of the eigenvalues of ∂q/∂η along the run (default 1 s; the check is also
    /// made at t_0).
    pub stability_check_interval: f64,
    /// Verify the inverse open loop: simulate the original model dx/dt = f(x) + g(x)u forward from the
    /// inverse's x(t_0) with the computed input samples, interpolated linearly between grid points, and report
    /// how far h(x) strays from y_d on the grid (`max_abs_tracking_error`, `rms_tracking_error`); the error is
    /// O(dt²).
    pub verify: bool,
    /// Keep the time series (default). `false` computes every sample but stores none (`data` has empty
    /// columns): enough for the summary of `invsim simulate` without `--out`/`--plot`, and it saves the memory
    /// traffic of the columns. `verify` needs the series and keeps it regardless.
    pub keep_series: bool,
    /// Integrate the zero dynamics forward even when they are unstable (the run then stops with
    /// [`SimulateError::UnstableZeroDynamics`]). Default `false`: unstable zero dynamics are inverted stably
    /// (non-causally, [`crate::stable`]). A given `eta0` also selects causal integration (an initial state is a
    /// causal notion).
    pub causal: bool,
    /// Tolerance of the stable inversion (default 1e-8), relative to the magnitude of each internal coordinate:
    /// the estimated discretisation error of η must be below it (Newton's method on the boundary-value problem
    /// stops at 1 % of it), and pre- and post-actuation last until the deviation from the equilibria has
    /// decayed by this factor.
    pub stable_tol: f64,
    /// Longest pre- or post-actuation allowed, s (default 3600): slower unstable zero dynamics are an error.
    pub max_pre_actuation: f64,
    /// Keep the pre- and post-actuation samples (t < t_0, t > t_end) of a stable inversion in the series and in
    /// the summary's integrals, bounds and verification (default `false`: they are computed and summarised in
    /// `input_before_start`, the series covers the cycle).
    pub include_extension: bool,
}

impl Default for SimulationOptions {
    fn default() -> Self {
        SimulationOptions {
            lookahead: 5.0,
            dt: 0.1,
            engine: "compiled".to_string(),
            eta0: None,
            rtol: 1e-10,
            atol: 1e-12,
            stability_check_interval: 1.0,
            verify: false,
            keep_series: true,
            causal: false,
            stable_tol: 1e-8,
            max_pre_actuation: 3600.0,
            include_extension: false,
        }
    }
}

/// Why a simulation could not be run or was stopped.
#[derive(Debug, Error)]
pub enum SimulateError {
    #[error("invalid output step dt = {0} s: it must be a positive, finite number of seconds")]
    InvalidDt(f64),
    #[error("invalid look-ahead a = {0} s: the kernel half-width must be a positive, finite number of seconds")]
    InvalidLookahead(f64),
    #[error(
        "invalid zero-dynamics tolerances rtol = {rtol}, atol = {atol}: both must be positive and finite"
    )]
    InvalidTolerance { rtol: f64, atol: f64 },
    #[error(
        "invalid stability check interval {0} s: it must be a positive, finite number of seconds"
    )]
    InvalidCheckInterval(f64),
    #[error("invalid initial internal state eta0: {reason}")]
    InvalidEta0 { reason: String },
    #[error(
        "relative degree {relative_degree} is too high: the smoother provides y_d and its derivatives up to \
         order {max}"
    )]
    RelativeDegreeTooHigh { relative_degree: usize, max: usize },
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
    #[error("cannot smooth the drive cycle: {0}")]
    Smoother(#[from] SmootherError),
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
    #[error(
        "the decoupling coefficient β(ξ, η) = L_g L_f^(r−1) h is {beta} at t = {t} s, so the input \
         u = (y^(r) − α)/β is undefined there: the relative degree is not well defined at this operating point"
    )]
    SingularDecoupling { t: f64, beta: f64 },
    #[error(
        "cannot find the initial internal state: Newton's method for the equilibrium q(ξ(t0), η, y_d^(r)(t0)) = 0 \
         at t0 = {t} s {reason}; give eta0 explicitly"
    )]
    ZeroDynamicsEquilibrium { t: f64, reason: String },
    #[error(
        "unstable zero dynamics at t = {t} s: {detail}; eigenvalues of ∂q/∂η: {eigs}. The system is non-minimum \
         phase for this output, so causal inverse simulation diverges; stable (non-causal) inversion is needed",
        eigs = format_eigenvalues(.eigenvalues)
    )]
    UnstableZeroDynamics {
        t: f64,
        eigenvalues: Vec<[f64; 2]>,
        detail: String,
    },
    #[error("integrating the internal dynamics failed at t = {t} s: {reason}")]
    Integration { t: f64, reason: String },
    #[error(
        "verification failed: the original model dx/dt = f(x) + g(x)u could not be integrated forward with the \
         computed input at t = {t} s: {reason} (the inverse itself completed; run without --verify to get it)"
    )]
    Verification { t: f64, reason: String },
    #[error("stable (non-causal) inversion of the zero dynamics failed: {reason}")]
    StableInversion { reason: String },
    #[error(
        "the zero dynamics change type along the reference: ∂q/∂η has {from} unstable eigenvalue(s) at the \
         equilibrium for y = {y_from} ({eigs_from}) but {to} at y = {y_to} ({eigs_to}); a bounded inverse needs a \
         fixed split into stable and unstable parts (Devasia, Chen & Paden 1996), so neither causal nor stable \
         inversion works over this whole reference; use --causal to integrate forward as far as the zero \
         dynamics are stable",
        eigs_from = format_eigenvalues(.eigenvalues_from),
        eigs_to = format_eigenvalues(.eigenvalues_to)
    )]
    ZeroDynamicsTypeChange {
        y_from: f64,
        y_to: f64,
        from: String,
        to: String,
        eigenvalues_from: Vec<[f64; 2]>,
        eigenvalues_to: Vec<[f64; 2]>,
    },
    #[error(
        "stable inversion needs {needed} s of {which}-actuation for the zero dynamics to decay to the tolerance \
         (slowest decay rate {rate} 1/s), more than the limit of {max} s"
    )]
    PreActuationTooLong {
        which: &'static str,
        needed: f64,
        rate: f64,
        max: f64,
    },
}

impl From<crate::ode::StepFailure> for SimulateError {
    fn from(f: crate::ode::StepFailure) -> Self {
        SimulateError::Integration {
            t: f.t,
            reason: f.reason,
        }
    }
}

/// "0.5, -2 ± 1i" style list of complex numbers given as [re, im].
pub(crate) fn format_eigenvalues(eigs: &[[f64; 2]]) -> String {
    if eigs.is_empty() {
        return "not computable (∂q/∂η is not finite)".to_string();
    }
    let mut s = String::new();
    let mut i = 0;
    while i < eigs.len() {
        if !s.is_empty() {
            s.push_str(", ");
        }
        let [re, im] = eigs[i];
        // Conjugate pairs are listed together.
        let paired =
            im != 0.0 && i + 1 < eigs.len() && eigs[i + 1][0] == re && eigs[i + 1][1] == -im;
        if paired {
            let _ = write!(s, "{} ± {}i", fmt_sig(re, 6), fmt_sig(im.abs(), 6));
            i += 2;
        } else if im == 0.0 {
            let _ = write!(s, "{}", fmt_sig(re, 6));
            i += 1;
        } else {
            let sign = if im < 0.0 { '-' } else { '+' };
            let _ = write!(s, "{} {} {}i", fmt_sig(re, 6), sign, fmt_sig(im.abs(), 6));
            i += 1;
        }
    }
    s
}

/// Result of a run: the summary and the time series, stored column by column.
#[derive(Debug, Clone)]
pub struct SimulationResult {
    pub summary: Summary,
    /// Column names: `t`, `yd_0` … `yd_r`, the input, the states, `eta1` …, the `[outputs]`.
    pub columns: Vec<String>,
    /// One vector per column, each with `summary.samples` entries.
    pub data: Vec<Vec<f64>>,
    /// Index of the input's column in `columns`/`data`.
    pub input_column: usize,
    /// The input's bounds [min, max] as declared by the model (reported, never clipped).
    pub input_bounds: [Option<f64>; 2],
    /// How the cycle defined the reference: y_d = offset + scale · (smoothed cycle) (the model's
    /// [`InverseModel::reference`]).
    pub reference: invsim_model_api::ReferenceMap,
}

impl SimulationResult {
    /// The column called `name`, if any.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .position(|c| c == name)
            .map(|i| self.data[i].as_slice())
    }
    /// Sample times t_k.
    pub fn time(&self) -> &[f64] {
        &self.data[0]
    }
    /// y_d^(k) at the samples, k = 0 … r.
    pub fn yd(&self, k: usize) -> Option<&[f64]> {
        (k <= self.summary.relative_degree).then(|| self.data[1 + k].as_slice())
    }
    /// The computed input u at the samples.
    pub fn input(&self) -> &[f64] {
        &self.data[self.input_column]
    }
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.data[0].len()
    }
    /// True if there are no samples (never the case for a successful run).
    pub fn is_empty(&self) -> bool {
        self.data[0].is_empty()
    }
}

/// What `invsim simulate` prints and writes with `--summary-json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    pub model: String,
    pub cycle: String,
    /// Cycle duration (last minus first time stamp), s.
    pub duration_s: f64,
    /// Distance of the (raw, piecewise-linear) cycle, m.
    pub distance_m: f64,
    pub relative_degree: usize,
    pub engine: String,
    pub samples: usize,
    pub lookahead_s: f64,
    pub dt_s: f64,
    /// Accumulated output → its integral over the run (trapezoidal rule on the output grid).
    pub integrals: BTreeMap<String, f64>,
    /// Accumulated output → integral · 1e5 / distance_m (per 100 km); empty if the cycle covers no distance.
    pub integrals_per_100km: BTreeMap<String, f64>,
    /// Accumulated output → unit of its integral (e.g. `kg` for an output in `kg/s`), where the unit is known.
    pub integral_units: BTreeMap<String, String>,
    /// The input's name.
    pub input: String,
    /// Smallest and largest input reached over the run.
    pub input_min: f64,
    pub input_max: f64,
    /// The model's input bounds (reported, never clipped).
    pub input_lower_bound: Option<f64>,
    pub input_upper_bound: Option<f64>,
    /// Maximal time intervals [t_start, t_end] of consecutive samples with the input outside its bounds.
    pub input_bound_violations: Vec<[f64; 2]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_abs_tracking_error: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rms_tracking_error: Option<f64>,
    /// How η was obtained: `"none"` (r = n), `"causal"` (integrated forward) or `"stable"` (the bounded,
    /// non-causal solution of [`crate::stable`]).
    pub inversion: String,
    /// The zero dynamics at the equilibria the reference passes: `none` (r = n), `minimum_phase`,
    /// `non_minimum_phase`, `mixed` or `unknown`.
    pub zero_dynamics_class: ZeroDynamicsClass,
    /// Eigenvalues [re, im] of ∂q/∂η at the equilibrium for the reference's first value.
    pub zero_dynamics_eigenvalues: Vec<[f64; 2]>,
    /// Length of the grid before t_0 (pre-actuation) and after the cycle's end (post-actuation) that the stable
    /// inversion needed, s (0 for a causal run).
    pub pre_actuation_s: f64,
    pub post_actuation_s: f64,
    /// The input the stable inverse needs before t_0 (only where pre-actuation was needed).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub input_before_start: Option<InputBeforeStart>,
    /// Numbers of the stable inversion (only for a stable run).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stable_inversion: Option<StableInversionStats>,
    pub warnings: Vec<String>,
}

/// The input a stable inverse needs before the cycle starts (the pre-actuation, t_start ≤ t < t_0).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InputBeforeStart {
    /// First time of the extended grid, s (t_0 − pre-actuation).
    pub t_start: f64,
    /// The input at t_start: the equilibrium input for the reference's first value.
    pub u_initial: f64,
    /// The input at t_0.
    pub u_at_start: f64,
    /// Smallest and largest input before t_0.
    pub min: f64,
    pub max: f64,
    /// Largest |u − u_initial| before t_0.
    pub max_deviation: f64,
    /// ∫ |u − u_initial| dt over [t_start, t_0] (trapezoidal rule), in input unit · s.
    pub integral_abs_deviation: f64,
    /// First time the input departs from u_initial by more than 1e-4 of its range over the run (before t_0),
    /// or `None` if it does not before t_0: how early the actuator must start to move.
    pub departs_at: Option<f64>,
}

/// Numbers of a stable inversion.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StableInversionStats {
    /// Collocation nodes and their spacing, s.
    pub nodes: usize,
    pub node_spacing_s: f64,
    /// Newton iterations on the finest grid.
    pub newton_iterations: usize,
    /// Estimated discretisation error of η, relative to each component's magnitude.
    pub estimated_error: f64,
    /// Number of unstable eigenvalues of ∂q/∂η (the dimension integrated backward).
    pub unstable_dimension: usize,
}

impl Summary {
    /// Human-readable summary, one line per field (what `invsim simulate` prints).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "model: {}", self.model);
        let _ = writeln!(s, "engine: {}", self.engine);
        let _ = writeln!(s, "cycle: {}", self.cycle);
        let _ = writeln!(s, "duration: {} s", fmt_sig(self.duration_s, 6));
        let _ = writeln!(s, "distance: {} m", fmt_sig(self.distance_m, 6));
        let _ = writeln!(s, "relative degree: {}", self.relative_degree);
        let _ = writeln!(s, "samples: {}", self.samples);
        let _ = writeln!(s, "dt: {} s", fmt_sig(self.dt_s, 6));
        let _ = writeln!(s, "look-ahead: {} s", fmt_sig(self.lookahead_s, 6));
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
        if let Some(e) = self.max_abs_tracking_error {
            let _ = writeln!(s, "max abs tracking error: {}", fmt_sig(e, 3));
        }
        if let Some(e) = self.rms_tracking_error {
            let _ = writeln!(s, "rms tracking error: {}", fmt_sig(e, 3));
        }
        if self.zero_dynamics_class != ZeroDynamicsClass::None {
            let _ = write!(s, "zero dynamics: {}", self.zero_dynamics_class.as_str());
            if !self.zero_dynamics_eigenvalues.is_empty() {
                let _ = write!(
                    s,
                    " (eigenvalues at the start: {})",
                    format_eigenvalues(&self.zero_dynamics_eigenvalues)
                );
            }
            let _ = writeln!(s, ", inversion: {}", self.inversion);
        }
        if let Some(st) = &self.stable_inversion {
            let _ = writeln!(
                s,
                "stable inversion: {} nodes at {} s, {} Newton iterations, estimated error {}, {} unstable dimension(s)",
                st.nodes,
                fmt_sig(st.node_spacing_s, 4),
                st.newton_iterations,
                fmt_sig(st.estimated_error, 2),
                st.unstable_dimension
            );
            let _ = writeln!(
                s,
                "pre-actuation: {} s, post-actuation: {} s",
                fmt_sig(self.pre_actuation_s, 4),
                fmt_sig(self.post_actuation_s, 4)
            );
        }
        if let Some(p) = &self.input_before_start {
            let _ = write!(
                s,
                "{} before t0: from {} (at {} s) to {} at t0, range [{}, {}], integral of |u - u_initial| {}",
                self.input,
                fmt_sig(p.u_initial, 4),
                fmt_sig(p.t_start, 6),
                fmt_sig(p.u_at_start, 4),
                fmt_sig(p.min, 4),
                fmt_sig(p.max, 4),
                fmt_sig(p.integral_abs_deviation, 3)
            );
            match p.departs_at {
                Some(t) => {
                    let _ = writeln!(
                        s,
                        "; it departs from its initial value at t = {} s",
                        fmt_sig(t, 4)
                    );
                }
                None => s.push('\n'),
            }
        }
        for w in &self.warnings {
            let _ = writeln!(s, "warning: {w}");
        }
        s
    }
}

/// `v` with `digits` significant digits, in positional notation for moderate magnitudes.
pub(crate) fn fmt_sig(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v == 0.0 {
        return "0".to_string();
    }
    let mag = v.abs().log10().floor() as i32;
    if !(-4..15).contains(&mag) {
        return format!("{:.*e}", digits.saturating_sub(1), v);
    }
    let decimals = (digits as i32 - 1 - mag).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The output grid t_k = t_0 + k·dt, k = 0 … n.
#[derive(Debug, Clone, Copy)]
struct Grid {
    t0: f64,
    dt: f64,
    n: usize,
    /// Index of t_0 on the grid: the number of pre-actuation samples of a stable inversion (0 otherwise), so
    /// t_k = t_0 + (k − k0)·dt.
    k0: usize,
    /// 1/dt when that is an integer: then t_k = t_0 + k/(1/dt) is the correctly rounded k·dt (0.3, not
    /// 0.30000000000000004, at dt = 0.1).
    per_second: Option<f64>,
}

impl Grid {
    fn time(&self, k: usize) -> f64 {
        let k = k as f64 - self.k0 as f64;
        match self.per_second {
            Some(m) => self.t0 + k / m,
            None => self.t0 + k * self.dt,
        }
    }
}

/// Simulate `model` inversely along `cycle`: at every grid time the smoothed reference y_d … y_d^(r), the input,
/// the state, η and the extra outputs (see the module docs and contract §3).
///
/// Accumulated outputs are integrated over the output grid with the trapezoidal rule,
/// ∫ o dt ≈ Σ_k dt·(o_k + o_{k+1})/2; input-bound violations are reported, never clipped.
pub fn simulate<M: InverseModel + ?Sized>(
    model: &M,
    cycle: &Cycle,
    opts: &SimulationOptions,
) -> Result<SimulationResult, SimulateError> {
    run(model, cycle, opts, Vec::new())
}

/// [`simulate`], reusing the column buffers of an earlier result: for repeated runs (parameter sweeps,
/// benchmarks) this saves allocating and first touching fresh memory, which costs about as much as the whole
/// inversion of a cheap model.
pub fn simulate_reusing<M: InverseModel + ?Sized>(
    model: &M,
    cycle: &Cycle,
    opts: &SimulationOptions,
    previous: SimulationResult,
) -> Result<SimulationResult, SimulateError> {
    run(model, cycle, opts, previous.data)
}

fn run<M: InverseModel + ?Sized>(
    model: &M,
    cycle: &Cycle,
    opts: &SimulationOptions,
    mut spare: Vec<Vec<f64>>,
) -> Result<SimulationResult, SimulateError> {
    // --- validation -------------------------------------------------------------------------------------
    if !(opts.dt > 0.0 && opts.dt.is_finite()) {
        return Err(SimulateError::InvalidDt(opts.dt));
    }
    if !(opts.lookahead > 0.0 && opts.lookahead.is_finite()) {
        return Err(SimulateError::InvalidLookahead(opts.lookahead));
    }
    let tol_ok = |v: f64| v > 0.0 && v.is_finite();
    if !(tol_ok(opts.rtol) && tol_ok(opts.atol)) {
        return Err(SimulateError::InvalidTolerance {
            rtol: opts.rtol,
            atol: opts.atol,
        });
    }
    if !tol_ok(opts.stability_check_interval) {
        return Err(SimulateError::InvalidCheckInterval(
            opts.stability_check_interval,
        ));
    }
    let info = model.info();
    let r = info.relative_degree;
    let n = info.n_states();
    let ne = info.n_eta;
    let no = info.outputs.len();
    if r + 1 > MAX_DERIVATIVES {
        return Err(SimulateError::RelativeDegreeTooHigh {
            relative_degree: r,
            max: MAX_DERIVATIVES - 1,
        });
    }
    let bad_cycle = |reason: String| SimulateError::InvalidCycle {
        cycle: cycle.name.clone(),
        reason,
    };
    if cycle.time.is_empty() || cycle.time.len() != cycle.speed.len() {
        return Err(bad_cycle(format!(
            "it has {} time stamps and {} speeds (need at least one of each, equally many)",
            cycle.time.len(),
            cycle.speed.len()
        )));
    }
    let t0 = cycle.time[0];
    let duration = cycle.duration();
    if !(t0.is_finite() && duration.is_finite() && duration >= 0.0) {
        return Err(bad_cycle(format!(
            "start time {t0} s and duration {duration} s must be finite, duration ≥ 0"
        )));
    }
    let steps = (duration / opts.dt).round();
    if steps + 1.0 > MAX_SAMPLES as f64 {
        return Err(SimulateError::TooManySamples {
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
    let mut grid = Grid {
        t0,
        dt: opts.dt,
        n: steps as usize,
        k0: 0,
        per_second,
    };
    let eta0 = match &opts.eta0 {
        Some(e) if e.len() != ne => {
            return Err(SimulateError::InvalidEta0 {
                reason: format!(
                    "model `{}` has {ne} internal coordinates, {} values were given",
                    info.name,
                    e.len()
                ),
            })
        }
        Some(e) if e.iter().any(|v| !v.is_finite()) => {
            return Err(SimulateError::InvalidEta0 {
                reason: format!("values must be finite, got {e:?}"),
            })
        }
        other => other.clone(),
    };

    let smoother = Smoother::new(cycle, opts.lookahead)?.with_reference(model.reference());

    // --- zero dynamics: classified along the reference; unstable ones are inverted stably (non-causally) on
    // a grid extended by pre- and post-actuation (crate::stable), the series reports the cycle's samples
    // [k_lo, k_hi] unless `include_extension` asks for all.
    let zd = stable::plan_run(
        model,
        cycle,
        &smoother,
        t0,
        grid.time(grid.n),
        opts.dt,
        opts,
        eta0.is_some(),
    )?;
    if let Some(st) = &zd.stable {
        let extended = steps + (st.k_pre + st.k_post) as f64;
        if extended + 1.0 > MAX_SAMPLES as f64 {
            return Err(SimulateError::TooManySamples {
                samples: extended + 1.0,
                duration: extended * opts.dt,
                dt: opts.dt,
                max: MAX_SAMPLES,
            });
        }
        grid.k0 = st.k_pre;
        grid.n += st.k_pre + st.k_post;
    }
    let (k_lo, k_hi) = match (&zd.stable, opts.include_extension) {
        (Some(_), false) => (grid.k0, grid.k0 + steps as usize),
        _ => (0, grid.n),
    };
    let mut before_start: Vec<[f64; 2]> = Vec::with_capacity(grid.k0);

    // --- columns ------------------------------------------------------------------------------------------
    let mut columns = Vec::with_capacity(2 + r + 1 + n + ne + no);
    columns.push("t".to_string());
    columns.extend((0..=r).map(|k| format!("yd_{k}")));
    let input_column = columns.len();
    columns.push(info.input.clone());
    columns.extend(info.states.iter().cloned());
    columns.extend((1..=ne).map(|k| format!("eta{k}")));
    columns.extend(info.outputs.iter().map(|o| o.name.clone()));
    let samples = grid.n + 1;
    let keep = opts.keep_series || opts.verify;
    let stored = if keep { samples } else { 0 };
    spare.truncate(columns.len());
    spare.resize_with(columns.len(), Vec::new);
    let mut data = spare;
    for column in &mut data {
        // Fresh columns come zeroed from the allocator without being touched; every entry is overwritten.
        if column.capacity() < stored {
            *column = vec![0.0; stored];
        } else {
            column.resize(stored, 0.0);
        }
    }
    // t_k for the whole grid up front (keeps the division off the per-sample path).
    for (k, t) in data[0].iter_mut().enumerate() {
        *t = grid.time(k);
    }

    // --- work space (allocated once; the per-sample loop below allocates nothing) -------------------------
    let mut yd = [0.0_f64; MAX_DERIVATIVES];
    let mut x = vec![0.0; n];
    let mut eta = vec![0.0; ne];
    let accumulate: Vec<usize> = (0..no).filter(|&i| info.outputs[i].accumulate).collect();
    let mut integrals = vec![0.0; accumulate.len()];
    let mut previous = vec![0.0; accumulate.len()];
    let mut warnings = Vec::new();

    // --- initial internal state and its stability (Isidori §4.3: minimum phase) ---------------------------
    let mut zd_ws = ZeroDynamicsWorkspace::new(ne);
    if ne > 0 && zd.stable.is_none() {
        smoother.eval(t0, &mut yd[..=r]);
        let (xi, yr) = (&yd[..r], yd[r]);
        match eta0 {
            Some(e) => eta.copy_from_slice(&e),
            // Newton from several starting points first (internal states in physical units are rarely near 0).
            None => match stable::equilibrium(model, xi, yr, None) {
                Some(e) => eta.copy_from_slice(&e),
                None => equilibrium(model, xi, yr, &mut eta, &mut zd_ws)
                    .map_err(|reason| SimulateError::ZeroDynamicsEquilibrium { t: t0, reason })?,
            },
        }
        check_stability(model, t0, xi, &eta, yr, &mut zd_ws)?;
    }
    let check_every = ((opts.stability_check_interval / opts.dt).round() as usize).max(1);
    let mut integrator = Dopri5::new(ne, opts.rtol, opts.atol, opts.dt);

    // --- bookkeeping of the input ----------------------------------------------------------------------
    let (umin_bound, umax_bound) = (info.input_min, info.input_max);
    let (mut u_min, mut u_max) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut violations = Intervals::default();

    // --- the run, block by block -------------------------------------------------------------------------
    // Per block of samples: y_d … y_d^(r) on the grid at once (Smoother::eval_grid); then the inverse, for
    // r = n the whole block at once (every sample is independent: InverseModel::invert_batch), for r < n
    // sample by sample with the zero dynamics integrated in between; then the extra outputs
    // (InverseModel::outputs_batch) and the per-sample bookkeeping. With `keep` a block is a view into the
    // result's columns, without it into block-sized scratch columns.
    let width = columns.len();
    let mut scratch: Vec<Vec<f64>> = if keep {
        Vec::new()
    } else {
        vec![vec![0.0; BLOCK]; width]
    };
    let mut k0 = 0;
    while k0 < samples {
        let k1 = (k0 + BLOCK).min(samples);
        let len = k1 - k0;
        let mut cols: Vec<&mut [f64]> = if keep {
            data.iter_mut().map(|c| &mut c[k0..k1]).collect()
        } else {
            scratch.iter_mut().map(|c| &mut c[..len]).collect()
        };
        if !keep {
            for (i, t) in cols[0].iter_mut().enumerate() {
                *t = grid.time(k0 + i);
            }
        }
        let (time_col, rest) = cols.split_at_mut(1);
        let time: &[f64] = time_col[0];
        let (yd_cols, rest) = rest.split_at_mut(r + 1);
        let (u_col, rest) = rest.split_at_mut(1);
        let (x_cols, rest) = rest.split_at_mut(n);
        let (eta_cols, out_cols) = rest.split_at_mut(ne);
        smoother.eval_grid(time, Some(grid.dt), yd_cols);

        if ne == 0 {
            let xi: Vec<&[f64]> = yd_cols[..r].iter().map(|c| &**c).collect();
            for (c, &v) in x_cols.iter_mut().zip(&x) {
                c[0] = v; // the guess for a numerically solved ψ⁻¹
            }
            model
                .invert_batch(&xi, &[], yd_cols[r], x_cols, u_col[0])
                .map_err(|(i, source)| SimulateError::Model { t: time[i], source })?;
            for (v, c) in x.iter_mut().zip(x_cols.iter()) {
                *v = c[len - 1];
            }
        } else if let Some(st) = &zd.stable {
            // η from the bounded (stable) solution of the zero dynamics between its collocation nodes
            // (crate::stable); then every sample is independent, as for r = n.
            for (i, &t) in time.iter().enumerate() {
                st.solution.eval(t, &mut eta);
                for (c, &v) in eta_cols.iter_mut().zip(&eta) {
                    c[i] = v;
                }
            }
            let xi: Vec<&[f64]> = yd_cols[..r].iter().map(|c| &**c).collect();
            let etas: Vec<&[f64]> = eta_cols.iter().map(|c| &**c).collect();
            for (c, &v) in x_cols.iter_mut().zip(&x) {
                c[0] = v; // the guess for a numerically solved ψ⁻¹
            }
            model
                .invert_batch(&xi, &etas, yd_cols[r], x_cols, u_col[0])
                .map_err(|(i, source)| SimulateError::Model { t: time[i], source })?;
            for (v, c) in x.iter_mut().zip(x_cols.iter()) {
                *v = c[len - 1];
            }
        } else {
            for i in 0..len {
                let (k, t) = (k0 + i, time[i]);
                if k > 0 {
                    let t_prev = grid.time(k - 1);
                    let mut q = |s: f64, e: &[f64], de: &mut [f64]| {
                        let mut yd_s = [0.0_f64; MAX_DERIVATIVES];
                        smoother.eval(s, &mut yd_s[..=r]);
                        model.zero_dynamics(&yd_s[..r], e, yd_s[r], de);
                        Ok(())
                    };
                    if let Err(err) = integrator.advance(t_prev, t, &mut eta, &mut q) {
                        // A failing integrator usually means that η is running away; say so if it is.
                        let (t_fail, eta_fail) = (integrator.t_fail, &integrator.y_fail);
                        smoother.eval(t_fail, &mut yd[..=r]);
                        let (xi, yr) = (&yd[..r], yd[r]);
                        if let Some(i) = eta_fail
                            .iter()
                            .position(|v| !v.is_finite() || v.abs() > ETA_BLOWUP)
                        {
                            return Err(SimulateError::UnstableZeroDynamics {
                                t: t_fail,
                                eigenvalues: eigenvalues_at(model, xi, eta_fail, yr, &mut zd_ws),
                                detail: format!("eta{} = {} has blown up", i + 1, eta_fail[i]),
                            });
                        }
                        check_stability(model, t_fail, xi, eta_fail, yr, &mut zd_ws)?;
                        return Err(err);
                    }
                }
                for (o, c) in yd[..=r].iter_mut().zip(yd_cols.iter()) {
                    *o = c[i];
                }
                let (xi, yr) = (&yd[..r], yd[r]);
                if let Some(j) = eta
                    .iter()
                    .position(|v| !v.is_finite() || v.abs() > ETA_BLOWUP)
                {
                    let eigenvalues = eigenvalues_at(model, xi, &eta, yr, &mut zd_ws);
                    return Err(SimulateError::UnstableZeroDynamics {
                        t,
                        eigenvalues,
                        detail: format!("eta{} = {} has blown up", j + 1, eta[j]),
                    });
                }
                if k % check_every == 0 && k > 0 {
                    check_stability(model, t, xi, &eta, yr, &mut zd_ws)?;
                }
                // x = ψ⁻¹(ξ, η) (previous x as the guess), u = (y_d^(r) − α)/β (paper eq. 26).
                let u = model
                    .invert(xi, &eta, yr, &mut x)
                    .map_err(|source| SimulateError::Model { t, source })?;
                u_col[0][i] = u;
                for (c, &v) in x_cols.iter_mut().zip(&x) {
                    c[i] = v;
                }
                for (c, &v) in eta_cols.iter_mut().zip(&eta) {
                    c[i] = v;
                }
            }
        }
        {
            let xs: Vec<&[f64]> = x_cols.iter().map(|c| &**c).collect();
            model.outputs_batch(&xs, u_col[0], out_cols);
        }

        // Per-sample bookkeeping.
        for i in 0..len {
            let (k, t, u) = (k0 + i, time[i], u_col[0][i]);
            // v·0 is NaN exactly when v is not finite: one test for the whole sample.
            let mut probe = u * 0.0;
            for c in yd_cols.iter().chain(x_cols.iter()).chain(out_cols.iter()) {
                probe += c[i] * 0.0;
            }
            if probe.is_nan() {
                let at = |cs: &[&mut [f64]]| cs.iter().map(|c| c[i]).collect::<Vec<f64>>();
                let (yd_i, x_i, eta_i, outs_i) =
                    (at(yd_cols), at(x_cols), at(eta_cols), at(out_cols));
                return Err(non_finite(model, t, &yd_i, &eta_i, u, &x_i, &outs_i));
            }
            // Pre-actuation (t < t_0) is summarised on its own; samples outside [k_lo, k_hi] are not reported.
            if k < grid.k0 || (k == grid.k0 && grid.k0 > 0) {
                before_start.push([t, u]);
            }
            if k < k_lo || k > k_hi {
                continue;
            }
            // Trapezoidal rule over the grid: ∫ o dt ≈ Σ_k dt·(o_k + o_{k+1})/2.
            for ((acc, prev), &o) in integrals.iter_mut().zip(&mut previous).zip(&accumulate) {
                let v = out_cols[o][i];
                if k > k_lo {
                    *acc += 0.5 * grid.dt * (*prev + v);
                }
                *prev = v;
            }
            // Input range and bound violations: maximal runs of consecutive samples outside the bounds.
            u_min = u_min.min(u);
            u_max = u_max.max(u);
            let outside = umin_bound.is_some_and(|b| u < b) || umax_bound.is_some_and(|b| u > b);
            violations.push(t, outside);
        }
        k0 = k1;
    }
    let violations = violations.finish();

    // --- summary ---------------------------------------------------------------------------------------
    let distance = cycle.distance();
    let has_distance = distance > 0.0 && distance.is_finite();
    let tables = integral_tables(info, &accumulate, &integrals, distance);
    if !accumulate.is_empty() && !has_distance {
        warnings.push(format!(
            "the cycle covers no distance ({distance} m): no per-100-km figures"
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
    if !violations.is_empty() {
        let total: f64 = violations.iter().map(|[a, b]| b - a).sum();
        let bounds = format!(
            "[{}, {}]",
            umin_bound.map_or("-inf".to_string(), |b| fmt_sig(b, 6)),
            umax_bound.map_or("inf".to_string(), |b| fmt_sig(b, 6))
        );
        warnings.push(format!(
            "input {} leaves its bounds {bounds} in {} interval(s), {} s in total (reached {} … {}); not clipped",
            info.input,
            violations.len(),
            fmt_sig(total, 4),
            fmt_sig(u_min, 4),
            fmt_sig(u_max, 4)
        ));
    }

    let (max_abs_tracking_error, rms_tracking_error) = if opts.verify {
        let state_column = input_column + 1;
        let (max_abs, rms, verify_warnings) =
            verify_forward(model, &grid, &data, input_column, state_column, opts)?;
        warnings.extend(verify_warnings);
        (Some(max_abs), Some(rms))
    } else {
        (None, None)
    };

    // --- the zero dynamics in the summary; the pre- and post-actuation rows leave the series ------------------
    if keep && (k_lo, k_hi) != (0, grid.n) {
        for column in &mut data {
            column.truncate(k_hi + 1);
            column.drain(..k_lo);
        }
    }
    let (inversion, pre_actuation_s, post_actuation_s, stable_inversion) = match &zd.stable {
        None if ne == 0 => ("none", 0.0, 0.0, None),
        None => ("causal", 0.0, 0.0, None),
        Some(st) => {
            let sol = &st.solution;
            if let Some((t, eigs)) = &sol.dichotomy_change {
                warnings.push(format!(
                    "stable inversion: at t = {} s the frozen linearisation ∂q/∂η has eigenvalues {}, not {} \
                     unstable one(s) as at the ends; the bounded solution was found, but check it (e.g. with \
                     --verify)",
                    fmt_sig(*t, 6),
                    format_eigenvalues(eigs),
                    st.plan.unstable
                ));
            }
            if sol.estimated_error > opts.stable_tol {
                warnings.push(format!(
                    "stable inversion: the estimated error {} of η exceeds the tolerance {} at the finest node \
                     spacing {} s",
                    fmt_sig(sol.estimated_error, 2),
                    opts.stable_tol,
                    fmt_sig(sol.h, 3)
                ));
            }
            let stats = StableInversionStats {
                nodes: sol.nodes(),
                node_spacing_s: sol.h,
                newton_iterations: sol.iterations,
                estimated_error: sol.estimated_error,
                unstable_dimension: st.plan.unstable,
            };
            (
                "stable",
                st.k_pre as f64 * opts.dt,
                st.k_post as f64 * opts.dt,
                Some(stats),
            )
        }
    };
    let input_before_start = match before_start.split_last() {
        Some((&[_, u_at_start], earlier)) if !earlier.is_empty() => {
            let [t_start, u_initial] = earlier[0];
            let (mut lo, mut hi, mut max_deviation, mut integral) =
                (u_at_start, u_at_start, 0.0_f64, 0.0);
            // 1e-4 of the input's range over the run, and above rounding.
            let threshold = (1e-4 * (u_max - u_min).abs()).max(1e-9 * u_initial.abs().max(1.0));
            let mut departs_at = None;
            for (j, &[t, u]) in before_start.iter().enumerate() {
                lo = lo.min(u);
                hi = hi.max(u);
                let dev = (u - u_initial).abs();
                max_deviation = max_deviation.max(dev);
                if dev > threshold && departs_at.is_none() && j + 1 < before_start.len() {
                    departs_at = Some(t);
                }
                if j > 0 {
                    integral += 0.5 * opts.dt * (dev + (before_start[j - 1][1] - u_initial).abs());
                }
            }
            Some(InputBeforeStart {
                t_start,
                u_initial,
                u_at_start,
                min: lo,
                max: hi,
                max_deviation,
                integral_abs_deviation: integral,
                departs_at,
            })
        }
        _ => None,
    };

    let summary = Summary {
        model: info.name.clone(),
        cycle: cycle.name.clone(),
        duration_s: duration,
        distance_m: distance,
        relative_degree: r,
        engine: opts.engine.clone(),
        samples: k_hi - k_lo + 1,
        lookahead_s: opts.lookahead,
        dt_s: opts.dt,
        integrals: tables.integrals,
        integrals_per_100km: tables.per_100km,
        integral_units: tables.units,
        input: info.input.clone(),
        input_min: u_min,
        input_max: u_max,
        input_lower_bound: umin_bound,
        input_upper_bound: umax_bound,
        input_bound_violations: violations,
        max_abs_tracking_error,
        rms_tracking_error,
        inversion: inversion.to_string(),
        zero_dynamics_class: zd.class,
        zero_dynamics_eigenvalues: zd.eigenvalues.clone(),
        pre_actuation_s,
        post_actuation_s,
        input_before_start,
        stable_inversion,
        warnings,
    };
    Ok(SimulationResult {
        summary,
        columns,
        data,
        input_column,
        input_bounds: [umin_bound, umax_bound],
        reference: smoother.reference(),
    })
}

/// The first non-finite quantity of a sample, in column order, as an error; a non-finite input is blamed on a
/// vanishing β(ξ, η) if that is the cause.
fn non_finite<M: InverseModel + ?Sized>(
    model: &M,
    t: f64,
    yd: &[f64],
    eta: &[f64],
    u: f64,
    x: &[f64],
    outs: &[f64],
) -> SimulateError {
    let info = model.info();
    let error = |quantity: String, value: f64| SimulateError::NonFinite { t, quantity, value };
    if let Some(i) = yd.iter().position(|v| !v.is_finite()) {
        return error(format!("yd_{i}"), yd[i]);
    }
    if !u.is_finite() {
        let r = info.relative_degree;
        let beta = model.beta(&yd[..r], eta);
        if beta == 0.0 || !beta.is_finite() {
            return SimulateError::SingularDecoupling { t, beta };
        }
        return error(info.input.clone(), u);
    }
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        return error(info.states[i].clone(), x[i]);
    }
    match outs.iter().position(|v| !v.is_finite()) {
        Some(i) => error(info.outputs[i].name.clone(), outs[i]),
        None => error("a value".to_string(), f64::NAN),
    }
}

/// The unit of ∫ o dt for an output in `unit`: `kg/s` → `kg`, `W` → `J`; `None` if not obvious.
pub(crate) fn integral_unit(unit: &str) -> Option<String> {
    let unit = unit.trim();
    if let Some(base) = unit.strip_suffix("/s") {
        return (!base.is_empty()).then(|| base.to_string());
    }
    match unit {
        "W" => Some("J".to_string()),
        "kW" => Some("kJ".to_string()),
        _ => None,
    }
}

// --- zero dynamics: equilibrium, linearisation, eigenvalues --------------------------------------------------

/// Buffers for linearising the zero dynamics along a run (no allocation per check).
pub(crate) type ZeroDynamicsWorkspace = JacobianWork;

/// Eigenvalues [re, im] of ∂q/∂η at (ξ, η, y^(r)); empty if the Jacobian is not finite.
fn eigenvalues_at<M: InverseModel + ?Sized>(
    model: &M,
    xi: &[f64],
    eta: &[f64],
    yr: f64,
    ws: &mut ZeroDynamicsWorkspace,
) -> Vec<[f64; 2]> {
    let n = eta.len();
    eigenvalues(&DMatrix::from_column_slice(
        n,
        n,
        ws.jacobian(model, xi, eta, yr),
    ))
}

/// Stop with [`SimulateError::UnstableZeroDynamics`] if ∂q/∂η has an eigenvalue with positive real part
/// (beyond finite-difference noise, 1e-9 + 1e-7·‖∂q/∂η‖_max): the zero dynamics are then locally unstable and
/// the system non-minimum phase (Isidori §4.3).
fn check_stability<M: InverseModel + ?Sized>(
    model: &M,
    t: f64,
    xi: &[f64],
    eta: &[f64],
    yr: f64,
    ws: &mut ZeroDynamicsWorkspace,
) -> Result<(), SimulateError> {
    let n = eta.len();
    let jac = ws.jacobian(model, xi, eta, yr);
    let scale = jac.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    // One internal coordinate: the Jacobian is the eigenvalue; no allocation needed on the stable path.
    if n == 1 && jac[0].is_finite() && jac[0] <= 1e-9 + 1e-7 * scale {
        return Ok(());
    }
    let eigs = eigenvalues(&DMatrix::from_column_slice(n, n, jac));
    if eigs.is_empty() {
        return Err(SimulateError::UnstableZeroDynamics {
            t,
            eigenvalues: eigs,
            detail: "the linearisation ∂q/∂η is not finite".to_string(),
        });
    }
    if let Some(e) = eigs.iter().find(|e| e[0] > 1e-9 + 1e-7 * scale) {
        return Err(SimulateError::UnstableZeroDynamics {
            t,
            detail: format!(
                "∂q/∂η has an eigenvalue with positive real part {}",
                fmt_sig(e[0], 6)
            ),
            eigenvalues: eigs,
        });
    }
    Ok(())
}

/// The equilibrium q(ξ, η, y^(r)) = 0 into `eta`, by Newton's method from η = 0 with the central-difference
/// Jacobian ∂q/∂η and a backtracking line search. The error is a phrase for
/// [`SimulateError::ZeroDynamicsEquilibrium`].
pub(crate) fn equilibrium<M: InverseModel + ?Sized>(
    model: &M,
    xi: &[f64],
    yr: f64,
    eta: &mut [f64],
    ws: &mut ZeroDynamicsWorkspace,
) -> Result<(), String> {
    const MAX_ITER: usize = 100;
    let n = eta.len();
    eta.fill(0.0);
    let norm = |v: &[f64]| v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let mut q = vec![0.0; n];
    let mut trial = vec![0.0; n];
    let mut q_trial = vec![0.0; n];
    model.zero_dynamics(xi, eta, yr, &mut q);
    for _ in 0..MAX_ITER {
        let res = norm(&q);
        if !res.is_finite() {
            return Err(format!("met a non-finite q at η = {eta:?}"));
        }
        if res == 0.0 {
            return Ok(());
        }
        let step = DMatrix::from_column_slice(n, n, ws.jacobian(model, xi, eta, yr))
            .lu()
            .solve(&DVector::from_column_slice(&q))
            .filter(|s| s.iter().all(|v| v.is_finite()))
            .ok_or_else(|| format!("met a singular Jacobian ∂q/∂η at η = {eta:?}"))?;
        // Backtracking: halve the step until the residual decreases.
        let mut lambda = 1.0;
        let mut accepted = false;
        for _ in 0..30 {
            for i in 0..n {
                trial[i] = eta[i] - lambda * step[i];
            }
            model.zero_dynamics(xi, &trial, yr, &mut q_trial);
            if norm(&q_trial) < res || norm(&q_trial) == 0.0 {
                accepted = true;
                break;
            }
            lambda *= 0.5;
        }
        let step_norm = lambda * norm(step.as_slice());
        let eta_norm = norm(eta);
        if !accepted {
            // No decrease possible: converged to rounding level if the step is negligible.
            if step_norm <= 1e-10 * (1.0 + eta_norm) {
                return Ok(());
            }
            return Err(format!("stalled at η = {eta:?} with residual {res:e}"));
        }
        eta.copy_from_slice(&trial);
        q.copy_from_slice(&q_trial);
        if step_norm <= 1e-14 * (1.0 + eta_norm) {
            return Ok(());
        }
    }
    Err(format!(
        "did not converge in {MAX_ITER} iterations (residual {:e})",
        norm(&q)
    ))
}

// --- forward verification ---------------------------------------------------------------------------------

/// Open-loop verification: simulate the original model dx/dt = f(x) + g(x)u forward from the inverse's state
/// x(t_0) with the inverse's *sampled* input, and compare y = h(x) with y_d on the grid. `data` holds the run's
/// columns: y_d in column 1, the input in `input_column`, the states from `state_column`.
///
/// Between grid points the input is interpolated linearly, u(t) = u_k + (t − t_k)/dt · (u_{k+1} − u_k): that
/// is what replaying the CSV in any other simulator does, it needs nothing but the samples, and its error,
/// u''·dt²/8 at most, makes the tracking error O(dt²) (about 100 times smaller at dt = 0.01 s than at
/// dt = 0.1 s). The check therefore measures what the output grid delivers, not merely the integrator: the
/// original model is integrated with the same adaptive Dormand–Prince 5(4) method and tolerances as the zero
/// dynamics, interval by interval (the interpolated input has a kink at every grid point, but is continuous,
/// so the FSAL stage carries over). A model whose right-hand side is not finite along the replay is an error
/// ([`SimulateError::Verification`]). Returns (max |y − y_d|, rms (y − y_d), warnings).
fn verify_forward<M: InverseModel + ?Sized>(
    model: &M,
    grid: &Grid,
    data: &[Vec<f64>],
    input_column: usize,
    state_column: usize,
    opts: &SimulationOptions,
) -> Result<(f64, f64, Vec<String>), SimulateError> {
    let n = model.info().n_states();
    let u = &data[input_column];
    let yd0 = &data[1];
    let mut x: Vec<f64> = (0..n).map(|j| data[state_column + j][0]).collect();
    let mut integrator = Dopri5::new(n, opts.rtol, opts.atol, opts.dt);
    let fail = |t: f64, reason: String| SimulateError::Verification { t, reason };
    let mut max_abs = 0.0_f64;
    let mut sum_sq = 0.0;
    for (k, &yd0_k) in yd0.iter().enumerate().take(grid.n + 1) {
        if k > 0 {
            let (ta, tb) = (grid.time(k - 1), grid.time(k));
            let (ua, ub) = (u[k - 1], u[k]);
            let width = tb - ta;
            let mut rhs = |s: f64, x: &[f64], dx: &mut [f64]| -> Result<(), SimulateError> {
                let w = ((s - ta) / width).clamp(0.0, 1.0);
                model.rhs(x, ua + w * (ub - ua), dx);
                Ok(())
            };
            match integrator.advance(ta, tb, &mut x, &mut rhs) {
                Ok(()) => {}
                Err(SimulateError::Integration { t, reason }) => {
                    let state: Vec<String> = model
                        .info()
                        .states
                        .iter()
                        .zip(&integrator.y_fail)
                        .map(|(name, v)| format!("{name} = {v:e}"))
                        .collect();
                    return Err(fail(t, format!("{reason}; state {}", state.join(", "))));
                }
                Err(e) => return Err(fail(ta, e.to_string())),
            }
            if let Some(j) = x.iter().position(|v| !v.is_finite()) {
                return Err(fail(
                    tb,
                    format!("state {} became {}", model.info().states[j], x[j]),
                ));
            }
        }
        let err = model.h(&x) - yd0_k;
        max_abs = max_abs.max(err.abs());
        sum_sq += err * err;
    }
    let rms = (sum_sq / (grid.n + 1) as f64).sqrt();
    // An open-loop replay can only confirm the inverse where the model is stable along the trajectory: the
    // replay's own O(dt²) interpolation error then stays small. Where it is unstable any error grows
    // exponentially whatever dt is. Say so when the replay strays, so the number is not mistaken for an
    // inaccuracy of the inverse.
    let scale = yd0
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE);
    let mut warnings = Vec::new();
    if max_abs > 1e-3 * scale {
        warnings.push(format!(
            "verification: the open-loop replay strays from y_d by up to {} ({:.1e} of the largest |y_d|). \
             Interpolating the sampled input costs O(dt²) (try a smaller --dt); an error that does not shrink \
             with dt means the model is unstable along this trajectory, where an open-loop replay amplifies \
             any error and does not measure the inverse",
            fmt_sig(max_abs, 3),
            max_abs / scale
        ));
    }
    Ok((max_abs, rms, warnings))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits() {
        assert_eq!(fmt_sig(0.345_612, 4), "0.3456");
        assert_eq!(fmt_sig(5.666_3, 3), "5.67");
        assert_eq!(fmt_sig(11_013.3, 6), "11013.3");
        assert_eq!(fmt_sig(1180.0, 6), "1180");
        assert_eq!(fmt_sig(-2.0e-9, 3), "-2.00e-9");
        assert_eq!(fmt_sig(0.0, 3), "0");
    }

    #[test]
    fn eigenvalue_list() {
        assert_eq!(
            format_eigenvalues(&[[0.5, 0.0], [-2.0, 1.0], [-2.0, -1.0]]),
            "0.5, -2 ± 1i"
        );
    }

    #[test]
    fn dopri_exponential() {
        // y' = -2 y, y(0) = 1 → y(1) = e^-2.
        let mut ode = Dopri5::new(1, 1e-10, 1e-12, 0.1);
        let mut y = [1.0];
        let mut f = |_t: f64, y: &[f64], dy: &mut [f64]| -> Result<(), SimulateError> {
            dy[0] = -2.0 * y[0];
            Ok(())
        };
        for k in 0..10 {
            ode.advance(k as f64 * 0.1, (k + 1) as f64 * 0.1, &mut y, &mut f)
                .unwrap();
        }
        assert!((y[0] - (-2.0_f64).exp()).abs() < 1e-10, "{}", y[0]);
    }

    #[test]
    fn integral_units() {
        assert_eq!(integral_unit("kg/s").as_deref(), Some("kg"));
        assert_eq!(integral_unit("W").as_deref(), Some("J"));
        assert_eq!(integral_unit("Pa"), None);
    }
}
