//! The interface between a derived model and the invsim runtime.
//!
//! Both the Rust code that `invsim-codegen` emits and the interpreter tape in `invsim-inversion` implement
//! [`InverseModel`]; the runtime drives either through it. This crate is deliberately tiny so that generated
//! model crates depend on it alone, not on the whole runtime; [`math`] holds the one numerical routine generated
//! code needs beyond `std`, a vectorised x^y for its batch methods, and [`map`] the smooth lookup maps.
//!
//! Notation (Isidori, *Nonlinear Control Systems*, 3rd ed., §4.1; Fröberg & Nielsen 2004, eq. 24–32):
//! for x' = f(x) + g(x)u, y = h(x) with relative degree r, the normal-form coordinates are
//! ξ = (h, L_f h, …, L_f^{r-1} h) and η (n − r internal coordinates); then
//! y^(r) = α(ξ, η) + β(ξ, η) u, so the input that makes y follow y_d is u = (y_d^(r) − α) / β.

use thiserror::Error;

pub mod headline;
pub mod hybrid;
pub mod math;
pub mod sensitivity;
pub mod zero_dynamics;

/// Smooth lookup maps (contract §6), evaluated by generated code and the interpreter alike; the one kernel
/// implementation lives in `invsim-kernel`.
pub use invsim_kernel::map;

pub use hybrid::{HybridSpec, RuleSpec};
pub use sensitivity::{MapCall, SensitivityLayout};

pub use headline::{
    known_fuel, Carrier, Density, FuelFlow, FuelInfo, HeadlineInfo, KnownFuel, KNOWN_FUELS,
};

/// Static description of a model: names, sizes, bounds, units. Order of every list is the model file's order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ModelInfo {
    /// Model name (the TOML's `name`, or its file stem).
    pub name: String,
    /// The model file's `description` (empty when it has none).
    pub description: String,
    /// SHA-256 of the model file's bytes, lower-case hex, if known.
    pub source_hash: Option<String>,
    /// State names x_1 … x_n.
    pub states: Vec<String>,
    /// Unit of each state (`None` where the model file gives none), in [`ModelInfo::states`] order.
    pub state_units: Vec<Option<String>>,
    /// Input name.
    pub input: String,
    /// Unit of the input.
    pub input_unit: Option<String>,
    /// Tracked output name (y = h(x)).
    pub output: String,
    /// Unit of the tracked output.
    pub output_unit: Option<String>,
    /// Relative degree r.
    pub relative_degree: usize,
    /// Number of internal coordinates η (n − r).
    pub n_eta: usize,
    /// Input bounds (reported, never clipped).
    pub input_min: Option<f64>,
    pub input_max: Option<f64>,
    /// Extra outputs reported per sample.
    pub outputs: Vec<OutputInfo>,
    /// Parameter names, in declaration order (the order of [`InverseModel::params`]).
    pub parameters: Vec<String>,
    /// The engine whose operating points the summary tabulates (the model file's `[engine]`), if any.
    pub engine: Option<EngineInfo>,
    /// The figure the summary leads with (the model file's `[headline]`), if any.
    pub headline: Option<HeadlineInfo>,
    /// Exogenous signals (the model file's `[signals]`), in file order.
    pub signals: Vec<SignalInfo>,
    /// Each state's `initial` value from the model file (`None` where it gives none), in state order.
    pub state_initial: Vec<Option<f64>>,
    /// Indices of the states chosen as the internal coordinates: η_j = x_{eta_states[j]}.
    pub eta_states: Vec<usize>,
    /// The map calls of [`InverseModel::sensitivity`]'s rows, in the order of their columns (none for a model
    /// without maps): what the derivatives with respect to a map's grid values are built from.
    pub map_calls: Vec<MapCall>,
    /// Which results of the inverse do not depend on the internal states η (found from the derived
    /// expressions; the default, for a model that does not say, takes every result to depend on them).
    pub eta_free: EtaFree,
    /// The zero dynamics dη/dt = q(ξ, η, w, y^(r)) are affine in η: q = A(ξ, w, y^(r)) η + b(ξ, w, y^(r))
    /// (found from the derived expressions; false for a model that does not say). A runtime may then
    /// integrate them by the variation of constants.
    pub zero_dynamics_affine: bool,
}

