//! The interpreted engine: a [`Derivation`] compiled to instruction tapes, implementing
//! [`InverseModel`] for any model file without generating Rust code.
//!
//! Each function is one tape over its varying inputs and the parameters. Because parameters change only
//! through [`InverseModel::set_param`], every tape is *specialised* to the current parameter values
//! ([`Tape::specialize`]): all parameter-only subexpressions (m_eff, the friction constants, …) are evaluated
//! once, and per-point evaluation runs only what depends on ξ, η, x or u.

use crate::derive::{Derivation, Solution};
use invsim_expr::{Id, Symbol, Tape};
use invsim_model_api::{
    set_param_checked, EngineInfo, InverseModel, ModelError, ModelInfo, OutputInfo, ReferenceMap,
    SignalInfo,
};
use thiserror::Error;

/// A tape could not be built (an expression referred to a symbol outside its inputs — a bug in the
/// derivation, reported rather than panicking).
#[derive(Debug, Clone, Error)]
#[error("cannot compile `{what}` for the interpreter: {source}")]
pub struct InterpretError {
    pub what: &'static str,
    #[source]
    pub source: invsim_expr::UnboundSymbol,
}

use invsim_model_api::zero_dynamics::{
    ISOLATED_INPUT_TOL, PSI_INV_NEWTON_MAX_ITER, PSI_INV_NEWTON_TOL,
};

/// Largest state dimension evaluated with stack buffers (larger models use the heap).
const STACK: usize = 16;

/// The model's static description (shared with generated code, which builds the same struct).
pub fn model_info(d: &Derivation) -> ModelInfo {
    let m = &d.model;
    ModelInfo {
        name: m.name.clone(),
        description: m.description.clone().unwrap_or_default(),
        source_hash: Some(m.source_hash.clone()),
        states: m.states.iter().map(|s| s.name.clone()).collect(),
        state_units: m.states.iter().map(|s| s.unit.clone()).collect(),
        input: m.input.name.clone(),
        input_unit: m.input.unit.clone(),
        output: m.output.name.clone(),
        output_unit: m.output.unit.clone(),
        relative_degree: d.relative_degree,
        n_eta: d.eta.len(),
        input_min: m.input.min,
        input_max: m.input.max,
        outputs: m
            .outputs
            .iter()
            .map(|o| OutputInfo {
                name: o.name.clone(),
                unit: o.unit.clone(),
                accumulate: o.accumulate,
                per_distance: o.per_distance,
            })
            .collect(),
        parameters: m.parameters.iter().map(|p| p.name.clone()).collect(),
        engine: m.engine.as_ref().map(|e| EngineInfo {
            speed: e.speed,
            torque: e.torque,
            map: e.map.clone(),
        }),
        headline: m.headline.clone(),
        state_initial: m.states.iter().map(|s| s.initial).collect(),
        eta_states: d.eta_states.clone(),
        map_calls: d.map_calls.clone(),
        eta_free: d.eta_free(),
        zero_dynamics_affine: d.zero_dynamics_affine.is_some(),
        signals: m
            .signals
            .iter()
            .map(|s| SignalInfo {
                name: s.name.clone(),
                unit: s.unit.clone(),
                doc: s.doc.clone(),
                default: s.default,
                column: s.column.clone(),
            })
            .collect(),
    }
}

