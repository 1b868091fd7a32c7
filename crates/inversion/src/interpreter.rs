//! The interpreted engine: a [`Derivation`] compiled to instruction tapes, implementing
//! [`InverseModel`] for any model file without generating Rust code.

use crate::derive::{Derivation, Solution};
use invsim_expr::{Id, Symbol, Tape};
use invsim_model_api::{set_param_checked, InverseModel, ModelError, ModelInfo, OutputInfo};
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

/// Maximum Newton iterations for a numerically solved ψ⁻¹.
pub const NEWTON_MAX_ITER: usize = 50;
/// Newton stops when the scaled residual is below this.
pub const NEWTON_TOL: f64 = 1e-13;

/// Interpreted model: every function of [`InverseModel`] evaluated from a tape.
#[derive(Debug, Clone)]
pub struct Interpreter {
    info: ModelInfo,
    params: Vec<f64>,
    n: usize,
    r: usize,
    closed: bool,
    /// (ξ, η, p) → (x, α, β) when ψ⁻¹ is closed-form.
    invert: Tape,
    /// (x, p) → (ψ, ∂ψ/∂x row-major, α_x, β_x): Newton's method and the numeric path.
    newton: Tape,
    /// (x, p) → h.
    h: Tape,
    /// (ξ, η, yr, p) → dη/dt (closed form) or (x, yr, p) → dη/dt (numeric ψ⁻¹).
    zero: Tape,
    /// (x, u, p) → f + g u.
    rhs: Tape,
    /// (x, u, p) → outputs.
    outputs: Tape,
}

fn compile(d: &Derivation, what: &'static str, exprs: &[Id], inputs: &[Symbol]) -> Result<Tape, InterpretError> {
    Tape::compile(d.pool(), exprs, inputs).map_err(|source| InterpretError { what, source })
}

/// The model's static description (shared with generated code, which builds the same struct).
pub fn model_info(d: &Derivation) -> ModelInfo {
    let m = &d.model;
    ModelInfo {
        name: m.name.clone(),
        source_hash: Some(m.source_hash.clone()),
        states: m.states.iter().map(|s| s.name.clone()).collect(),
        input: m.input.name.clone(),
        output: m.output.name.clone(),
        relative_degree: d.relative_degree,
        n_eta: d.eta.len(),
        input_min: m.input.min,
        input_max: m.input.max,
        outputs: m
            .outputs
            .iter()
            .map(|o| OutputInfo { name: o.name.clone(), unit: o.unit.clone(), accumulate: o.accumulate })
            .collect(),
        parameters: m.parameters.iter().map(|p| p.name.clone()).collect(),
    }
}

impl Interpreter {
    pub fn new(d: &Derivation) -> Result<Interpreter, InterpretError> {
        let m = &d.model;
        let params: Vec<Symbol> = m.parameters.iter().map(|p| p.symbol).collect();
        let states = m.state_symbols();
        let u = m.input.symbol;
        let n = states.len();
        let r = d.relative_degree;
        let closed = d.psi_inv_closed();
        let cat = |parts: &[&[Symbol]]| -> Vec<Symbol> { parts.iter().flat_map(|p| p.iter().copied()).collect() };
        let xi_eta_p = cat(&[&d.xi, &d.eta, &params]);
        let x_p = cat(&[&states, &params]);
        let x_u_p = cat(&[&states, &[u], &params]);

        let invert = if closed {
            let mut exprs: Vec<Id> = d
                .psi_inv
                .iter()
                .map(|s| match s {
                    Solution::Closed(e) => *e,
                    Solution::Numeric => unreachable!("closed() checked"),
                })
                .collect();
            exprs.push(d.alpha);
            exprs.push(d.beta);
            compile(d, "ψ⁻¹, α, β", &exprs, &xi_eta_p)?
        } else {
            compile(d, "ψ⁻¹, α, β", &[], &xi_eta_p)?
        };
        let mut newton_exprs: Vec<Id> = d.psi.clone();
        for row in &d.jacobian {
            newton_exprs.extend(row.iter().copied());
        }
        newton_exprs.push(d.alpha_x);
        newton_exprs.push(d.beta_x);
        let newton = compile(d, "ψ and its Jacobian", &newton_exprs, &x_p)?;
        let h = compile(d, "h", &[m.output.h], &x_p)?;
        let zero = if closed {
            compile(d, "zero dynamics", &d.zero_dynamics, &cat(&[&d.xi, &d.eta, &[d.yr], &params]))?
        } else {
            compile(d, "zero dynamics", &d.zero_dynamics_x, &cat(&[&states, &[d.yr], &params]))?
        };
        let rhs: Vec<Id> = m.states.iter().map(|s| s.rhs).collect();
        let rhs = compile(d, "f + g u", &rhs, &x_u_p)?;
        let outs: Vec<Id> = m.outputs.iter().map(|o| o.expr).collect();
        let outputs = compile(d, "outputs", &outs, &x_u_p)?;
        Ok(Interpreter {
            info: model_info(d),
            params: m.parameters.iter().map(|p| p.value).collect(),
            n,
            r,
            closed,
            invert,
            newton,
            h,
            zero,
            rhs,
            outputs,
        })
    }