/// Which results of the inverse at a point are functions of (ξ, w, y^(r)) alone, whatever the internal
/// states η: the free input u (u = (y^(r) − α)/β with α, β free of η, or the input's closed-form solution
/// free of η) and each extra output o(x, w, u) along x = ψ⁻¹(ξ, η) (its states' closed forms and u free of
/// η). A state ψ⁻¹ solves by Newton's method (from a start the caller gives) makes every result depend.
/// Strategies use it to reuse a candidate's price across runs whose charge differs (a battery with constant
/// open-circuit voltage and resistance: `modes/price_cache.rs` in the runtime).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct EtaFree {
    /// The free input u.
    pub input: bool,
    /// Each extra output, in [`ModelInfo::outputs`] order (empty: none known free).
    pub outputs: Vec<bool>,
}

impl EtaFree {
    /// Is extra output `i` free of η?
    pub fn output(&self, i: usize) -> bool {
        self.outputs.get(i).copied().unwrap_or(false)
    }
}

impl ModelInfo {
    /// Number of states n.
    pub fn n_states(&self) -> usize {
        self.states.len()
    }

    /// Length of the signal-values slice `w` of every evaluation method: (r + 1) values per signal,
    /// [S, S_d1, …, S_dr] for each signal S in file order (0 for a model without signals).
    pub fn n_w(&self) -> usize {
        self.signals.len() * (self.relative_degree + 1)
    }

    /// The signal values at a constant nominal point: each signal at its default (0 without one), every
    /// derivative 0 (where `derive` classifies the zero dynamics).
    pub fn nominal_w(&self) -> Vec<f64> {
        let r = self.relative_degree;
        let mut w = vec![0.0; self.n_w()];
        for (i, s) in self.signals.iter().enumerate() {
            w[i * (r + 1)] = s.default.unwrap_or(0.0);
        }
        w
    }
}

/// One exogenous signal of the model's `[signals]` table: a time-varying quantity the model does not control
/// (road grade, auxiliary load), known over the whole run in advance.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SignalInfo {
    pub name: String,
    pub unit: Option<String>,
    pub doc: Option<String>,
    /// The value used when neither the command line nor the cycle file gives the signal.
    pub default: Option<f64>,
    /// The cycle file's column to read it from (`None`: the signal's name; `grade` also matches `cycGrade`).
    pub column: Option<String>,
}

/// One entry of the model's `[outputs]` table.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OutputInfo {
    pub name: String,
    pub unit: Option<String>,
    /// Integrate this output over the run and report the integral.
    pub accumulate: bool,
    /// The integral means something per distance driven: the summary gives it per 100 km (the model file's
    /// `per_distance`; default: accumulated outputs of a model that tracks the cycle's speed itself).
    pub per_distance: bool,
}

/// The model's engine: the two `[outputs]` entries that give its speed and torque (the model file's
/// `[engine] speed = "…", torque = "…"`), by index into [`ModelInfo::outputs`], and the engine map the
/// operating points are drawn over, if the file gives one.
#[derive(Debug, Clone, PartialEq)]
pub struct EngineInfo {
    pub speed: usize,
    pub torque: usize,
    pub map: Option<EngineMapInfo>,
}

/// The model file's `[engine] map`: an expression in the engine's speed and torque (the two outputs' names),
/// the parameters and the maps, e.g. a BSFC map `bsfc(n_e*pi/30, T_e)` in g/kWh.
#[derive(Debug, Clone, PartialEq)]
pub struct EngineMapInfo {
    pub expr: String,
    pub unit: Option<String>,
    /// The colour scale's ends (`map_range`), if the file gives them.
    pub range: Option<[f64; 2]>,
}

/// How the drive cycle defines the reference of the tracked output: y_d = `offset` + `scale` · (smoothed cycle),
/// so y_d^(k) = `scale` · (smoothed cycle)^(k) for k ≥ 1 and every derivative stays exact. The identity map
/// (offset 0, scale 1) makes the output follow the cycle's speed itself; a model whose output is not a vehicle
/// speed (a boost pressure, an engine speed) declares its map in the model file's `[output]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceMap {
    pub offset: f64,
    pub scale: f64,
}

impl ReferenceMap {
    /// y_d = smoothed cycle.
    pub const IDENTITY: ReferenceMap = ReferenceMap {
        offset: 0.0,
        scale: 1.0,
    };

