//! Options of the inverse simulation, their defaults and their builder.

use super::error::SimulateError;
use crate::grid::check_dt;
use crate::modes::Switching;
use crate::progress::Progress;
use crate::smoother::ZeroDynamicsReference;

/// Default kernel half-width a, s (`--lookahead`).
pub const DEFAULT_LOOKAHEAD: f64 = 5.0;
/// Default output step, s (`--dt`).
pub const DEFAULT_DT: f64 = 0.1;
/// Default relative tolerance of the zero-dynamics integrator.
pub const DEFAULT_RTOL: f64 = 1e-10;
/// Default absolute tolerance of the zero-dynamics integrator.
pub const DEFAULT_ATOL: f64 = 1e-12;
/// Default seconds between two stability checks of a causal run.
pub const DEFAULT_STABILITY_CHECK_INTERVAL: f64 = 1.0;
/// Default tolerance of the stable inversion.
pub const DEFAULT_STABLE_TOL: f64 = 1e-8;
/// Default longest pre- or post-actuation, s.
pub const DEFAULT_MAX_PRE_ACTUATION: f64 = 3600.0;

/// Options of [`simulate()`](crate::simulate()).
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationOptions {
    /// Kernel half-width a in seconds, the driver's look-ahead (paper eq. 33; default [`DEFAULT_LOOKAHEAD`]).
    pub lookahead: f64,
    /// Output step in seconds (default [`DEFAULT_DT`]). The grid is t_k = t_0 + k·dt, k = 0 … round(duration/dt).
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
    /// Where the zero-dynamics integrator takes the reference at its stage times: the sub-grid interpolant
    /// (default) or the smoother evaluated pointwise ([`ZeroDynamicsReference`]).
    pub zero_dynamics_reference: ZeroDynamicsReference,
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
    /// Tally the engine's operating points (the summary's `engine_operating_points`, models with an
    /// `[engine]`; default `true`). A sweep turns it off: its rows do not report them.
    pub operating_points: bool,
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
    /// Called with the fraction of the run done after each block of samples (default: none).
    pub progress: Progress,
    /// Signal values given on the command line (`--signal`); the others come from the cycle or the model's
    /// defaults ([`crate::signals::resolve`]). The inverse and its replay use the smoothed signals.
    pub signals: Vec<crate::signals::SignalInput>,
    /// Start values of states given on the command line (`--initial NAME=VALUE`), over the model file's
    /// `initial` ([`crate::initial`]).
    pub initial: Vec<(String, f64)>,
    /// Models with modes: how a switch enters the new mode (default re-entry).
    pub switching: Switching,
    /// Models with modes: the re-entry's transition time, s (default: the look-ahead).
    pub transition_time: Option<f64>,
    /// `--lookahead auto`: the run chooses the look-ahead for its cycle and dt ([`crate::lookahead::choose`])
    /// and `lookahead` is not used (default `false`).
    pub lookahead_auto: bool,
    /// Models with modes and a `[hybrid]` table: the energy-management strategy (`--strategy ecms`;
    /// docs/hybrids.md); `None`: the mode sequence of docs/reference.md §2.5.
    pub strategy: Option<crate::modes::StrategyOptions>,
    /// Differentiate the summary's figures with respect to these parameters (`["all"]`: every one) and report
    /// the derivatives in the summary's `gradient` ([`crate::gradient`]; default `None`: no gradient).
    pub gradient: Option<Vec<String>>,
}

impl Default for SimulationOptions {
    fn default() -> Self {
        SimulationOptions {
            lookahead: DEFAULT_LOOKAHEAD,
            dt: DEFAULT_DT,
            engine: "compiled".to_string(),
            eta0: None,
            rtol: DEFAULT_RTOL,
            atol: DEFAULT_ATOL,
            zero_dynamics_reference: ZeroDynamicsReference::SubGrid,
            stability_check_interval: DEFAULT_STABILITY_CHECK_INTERVAL,
            verify: false,
            keep_series: true,
            operating_points: true,
            causal: false,
            stable_tol: DEFAULT_STABLE_TOL,
            max_pre_actuation: DEFAULT_MAX_PRE_ACTUATION,
            include_extension: false,
            progress: Progress::none(),
            signals: Vec::new(),
            initial: Vec::new(),
            switching: Switching::Reentry,
            transition_time: None,
            lookahead_auto: false,
            strategy: None,
            gradient: None,
        }
    }
}