/// The tapes of one model, over (varying inputs, parameters); the signal values `w` are varying inputs of
/// every tape, after the coordinates (x, or ξ and η).
#[derive(Debug, Clone)]
struct Tapes {
    /// (ξ, η, w) → (x, α, β); empty when ψ⁻¹ is not closed-form.
    invert: Tape,
    /// (ξ, η, w) → (α, β); empty when ψ⁻¹ is not closed-form.
    alpha_beta: Tape,
    /// (x, w) → (ψ, ∂ψ/∂x row-major, α_x, β_x).
    newton: Tape,
    /// (x, w) → h.
    h: Tape,
    /// (ξ, η, w, yr, u) → dη/dt when ψ⁻¹ is closed-form, else (x, w, yr, u) → dη/dt (u only where the zero
    /// dynamics contain the input: a non-affine y^(r) solved by Newton's method).
    zero: Tape,
    /// (x, w, u) → f + g u.
    rhs: Tape,
    /// (x, w, u) → the `[outputs]`.
    outputs: Tape,
    /// (x, w, u) → the sensitivities' partial derivatives (`Derivation::sensitivity`), built from the
    /// unspecialised expressions and specialised like every other tape.
    sensitivity: Tape,
    /// Non-affine models: (ξ, η, w, u) → (φ, ∂φ/∂u), y^(r) = φ, where ψ⁻¹ is closed-form, else
    /// (x, w, u) → (φ, ∂φ/∂u) in the states; empty for affine ones.
    phi: Tape,
    /// Non-affine models with an input solution: (ξ, η, w, yr) → u where ψ⁻¹ is closed-form, else
    /// (x, w, yr) → u; empty otherwise.
    solution: Tape,
    /// (ξ, η, w, yr) → ∂(dη/dt)/∂(η, ξ, y^(r), p) (`Derivation::zero_dynamics_jacobian`); `None` where the
    /// derivation has none.
    zero_jacobian: Option<Tape>,
    /// (ξ, η, w, yr) → [∂q/∂η row-major, q] of zero dynamics affine in η (`Derivation::zero_dynamics_affine`;
    /// at η = 0, A and b of q = A η + b); `None` where they are not affine.
    zero_affine: Option<Tape>,
    /// (x, w, u) → ∂o/∂(η, ξ, y^(r), p) (`Derivation::outputs_jacobian`); `None` where the derivation has
    /// none.
    outputs_jacobian: Option<Tape>,
}

impl Tapes {
    fn set_map(&mut self, index: usize, data: &std::sync::Arc<invsim_model_api::map::Map>) {
        for t in [
            &mut self.invert,
            &mut self.alpha_beta,
            &mut self.newton,
            &mut self.h,
            &mut self.zero,
            &mut self.rhs,
            &mut self.outputs,
            &mut self.sensitivity,
            &mut self.phi,
            &mut self.solution,
        ]
        .into_iter()
        .chain(self.zero_jacobian.as_mut())
        .chain(self.zero_affine.as_mut())
        .chain(self.outputs_jacobian.as_mut())
        {
            t.set_map(index, data.clone());
        }
    }

    fn specialize(&self, p: &[f64]) -> Tapes {
        Tapes {
            invert: self.invert.specialize(p),
            alpha_beta: self.alpha_beta.specialize(p),
            newton: self.newton.specialize(p),
            h: self.h.specialize(p),
            zero: self.zero.specialize(p),
            rhs: self.rhs.specialize(p),
            outputs: self.outputs.specialize(p),
            sensitivity: self.sensitivity.specialize(p),
            phi: self.phi.specialize(p),
            solution: self.solution.specialize(p),
            zero_jacobian: self.zero_jacobian.as_ref().map(|t| t.specialize(p)),
            zero_affine: self.zero_affine.as_ref().map(|t| t.specialize(p)),
            outputs_jacobian: self.outputs_jacobian.as_ref().map(|t| t.specialize(p)),
        }
    }
}

/// Interpreted model: every function of [`InverseModel`] evaluated from a tape.
#[derive(Debug, Clone)]
pub struct Interpreter {
    info: ModelInfo,
    reference: ReferenceMap,
    params: Vec<f64>,
    n: usize,
    r: usize,
    closed: bool,
    /// Every right-hand side affine in the input (else u solves y^(r) = φ(ξ, η, w, u), see `solve_input`).
    affine: bool,
    /// Where Newton's method for u starts: the middle of [min, max], a bound if only one is given, else 0.
    u_start: f64,
    generic: Tapes,
    special: Tapes,
    /// The model's maps (contract §6) by `MapId` index, and their names.
    maps: Vec<invsim_model_api::map::Map>,
    map_names: Vec<String>,
}