    /// True for the identity map.
    pub fn is_identity(&self) -> bool {
        self.offset == 0.0 && self.scale == 1.0
    }
}

impl Default for ReferenceMap {
    fn default() -> Self {
        ReferenceMap::IDENTITY
    }
}

/// Errors a model can report while being evaluated.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ModelError {
    #[error("unknown parameter `{name}` (the model declares: {known})")]
    UnknownParameter { name: String, known: String },
    #[error("parameter `{name}` must be finite, got {value}")]
    NonFiniteParameter { name: String, value: f64 },
    #[error(
        "Newton's method for ψ⁻¹ did not converge in {iterations} iterations (residual {residual:e}); \
         state guess may be far from the solution or the Jacobian singular"
    )]
    NewtonDidNotConverge { iterations: usize, residual: f64 },
    #[error(
        "no value of the input reaches y^(r) = {yr:e} here: the model is not affine in the input and \
         y^(r) = φ(ξ, η, w, u) has no real root u (closest residual {residual:e})"
    )]
    NoInputSolution { yr: f64, residual: f64 },
    #[error("unknown map `{name}` (the model declares: {known})")]
    UnknownMap { name: String, known: String },
    #[error("cannot replace map `{name}`: {reason}")]
    BadMap { name: String, reason: String },
    #[error("this engine of model `{model}` provides no parameter sensitivities")]
    NoSensitivities { model: String },
}

/// Replace the data of the map `name` among `maps` (named in the same order by `names`), keeping its
/// settings (shared by every implementation of [`InverseModel::set_map`]).
pub fn set_map_checked(
    maps: &mut [map::Map],
    names: &[&str],
    name: &str,
    data: (&[f64], Option<&[f64]>, &[f64]),
) -> Result<(), ModelError> {
    let Some(i) = names.iter().position(|n| *n == name) else {
        let known = if names.is_empty() {
            "none".to_string()
        } else {
            names.join(", ")
        };
        return Err(ModelError::UnknownMap {
            name: name.to_string(),
            known,
        });
    };
    let (x, y, values) = data;
    maps[i] = maps[i]
        .with_data(x.to_vec(), y.map(<[f64]>::to_vec), values.to_vec())
        .map_err(|e| ModelError::BadMap {
            name: name.to_string(),
            reason: e.to_string(),
        })?;
    Ok(())
}

/// A derived model: α, β, ψ, ψ⁻¹, the zero dynamics, the original right-hand side and the extra outputs.
///
/// Slices have the lengths given by [`ModelInfo`]: `xi` has r entries, `eta` n − r, `x` n, `outputs` the
/// number of `[outputs]`, `w` [`ModelInfo::n_w`] (the signal values [S, S_d1, …, S_dr] per signal S in file
/// order; empty for a model without signals). Implementations may panic on wrong lengths (a programming
/// error, not user data). With signals, every Lie derivative is a total time derivative (the signals'
/// derivatives enter through `w`), so ψ, ψ⁻¹, α, β and the zero dynamics depend on `w`.
pub trait InverseModel: Send + Sync {
    /// Names, sizes and bounds.
    fn info(&self) -> &ModelInfo;
    /// Current parameter values, in [`ModelInfo::parameters`] order.
    fn params(&self) -> &[f64];
    /// Override one parameter by name (`--set NAME=VALUE`).
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ModelError>;
    /// Replace a lookup map's grid and values, keeping its settings (`--map NAME=FILE.csv`, contract §6):
    /// `data` = (x grid, y grid for a 2-D map, values row-major). Models without maps refuse every name.
    fn set_map(
        &mut self,
        name: &str,
        data: (&[f64], Option<&[f64]>, &[f64]),
    ) -> Result<(), ModelError> {
        set_map_checked(&mut [], &[], name, data)
    }

    /// The model's lookup maps (contract §6) in the model file's order, each named as there (models without
    /// maps: none).
    fn maps(&self) -> &[map::Map] {
        &[]
    }