    /// Newton's method on ψ(x) = (ξ, η) from the guess in `x` (the analytic Jacobian, LU-solved).
    fn newton(&self, xi: &[f64], eta: &[f64], x: &mut [f64]) -> Result<(), ModelError> {
        let n = self.n;
        let mut buf = vec![0.0; n + n * n + 2];
        let mut residual = f64::INFINITY;
        for _ in 0..NEWTON_MAX_ITER {
            self.newton.eval_parts(&[x, &self.params], &mut buf);
            let target = |i: usize| if i < self.r { xi[i] } else { eta[i - self.r] };
            let res = nalgebra::DVector::from_fn(n, |i, _| buf[i] - target(i));
            let scale = nalgebra::DVector::from_fn(n, |i, _| target(i).abs().max(1e-12));
            residual = res.component_div(&scale).amax();
            if residual < NEWTON_TOL {
                return Ok(());
            }
            let jac = nalgebra::DMatrix::from_fn(n, n, |i, j| buf[n + i * n + j]);
            let Some(step) = jac.lu().solve(&res) else { break };
            for i in 0..n {
                x[i] -= step[i];
            }
            if !x.iter().all(|v| v.is_finite()) {
                break;
            }
        }
        Err(ModelError::NewtonDidNotConverge { iterations: NEWTON_MAX_ITER, residual })
    }

    fn alpha_beta(&self, xi: &[f64], eta: &[f64]) -> (f64, f64) {
        let mut x = vec![1.0; self.n];
        match self.invert(xi, eta, 0.0, &mut x) {
            Ok(_) => {
                let n = self.n;
                let mut buf = vec![0.0; n + n * n + 2];
                self.newton.eval_parts(&[&x, &self.params], &mut buf);
                (buf[n + n * n], buf[n + n * n + 1])
            }
            Err(_) => (f64::NAN, f64::NAN),
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
        set_param_checked(&self.info, &mut self.params, name, value)
    }
    fn h(&self, x: &[f64]) -> f64 {
        let mut out = [0.0];
        self.h.eval_parts(&[x, &self.params], &mut out);
        out[0]
    }
    fn psi(&self, x: &[f64], xi: &mut [f64], eta: &mut [f64]) {
        let n = self.n;
        let mut buf = vec![0.0; n + n * n + 2];
        self.newton.eval_parts(&[x, &self.params], &mut buf);
        xi.copy_from_slice(&buf[..self.r]);
        eta.copy_from_slice(&buf[self.r..n]);
    }
    fn psi_inv(&self, xi: &[f64], eta: &[f64], x: &mut [f64]) -> Result<(), ModelError> {
        if self.closed {
            let n = self.n;
            let mut buf = [0.0; 64];
            if n + 2 <= buf.len() {
                self.invert.eval_parts(&[xi, eta, &self.params], &mut buf[..n + 2]);
                x.copy_from_slice(&buf[..n]);
            } else {
                let mut v = vec![0.0; n + 2];
                self.invert.eval_parts(&[xi, eta, &self.params], &mut v);
                x.copy_from_slice(&v[..n]);
            }
            Ok(())
        } else {
            self.newton(xi, eta, x)
        }
    }
    fn alpha(&self, xi: &[f64], eta: &[f64]) -> f64 {
        if self.closed {
            let mut buf = vec![0.0; self.n + 2];
            self.invert.eval_parts(&[xi, eta, &self.params], &mut buf);
            buf[self.n]
        } else {
            self.alpha_beta(xi, eta).0
        }
    }
    fn beta(&self, xi: &[f64], eta: &[f64]) -> f64 {
        if self.closed {
            let mut buf = vec![0.0; self.n + 2];
            self.invert.eval_parts(&[xi, eta, &self.params], &mut buf);
            buf[self.n + 1]
        } else {
            self.alpha_beta(xi, eta).1
        }
    }
    fn zero_dynamics(&self, xi: &[f64], eta: &[f64], yr: f64, deta: &mut [f64]) {
        if self.closed {
            self.zero.eval_parts(&[xi, eta, &[yr], &self.params], deta);
        } else {
            let mut x = vec![1.0; self.n];
            if self.newton(xi, eta, &mut x).is_err() {
                deta.fill(f64::NAN);
                return;
            }
            self.zero.eval_parts(&[&x, &[yr], &self.params], deta);
        }
    }
    fn rhs(&self, x: &[f64], u: f64, dx: &mut [f64]) {
        self.rhs.eval_parts(&[x, &[u], &self.params], dx);
    }
    fn outputs(&self, x: &[f64], u: f64, out: &mut [f64]) {
        self.outputs.eval_parts(&[x, &[u], &self.params], out);
    }
    /// One fused tape evaluation for (x, α, β) in the closed-form case; Newton from the guess otherwise.
    fn invert(&self, xi: &[f64], eta: &[f64], yr: f64, x: &mut [f64]) -> Result<f64, ModelError> {
        let n = self.n;
        if self.closed {
            let mut buf = [0.0; 64];
            let (a, b) = if n + 2 <= buf.len() {
                self.invert.eval_parts(&[xi, eta, &self.params], &mut buf[..n + 2]);
                x.copy_from_slice(&buf[..n]);
                (buf[n], buf[n + 1])
            } else {
                let mut v = vec![0.0; n + 2];
                self.invert.eval_parts(&[xi, eta, &self.params], &mut v);
                x.copy_from_slice(&v[..n]);
                (v[n], v[n + 1])
            };
            return Ok((yr - a) / b);
        }
        self.newton(xi, eta, x)?;
        let mut buf = vec![0.0; n + n * n + 2];
        self.newton.eval_parts(&[x, &self.params], &mut buf);
        Ok((yr - buf[n + n * n]) / buf[n + n * n + 1])
    }
}