fn compile(
    d: &Derivation,
    what: &'static str,
    exprs: &[Id],
    inputs: &[Symbol],
) -> Result<Tape, InterpretError> {
    Tape::compile(d.pool(), exprs, inputs).map_err(|source| InterpretError { what, source })
}

/// The tapes of a non-affine model (empty for an affine one): (ξ, η, w, u) → (φ, ∂φ/∂u) and, where u can be
/// isolated, (ξ, η, w, yr) → u; where ψ⁻¹ is solved numerically the same in the states, (x, w, u) and
/// (x, w, yr) (φ = D^r h and u isolated from φ(x, w, u) = yr, evaluated at Newton's x = ψ⁻¹(ξ, η)).
fn non_affine_tapes(d: &Derivation, params: &[Symbol]) -> Result<(Tape, Tape), InterpretError> {
    let u = d.model.input.symbol;
    let states = d.model.state_symbols();
    let (phi_exprs, sol_exprs, coords): (Vec<Id>, Vec<Id>, Vec<Symbol>) = if d.yr_affine {
        (Vec::new(), Vec::new(), Vec::new())
    } else if d.psi_inv_closed() {
        (
            vec![d.alpha, d.beta],
            d.input_solution.into_iter().collect(),
            cat(&[&d.xi, &d.eta]),
        )
    } else {
        (
            vec![d.alpha_x, d.beta_x],
            d.input_solution_x.into_iter().collect(),
            states,
        )
    };
    Ok((
        compile(
            d,
            "y^(r) and its ∂/∂u",
            &phi_exprs,
            &cat(&[&coords, &d.w, &[u], params]),
        )?,
        compile(
            d,
            "the input solution",
            &sol_exprs,
            &cat(&[&coords, &d.w, &[d.yr], params]),
        )?,
    ))
}

/// `tape` at the inputs `parts` into `out`, if there is a tape (an optional function of the model).
fn evaluated(tape: Option<&Tape>, parts: &[&[f64]], out: &mut [f64]) -> bool {
    tape.map(|t| t.eval_parts(parts, out)).is_some()
}

fn cat(parts: &[&[Symbol]]) -> Vec<Symbol> {
    parts.iter().flat_map(|p| p.iter().copied()).collect()
}