    /// The tracked output y = h(x).
    fn h(&self, x: &[f64], w: &[f64]) -> f64;
    /// Normal-form coordinates (ξ, η) = ψ(x).
    fn psi(&self, x: &[f64], w: &[f64], xi: &mut [f64], eta: &mut [f64]);
    /// x = ψ⁻¹(ξ, η). On entry `x` holds a guess, used only where ψ⁻¹ is solved numerically.
    fn psi_inv(&self, xi: &[f64], eta: &[f64], w: &[f64], x: &mut [f64]) -> Result<(), ModelError>;
    /// α(ξ, η) = L_f^r h ∘ ψ⁻¹.
    fn alpha(&self, xi: &[f64], eta: &[f64], w: &[f64]) -> f64;
    /// β(ξ, η) = L_g L_f^{r−1} h ∘ ψ⁻¹.
    fn beta(&self, xi: &[f64], eta: &[f64], w: &[f64]) -> f64;
    /// dη/dt = q(ξ, η, y^(r)) = L_f η + L_g η · (y^(r) − α)/β, written into `deta`.
    fn zero_dynamics(&self, xi: &[f64], eta: &[f64], w: &[f64], yr: f64, deta: &mut [f64]);
    /// The original model dx/dt = f(x) + g(x) u, written into `dx`.
    fn rhs(&self, x: &[f64], w: &[f64], u: f64, dx: &mut [f64]);
    /// The extra outputs of `[outputs]` at (x, u), written into `out`.
    fn outputs(&self, x: &[f64], w: &[f64], u: f64, out: &mut [f64]);

    /// The partial derivatives of ψ's ξ rows, of y^(r) = φ, of the internal states' right-hand sides and of
    /// the `[outputs]` with respect to the states, the input, every parameter and every map call of
    /// [`ModelInfo::map_calls`], and the calls' arguments, at (x, w, u), written into
    /// `out` as [`SensitivityLayout::of`] this model's info lays them out (see [`sensitivity`] for how the
    /// runtime combines them). Engines without them return [`ModelError::NoSensitivities`].
    fn sensitivity(&self, x: &[f64], w: &[f64], u: f64, out: &mut [f64]) -> Result<(), ModelError> {
        let _ = (x, w, u, out);
        Err(ModelError::NoSensitivities {
            model: self.info().name.clone(),
        })
    }

    /// The zero dynamics' partial derivatives ∂q/∂(η, ξ, y^(r), p) at (ξ, η, w, y^(r)), for dη/dt =
    /// q(ξ, η, w, y^(r); p), written row-major into `out`: n_η rows (the internal states) of n_η + r + 1 + P
    /// columns (η_1 … η_(n−r), ξ_1 … ξ_r, y^(r), then the parameters in [`ModelInfo::parameters`]' order).
    /// They equal what the runtime assembles from [`InverseModel::sensitivity`] by the implicit function
    /// theorem, in one evaluation. `false`, with `out` untouched, where the model has none (the default: ψ⁻¹
    /// or the input solved numerically, no internal states).
    fn zero_dynamics_jacobian(
        &self,
        xi: &[f64],
        eta: &[f64],
        w: &[f64],
        yr: f64,
        out: &mut [f64],
    ) -> bool {
        let _ = (xi, eta, w, yr, out);
        false
    }

    /// Zero dynamics affine in η ([`ModelInfo::zero_dynamics_affine`]), q(ξ, η, w, y^(r)) = A η + b: A
    /// row-major (n_η × n_η) then b, written into `out` (n_η (n_η + 1) values) from one evaluation at
    /// (ξ, w, y^(r)). `false`, with `out` untouched, where the model has none (the default; the runtime then
    /// takes b and A from [`InverseModel::zero_dynamics`] at η = 0 and at a second η).
    fn zero_dynamics_affine(&self, xi: &[f64], w: &[f64], yr: f64, out: &mut [f64]) -> bool {
        let _ = (xi, w, yr, out);
        false
    }

    /// The extra outputs' partial derivatives ∂o/∂(η, ξ, y^(r), p) at the point (x, w, u), the outputs taken as
    /// functions o(ψ⁻¹(ξ, η), w, u) of the normal-form coordinates with u = (y^(r) − α)/β, at ξ = ψ_ξ(x),
    /// η = x_η, y^(r) = α + β·u: row-major, a row per output of n_η + r + 1 + P columns (as
    /// [`InverseModel::zero_dynamics_jacobian`]'s). `false`, with `out` untouched, where the model has none
    /// (the default: ψ⁻¹ or the input solved numerically, no extra outputs).
    fn outputs_jacobian(&self, x: &[f64], w: &[f64], u: f64, out: &mut [f64]) -> bool {
        let _ = (x, w, u, out);
        false
    }