impl SimulationOptions {
    /// A builder starting from the defaults; [`SimulationOptionsBuilder::build`] validates the values once.
    ///
    /// ```
    /// let opts = invsim_runtime::SimulationOptions::builder().lookahead(5.0).dt(0.1).build()?;
    /// assert_eq!(opts.dt, 0.1);
    /// # Ok::<(), invsim_runtime::SimulateError>(())
    /// ```
    pub fn builder() -> SimulationOptionsBuilder {
        SimulationOptionsBuilder(SimulationOptions::default())
    }

    /// Check the values that do not depend on the model or the cycle: dt, the look-ahead, the tolerances of
    /// the zero-dynamics integrator and the stability check interval (every run checks them again, since the
    /// fields are public).
    pub fn validate(&self) -> Result<(), SimulateError> {
        check_dt(self.dt)?;
        if !(self.lookahead > 0.0 && self.lookahead.is_finite()) {
            return Err(SimulateError::InvalidLookahead(self.lookahead));
        }
        let tol_ok = |v: f64| v > 0.0 && v.is_finite();
        if !(tol_ok(self.rtol) && tol_ok(self.atol)) {
            return Err(SimulateError::InvalidTolerance {
                rtol: self.rtol,
                atol: self.atol,
            });
        }
        if !tol_ok(self.stability_check_interval) {
            return Err(SimulateError::InvalidCheckInterval(
                self.stability_check_interval,
            ));
        }
        if let Some(t) = self.transition_time.filter(|t| !tol_ok(*t)) {
            return Err(SimulateError::InvalidTransitionTime(t));
        }
        Ok(())
    }
}

/// Builds [`SimulationOptions`] (see [`SimulationOptions::builder`]); each setter sets the field of the same
/// name.
#[derive(Debug, Clone)]
pub struct SimulationOptionsBuilder(SimulationOptions);

macro_rules! setters {
    ($($(#[$doc:meta])* $name:ident: $ty:ty),* $(,)?) => {
        impl SimulationOptionsBuilder {
            $(
                $(#[$doc])*
                pub fn $name(mut self, value: $ty) -> Self {
                    self.0.$name = value;
                    self
                }
            )*
        }
    };
}

setters! {
    /// Kernel half-width a, s.
    lookahead: f64,
    /// Output step, s.
    dt: f64,
    /// Relative tolerance of the zero-dynamics integrator.
    rtol: f64,
    /// Absolute tolerance of the zero-dynamics integrator.
    atol: f64,
    /// Where the zero dynamics take the reference at stage times.
    zero_dynamics_reference: ZeroDynamicsReference,
    /// Seconds between two stability checks of a causal run.
    stability_check_interval: f64,
    /// Replay the input through the original model.
    verify: bool,
    /// Keep the time series.
    keep_series: bool,
    /// Tally the engine's operating points.
    operating_points: bool,
    /// Integrate the zero dynamics forward even when unstable.
    causal: bool,
    /// Tolerance of the stable inversion.
    stable_tol: f64,
    /// Longest pre- or post-actuation, s.
    max_pre_actuation: f64,
    /// Keep the pre- and post-actuation samples.
    include_extension: bool,
    /// Models with modes: how a switch enters the new mode.
    switching: Switching,
    /// Models with modes: the re-entry's transition time, s.
    transition_time: Option<f64>,
    /// Choose the look-ahead for the cycle and dt.
    lookahead_auto: bool,
}

impl SimulationOptionsBuilder {
    /// Which implementation of the model is driven (only reported).
    pub fn engine(mut self, engine: impl Into<String>) -> Self {
        self.0.engine = engine.into();
        self
    }

    /// The initial internal state η(t_0) (selects causal integration).
    pub fn eta0(mut self, eta0: Option<Vec<f64>>) -> Self {
        self.0.eta0 = eta0;
        self
    }

    /// The parameters to differentiate the summary's figures by (`["all"]`: every one).
    pub fn gradient(mut self, names: Option<Vec<String>>) -> Self {
        self.0.gradient = names;
        self
    }

    /// A progress callback, called with the fraction of the run done.
    pub fn progress(mut self, progress: Progress) -> Self {
        self.0.progress = progress;
        self
    }

    /// The options, validated ([`SimulationOptions::validate`]).
    pub fn build(self) -> Result<SimulationOptions, SimulateError> {
        self.0.validate()?;
        Ok(self.0)
    }
}