impl Interpreter {
    pub fn new(d: &Derivation) -> Result<Interpreter, InterpretError> {
        let m = &d.model;
        let params: Vec<Symbol> = m.parameters.iter().map(|p| p.symbol).collect();
        let states = m.state_symbols();
        let u = m.input.symbol;
        let closed = d.psi_inv_closed();
        let w = &d.w;
        let xi_eta_p = cat(&[&d.xi, &d.eta, w, &params]);
        let x_p = cat(&[&states, w, &params]);
        let x_u_p = cat(&[&states, w, &[u], &params]);

        let (invert, alpha_beta) = if closed {
            let mut exprs: Vec<Id> = d
                .psi_inv
                .iter()
                .filter_map(|s| match s {
                    Solution::Closed(e) => Some(*e),
                    Solution::Numeric => None,
                })
                .collect();
            if d.yr_affine {
                exprs.push(d.alpha);
                exprs.push(d.beta);
                (
                    compile(d, "ψ⁻¹, α, β", &exprs, &xi_eta_p)?,
                    compile(d, "α, β", &[d.alpha, d.beta], &xi_eta_p)?,
                )
            } else {
                (
                    compile(d, "ψ⁻¹", &exprs, &xi_eta_p)?,
                    compile(d, "α, β", &[], &xi_eta_p)?,
                )
            }
        } else {
            (
                compile(d, "ψ⁻¹, α, β", &[], &xi_eta_p)?,
                compile(d, "α, β", &[], &xi_eta_p)?,
            )
        };
        let mut newton_exprs: Vec<Id> = d.psi.clone();
        for row in &d.jacobian {
            newton_exprs.extend(row.iter().copied());
        }
        if d.yr_affine {
            newton_exprs.push(d.alpha_x);
            newton_exprs.push(d.beta_x);
        } else {
            // φ and ∂φ/∂u contain u: a non-affine model is solved in (ξ, η) (`phi`), these slots are unused.
            newton_exprs.push(m.output.h);
            newton_exprs.push(m.output.h);
        }
        let newton = compile(d, "ψ and its Jacobian", &newton_exprs, &x_p)?;
        let h = compile(d, "h", &[m.output.h], &x_p)?;
        let zero = if closed {
            compile(
                d,
                "zero dynamics",
                &d.zero_dynamics,
                &cat(&[&d.xi, &d.eta, w, &[d.yr, u], &params]),
            )?
        } else {
            compile(
                d,
                "zero dynamics",
                &d.zero_dynamics_x,
                &cat(&[&states, w, &[d.yr, u], &params]),
            )?
        };
        let rhs: Vec<Id> = m.states.iter().map(|s| s.rhs).collect();
        let rhs = compile(d, "f + g u", &rhs, &x_u_p)?;
        let outs: Vec<Id> = m.outputs.iter().map(|o| o.expr).collect();
        let outputs = compile(d, "outputs", &outs, &x_u_p)?;
        let sensitivity = compile(d, "the sensitivities", &d.sensitivity, &x_u_p)?;
        let (phi, solution) = non_affine_tapes(d, &params)?;
        let optional = |what: &'static str, e: &Option<Vec<Id>>, inputs: &[Symbol]| {
            e.as_ref().map(|e| compile(d, what, e, inputs)).transpose()
        };
        let zero_jacobian = optional(
            "the zero dynamics' partial derivatives",
            &d.zero_dynamics_jacobian,
            &cat(&[&d.xi, &d.eta, w, &[d.yr], &params]),
        )?;
        let zero_affine = optional(
            "the affine zero dynamics' coefficients",
            &d.zero_dynamics_affine,
            &cat(&[&d.xi, &d.eta, w, &[d.yr], &params]),
        )?;
        let outputs_jacobian = optional(
            "the outputs' partial derivatives",
            &d.outputs_jacobian,
            &x_u_p,
        )?;
        let generic = Tapes {
            zero_jacobian,
            zero_affine,
            outputs_jacobian,
            phi,
            solution,
            invert,
            alpha_beta,
            newton,
            h,
            zero,
            rhs,
            outputs,
            sensitivity,
        };
        let values: Vec<f64> = m.parameters.iter().map(|p| p.value).collect();
        let special = generic.specialize(&values);
        Ok(Interpreter {
            info: model_info(d),
            reference: ReferenceMap {
                offset: m.output.reference_offset,
                scale: m.output.reference_scale,
            },
            params: values,
            n: states.len(),
            r: d.relative_degree,
            closed,
            affine: d.yr_affine,
            u_start: match (m.input.min, m.input.max) {
                (Some(lo), Some(hi)) => 0.5 * (lo + hi),
                (Some(b), None) | (None, Some(b)) => b,
                (None, None) => 0.0,
            },
            generic,
            special,
            maps: d.pool().maps().iter().map(|m| (*m.data).clone()).collect(),
            map_names: d.pool().maps().iter().map(|m| m.name.clone()).collect(),
        })
    }

    /// Number of per-point instructions of the fused (x, α, β) tape (after parameter hoisting).
    pub fn invert_cost(&self) -> usize {
        self.special.invert.len()
    }

    /// Newton's method on ψ(x) = (ξ, η) from the guess in `x`, with the analytic Jacobian (LU-solved).
    fn newton(&self, xi: &[f64], eta: &[f64], w: &[f64], x: &mut [f64]) -> Result<(), ModelError> {
        let n = self.n;
        let mut buf = vec![0.0; n + n * n + 2];
        let mut residual = f64::INFINITY;
        for _ in 0..PSI_INV_NEWTON_MAX_ITER {
            self.special.newton.eval_parts(&[x, w], &mut buf);
            let target = |i: usize| if i < self.r { xi[i] } else { eta[i - self.r] };
            let res = nalgebra::DVector::from_fn(n, |i, _| buf[i] - target(i));
            residual = (0..n)
                .map(|i| res[i].abs() / target(i).abs().max(1.0))
                .fold(0.0, f64::max);
            if residual < PSI_INV_NEWTON_TOL {
                return Ok(());
            }
            let jac = nalgebra::DMatrix::from_fn(n, n, |i, j| buf[n + i * n + j]);
            let Some(step) = jac.lu().solve(&res) else {
                break;
            };
            for i in 0..n {
                x[i] -= step[i];
            }
            if !x.iter().all(|v| v.is_finite()) {
                break;
            }
        }
        Err(ModelError::NewtonDidNotConverge {
            iterations: PSI_INV_NEWTON_MAX_ITER,
            residual,
        })
    }

    /// (φ, ∂φ/∂u) of a non-affine model at (coordinates, w, u): the coordinates are `[ξ, η]` where ψ⁻¹ is
    /// closed-form, `[x]` where it is solved numerically.
    fn phi(&self, at: [&[f64]; 2], w: &[f64], u: f64) -> (f64, f64) {
        let mut out = [0.0; 2];
        self.special
            .phi
            .eval_parts(&[at[0], at[1], w, &[u]], &mut out);
        (out[0], out[1])
    }

    /// u with y^(r) = φ(ξ, η, w, u) = yr (non-affine models): the input solution where u was isolated (checked
    /// to satisfy φ(u) = yr within [`ISOLATED_INPUT_TOL`], relative), else
    /// Newton's method with the analytic ∂φ/∂u from `start` (the previous sample's input; NaN: the middle of
    /// the input's bounds, 0 without bounds), each step halved until |φ − yr| decreases; converged when the
    /// step is below 1e-12·(1 + |u|). `at`: the coordinates as in [`Interpreter::phi`].
    fn solve_input(
        &self,
        at: [&[f64]; 2],
        w: &[f64],
        yr: f64,
        start: f64,
    ) -> Result<f64, ModelError> {
        if self.special.solution.n_outputs() > 0 {
            let mut u = [0.0];
            self.special
                .solution
                .eval_parts(&[at[0], at[1], w, &[yr]], &mut u);
            if !u[0].is_finite() {
                return Err(ModelError::NoInputSolution {
                    yr,
                    residual: f64::NAN,
                });
            }
            // The isolated u holds only on its branch's domain (sqrt(P) = R gives P = R², a root only for
            // R ≥ 0): outside it φ(u) ≠ yr, and the reference needs a value no input reaches (a negative
            // thrust from k_T·sqrt(P)).
            let (phi, _) = self.phi(at, w, u[0]);
            let residual = (phi - yr).abs();
            // NaN is refused too.
            let solves = residual <= ISOLATED_INPUT_TOL * (1.0 + yr.abs() + phi.abs());
            if !solves {
                return Err(ModelError::NoInputSolution { yr, residual });
            }
            return Ok(u[0]);
        }
        let mut u = if start.is_finite() {
            start
        } else {
            self.u_start
        };
        let (mut phi, mut dphi) = self.phi(at, w, u);
        let mut residual = (phi - yr).abs();
        for _ in 0..PSI_INV_NEWTON_MAX_ITER {
            let step = (phi - yr) / dphi;
            if !step.is_finite() {
                break;
            }
            if step.abs() <= 1e-12 * (1.0 + u.abs()) {
                return Ok(u - step);
            }
            let mut lambda = 1.0;
            loop {
                let trial = u - lambda * step;
                let (p, dp) = self.phi(at, w, trial);
                if (p - yr).abs() < residual || lambda < 1e-6 {
                    (u, phi, dphi, residual) = (trial, p, dp, (p - yr).abs());
                    break;
                }
                lambda *= 0.5;
            }
        }
        Err(ModelError::NoInputSolution { yr, residual })
    }

    /// (α, β) in the original states (the numeric-ψ⁻¹ path).
    fn alpha_beta_x(&self, x: &[f64], w: &[f64]) -> (f64, f64) {
        let n = self.n;
        let mut buf = vec![0.0; n + n * n + 2];
        self.special.newton.eval_parts(&[x, w], &mut buf);
        (buf[n + n * n], buf[n + n * n + 1])
    }

    /// (α, β) at (ξ, η), from the closed form or via Newton from x = 1.
    fn alpha_beta(&self, xi: &[f64], eta: &[f64], w: &[f64]) -> (f64, f64) {
        if !self.affine && self.closed {
            // The linearisation at u = 0: y^(r) ≈ φ(0) + ∂φ/∂u(0)·u.
            return self.phi([xi, eta], w, 0.0);
        }
        if self.closed {
            let mut ab = [0.0; 2];
            self.special.alpha_beta.eval_parts(&[xi, eta, w], &mut ab);
            (ab[0], ab[1])
        } else {
            let mut x = vec![1.0; self.n];
            match self.newton(xi, eta, w, &mut x) {
                // The linearisation at u = 0 in the states where y^(r) is not affine in u.
                Ok(()) if !self.affine => self.phi([&x, &[]], w, 0.0),
                Ok(()) => self.alpha_beta_x(&x, w),
                Err(_) => (f64::NAN, f64::NAN),
            }
        }
    }

    /// Closed-form (x, α, β) into `x`, returning (α, β).
    fn invert_closed(&self, xi: &[f64], eta: &[f64], w: &[f64], x: &mut [f64]) -> (f64, f64) {
        let n = self.n;
        if n + 2 <= STACK {
            let mut buf = [0.0; STACK];
            self.special
                .invert
                .eval_parts(&[xi, eta, w], &mut buf[..n + 2]);
            x.copy_from_slice(&buf[..n]);
            (buf[n], buf[n + 1])
        } else {
            let mut v = vec![0.0; n + 2];
            self.special.invert.eval_parts(&[xi, eta, w], &mut v);
            x.copy_from_slice(&v[..n]);
            (v[n], v[n + 1])
        }
    }
}