    /// How a drive cycle defines this output's reference (default: y_d is the smoothed cycle itself).
    fn reference(&self) -> ReferenceMap {
        ReferenceMap::IDENTITY
    }

    /// Inverse at one point: x = ψ⁻¹(ξ, η) into `x` and u = (y^(r) − α)/β returned (paper eq. 26).
    fn invert(
        &self,
        xi: &[f64],
        eta: &[f64],
        w: &[f64],
        yr: f64,
        x: &mut [f64],
    ) -> Result<f64, ModelError> {
        self.psi_inv(xi, eta, w, x)?;
        Ok((yr - self.alpha(xi, eta, w)) / self.beta(xi, eta, w))
    }

    /// [`InverseModel::invert`] with a guess for the input: where u solves y^(r) = φ(ξ, η, w, u) by Newton's
    /// method (a model whose y^(r) is not affine in u, without a closed-form input solution), Newton starts
    /// from `u_guess`, the previous sample's input, so that a run follows one continuous root; a NaN guess
    /// starts from the model's own start (the middle of the input's bounds). Elsewhere the guess is ignored.
    fn invert_from(
        &self,
        xi: &[f64],
        eta: &[f64],
        w: &[f64],
        yr: f64,
        x: &mut [f64],
        u_guess: f64,
    ) -> Result<f64, ModelError> {
        let _ = u_guess;
        self.invert(xi, eta, w, yr, x)
    }

    /// [`InverseModel::zero_dynamics`] where the input u in them solves y^(r) = φ(ξ, η, w, u) by Newton's
    /// method: it starts from `u_guess` (the previous sample's input, as in [`InverseModel::invert_from`]),
    /// so that η moves with the same root as the inverse; elsewhere the guess is ignored.
    fn zero_dynamics_from(
        &self,
        xi: &[f64],
        eta: &[f64],
        w: &[f64],
        yr: f64,
        u_guess: f64,
        deta: &mut [f64],
    ) {
        let _ = u_guess;
        self.zero_dynamics(xi, eta, w, yr, deta)
    }

    /// The inverse at many points, stored column-wise: ξ_i at point k is `xi[i][k]`, η_j is `eta[j][k]`,
    /// the signal value w_l is `w[l][k]`, y^(r) is `yr[k]`; x_s is written to `x[s][k]` and u to `u[k]`. On entry `x[s][0]` is the guess for the
    /// first point (where ψ⁻¹ is numeric) and `u[0]` the guess for its input (NaN: none, see
    /// [`InverseModel::invert_from`]); each later point starts from its predecessor.
    ///
    /// Returns the index of the first point that fails, with its error. The default calls
    /// [`InverseModel::invert`] point by point; an interpreter overrides it to amortise its dispatch.
    fn invert_batch(
        &self,
        xi: &[&[f64]],
        eta: &[&[f64]],
        w: &[&[f64]],
        yr: &[f64],
        x: &mut [&mut [f64]],
        u: &mut [f64],
    ) -> Result<(), (usize, ModelError)> {
        invert_pointwise(self, xi, eta, w, yr, x, u)
    }

    /// [`InverseModel::sensitivity`] at many points, column-wise: `x[s][k]`, `w[l][k]`, `u[k]` in, entry e of
    /// point k (the layout of [`SensitivityLayout`]) to `out[e][k]`. Without `invariant`, the entries that
    /// depend on none of x, w and u (most are 0) may be left as they are: the caller has them from an earlier
    /// call with the same parameters and at least as many points. An empty `out[e]` is an entry the caller
    /// does not want: it is not written (a compiled model does not compute it). Returns the index of the
    /// first point that fails, with its error. The default calls [`InverseModel::sensitivity`] point by point
    /// (and writes every entry wanted).
    fn sensitivity_batch(
        &self,
        x: &[&[f64]],
        w: &[&[f64]],
        u: &[f64],
        (out, invariant): (&mut [&mut [f64]], bool),
    ) -> Result<(), (usize, ModelError)> {
        let _ = invariant;
        columns_pointwise((x, w, u), out, |x, w, u, s| self.sensitivity(x, w, u, s))
    }

    /// The extra outputs at many points, column-wise: `x[s][k]`, `w[l][k]`, `u[k]` in, `out[o][k]` out. The
    /// default calls [`InverseModel::outputs`] point by point.
    fn outputs_batch(&self, x: &[&[f64]], w: &[&[f64]], u: &[f64], out: &mut [&mut [f64]]) {
        let each = columns_pointwise((x, w, u), out, |x, w, u, o| {
            self.outputs(x, w, u, o);
            Ok::<(), std::convert::Infallible>(())
        });
        if let Err((_, never)) = each {
            match never {}
        }
    }
}

/// A batch method point by point: point k of the columns `x`, `w` and `u` handed to `f` with a buffer for
/// `out.len()` results, which go to `out[·][k]`; the first failing point's index with its error.
fn columns_pointwise<E>(
    (x, w, u): (&[&[f64]], &[&[f64]], &[f64]),
    out: &mut [&mut [f64]],
    mut f: impl FnMut(&[f64], &[f64], f64, &mut [f64]) -> Result<(), E>,
) -> Result<(), (usize, E)> {
    let mut x_k = vec![0.0; x.len()];
    let mut w_k = vec![0.0; w.len()];
    let mut o_k = vec![0.0; out.len()];
    for (k, &u_k) in u.iter().enumerate() {
        for (v, c) in x_k.iter_mut().zip(x) {
            *v = c[k];
        }
        for (v, c) in w_k.iter_mut().zip(w) {
            *v = c[k];
        }
        f(&x_k, &w_k, u_k, &mut o_k).map_err(|e| (k, e))?;
        // An empty column is not wanted ([`InverseModel::sensitivity_batch`]).
        for (c, &v) in out.iter_mut().zip(&o_k).filter(|(c, _)| !c.is_empty()) {
            c[k] = v;
        }
    }
    Ok(())
}

/// Look up a parameter index by name, with an error listing the known names.
pub fn param_index(info: &ModelInfo, name: &str) -> Result<usize, ModelError> {
    info.parameters
        .iter()
        .position(|p| p == name)
        .ok_or_else(|| ModelError::UnknownParameter {
            name: name.to_string(),
            known: info.parameters.join(", "),
        })
}

/// Check an override value and store it (shared by every implementation of `set_param`).
pub fn set_param_checked(
    info: &ModelInfo,
    params: &mut [f64],
    name: &str,
    value: f64,
) -> Result<(), ModelError> {
    if !value.is_finite() {
        return Err(ModelError::NonFiniteParameter {
            name: name.to_string(),
            value,
        });
    }
    let i = param_index(info, name)?;
    params[i] = value;
    Ok(())
}

/// [`InverseModel::invert_batch`] point by point through [`InverseModel::invert`], each point warm-started
/// from its predecessor's state (the default implementation, also for implementors that override the batch
/// only in some cases).
pub fn invert_pointwise<M: InverseModel + ?Sized>(
    model: &M,
    xi: &[&[f64]],
    eta: &[&[f64]],
    w: &[&[f64]],
    yr: &[f64],
    x: &mut [&mut [f64]],
    u: &mut [f64],
) -> Result<(), (usize, ModelError)> {
    let mut xi_k = vec![0.0; xi.len()];
    let mut eta_k = vec![0.0; eta.len()];
    let mut w_k = vec![0.0; w.len()];
    let mut x_k: Vec<f64> = x
        .iter()
        .map(|c| c.first().copied().unwrap_or(0.0))
        .collect();
    // The input's guess: the caller's for the first point, then the previous point's input.
    let mut u_guess = u.first().copied().unwrap_or(f64::NAN);
    for k in 0..yr.len() {
        for (v, c) in xi_k.iter_mut().zip(xi) {
            *v = c[k];
        }
        for (v, c) in eta_k.iter_mut().zip(eta) {
            *v = c[k];
        }
        for (v, c) in w_k.iter_mut().zip(w) {
            *v = c[k];
        }
        u[k] = model
            .invert_from(&xi_k, &eta_k, &w_k, yr[k], &mut x_k, u_guess)
            .map_err(|e| (k, e))?;
        u_guess = u[k];
        for (c, &v) in x.iter_mut().zip(&x_k) {
            c[k] = v;
        }
    }
    Ok(())
}