impl InverseModel for Interpreter {
    fn info(&self) -> &ModelInfo {
        &self.info
    }
    fn params(&self) -> &[f64] {
        &self.params
    }
    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
        set_param_checked(&self.info, &mut self.params, name, value)?;
        self.special = self.generic.specialize(&self.params);
        Ok(())
    }
    fn maps(&self) -> &[invsim_model_api::map::Map] {
        &self.maps
    }
    fn set_map(
        &mut self,
        name: &str,
        data: (&[f64], Option<&[f64]>, &[f64]),
    ) -> Result<(), ModelError> {
        let names: Vec<&str> = self.map_names.iter().map(String::as_str).collect();
        invsim_model_api::set_map_checked(&mut self.maps, &names, name, data)?;
        if let Some(i) = names.iter().position(|n| *n == name) {
            let data = std::sync::Arc::new(self.maps[i].clone());
            self.generic.set_map(i, &data);
            self.special = self.generic.specialize(&self.params);
        }
        Ok(())
    }
    fn h(&self, x: &[f64], w: &[f64]) -> f64 {
        let mut out = [0.0];
        self.special.h.eval_parts(&[x, w], &mut out);
        out[0]
    }
    fn psi(&self, x: &[f64], w: &[f64], xi: &mut [f64], eta: &mut [f64]) {
        let n = self.n;
        let mut buf = vec![0.0; n + n * n + 2];
        self.special.newton.eval_parts(&[x, w], &mut buf);
        xi.copy_from_slice(&buf[..self.r]);
        eta.copy_from_slice(&buf[self.r..n]);
    }
    fn psi_inv(&self, xi: &[f64], eta: &[f64], w: &[f64], x: &mut [f64]) -> Result<(), ModelError> {
        if self.closed && !self.affine {
            let mut buf = vec![0.0; self.n];
            self.special.invert.eval_parts(&[xi, eta, w], &mut buf);
            x.copy_from_slice(&buf);
            Ok(())
        } else if self.closed {
            self.invert_closed(xi, eta, w, x);
            Ok(())
        } else {
            self.newton(xi, eta, w, x)
        }
    }
    fn alpha(&self, xi: &[f64], eta: &[f64], w: &[f64]) -> f64 {
        self.alpha_beta(xi, eta, w).0
    }
    fn beta(&self, xi: &[f64], eta: &[f64], w: &[f64]) -> f64 {
        self.alpha_beta(xi, eta, w).1
    }
    fn zero_dynamics(&self, xi: &[f64], eta: &[f64], w: &[f64], yr: f64, deta: &mut [f64]) {
        self.zero_dynamics_from(xi, eta, w, yr, f64::NAN, deta)
    }
    /// As [`InverseModel::zero_dynamics`]; an input solved by Newton starts from `u_guess`.
    fn zero_dynamics_from(
        &self,
        xi: &[f64],
        eta: &[f64],
        w: &[f64],
        yr: f64,
        u_guess: f64,
        deta: &mut [f64],
    ) {
        // The input in the zero dynamics: none where it is affine or isolated, else Newton's.
        let newton_u = !self.affine && self.special.solution.n_outputs() == 0;
        if self.closed {
            let u = if newton_u {
                self.solve_input([xi, eta], w, yr, u_guess)
                    .unwrap_or(f64::NAN)
            } else {
                0.0
            };
            self.special.zero.eval_parts(&[xi, eta, w, &[yr, u]], deta);
        } else {
            let mut x = vec![1.0; self.n];
            if self.newton(xi, eta, w, &mut x).is_err() {
                deta.fill(f64::NAN);
                return;
            }
            let u = if newton_u {
                self.solve_input([&x, &[]], w, yr, u_guess)
                    .unwrap_or(f64::NAN)
            } else {
                0.0
            };
            self.special.zero.eval_parts(&[&x, w, &[yr, u]], deta);
        }
    }
    fn rhs(&self, x: &[f64], w: &[f64], u: f64, dx: &mut [f64]) {
        self.special.rhs.eval_parts(&[x, w, &[u]], dx);
    }
    fn outputs(&self, x: &[f64], w: &[f64], u: f64, out: &mut [f64]) {
        self.special.outputs.eval_parts(&[x, w, &[u]], out);
    }
    fn sensitivity(&self, x: &[f64], w: &[f64], u: f64, out: &mut [f64]) -> Result<(), ModelError> {
        self.special.sensitivity.eval_parts(&[x, w, &[u]], out);
        Ok(())
    }
    fn zero_dynamics_jacobian(
        &self,
        xi: &[f64],
        eta: &[f64],
        w: &[f64],
        yr: f64,
        out: &mut [f64],
    ) -> bool {
        evaluated(
            self.special.zero_jacobian.as_ref(),
            &[xi, eta, w, &[yr]],
            out,
        )
    }
    fn zero_dynamics_affine(&self, xi: &[f64], w: &[f64], yr: f64, out: &mut [f64]) -> bool {
        // At η = 0 (the coefficients of η are free of it).
        const ON_STACK: usize = 8;
        let n_eta = self.info.n_eta;
        let (near, far);
        let zeros: &[f64] = if n_eta <= ON_STACK {
            near = [0.0; ON_STACK];
            &near[..n_eta]
        } else {
            far = vec![0.0; n_eta];
            &far
        };
        evaluated(
            self.special.zero_affine.as_ref(),
            &[xi, zeros, w, &[yr]],
            out,
        )
    }
    fn outputs_jacobian(&self, x: &[f64], w: &[f64], u: f64, out: &mut [f64]) -> bool {
        evaluated(self.special.outputs_jacobian.as_ref(), &[x, w, &[u]], out)
    }
    fn reference(&self) -> ReferenceMap {
        self.reference
    }
    /// Closed-form ψ⁻¹: one batched evaluation of the fused (x, α, β) tape over all points.
    fn invert_batch(
        &self,
        xi: &[&[f64]],
        eta: &[&[f64]],
        w: &[&[f64]],
        yr: &[f64],
        x: &mut [&mut [f64]],
        u: &mut [f64],
    ) -> Result<(), (usize, ModelError)> {
        if !self.closed || !self.affine {
            // Newton point by point, warm-started from the previous point.
            return invsim_model_api::invert_pointwise(self, xi, eta, w, yr, x, u);
        }
        let m = yr.len();
        let mut alpha = vec![0.0; m];
        let mut beta = vec![0.0; m];
        {
            let inputs: Vec<&[f64]> = xi.iter().chain(eta).chain(w).copied().collect();
            let mut outs: Vec<&mut [f64]> = x.iter_mut().map(|c| &mut c[..m]).collect();
            outs.push(&mut alpha);
            outs.push(&mut beta);
            self.special.invert.eval_batch(&inputs, &mut outs);
        }
        for k in 0..m {
            u[k] = (yr[k] - alpha[k]) / beta[k];
        }
        Ok(())
    }

    fn outputs_batch(&self, x: &[&[f64]], w: &[&[f64]], u: &[f64], out: &mut [&mut [f64]]) {
        if out.is_empty() {
            return;
        }
        let mut inputs: Vec<&[f64]> = x.iter().map(|c| &c[..u.len()]).collect();
        inputs.extend(w.iter().map(|c| &c[..u.len()]));
        inputs.push(u);
        let mut cols: Vec<&mut [f64]> = out.iter_mut().map(|c| &mut c[..u.len()]).collect();
        self.special.outputs.eval_batch(&inputs, &mut cols);
    }

    /// One fused tape evaluation for (x, α, β) in the closed-form case; Newton from the guess otherwise.
    fn invert(
        &self,
        xi: &[f64],
        eta: &[f64],
        w: &[f64],
        yr: f64,
        x: &mut [f64],
    ) -> Result<f64, ModelError> {
        self.invert_from(xi, eta, w, yr, x, f64::NAN)
    }

    /// As [`InverseModel::invert`]; a non-affine y^(r) solved by Newton starts from `u_guess`.
    fn invert_from(
        &self,
        xi: &[f64],
        eta: &[f64],
        w: &[f64],
        yr: f64,
        x: &mut [f64],
        u_guess: f64,
    ) -> Result<f64, ModelError> {
        if self.closed && !self.affine {
            let n = self.n;
            let mut buf = vec![0.0; n];
            self.special.invert.eval_parts(&[xi, eta, w], &mut buf);
            x.copy_from_slice(&buf);
            return self.solve_input([xi, eta], w, yr, u_guess);
        }
        if self.closed {
            let (a, b) = self.invert_closed(xi, eta, w, x);
            return Ok((yr - a) / b);
        }
        self.newton(xi, eta, w, x)?;
        if !self.affine {
            // ψ⁻¹ by Newton's method, then u from φ(x, w, u) = y^(r) at that x.
            return self.solve_input([&*x, &[]], w, yr, u_guess);
        }
        let (a, b) = self.alpha_beta_x(x, w);
        Ok((yr - a) / b)
    }
}
