//! The input of a model whose y^(r) = φ(ξ, η, w, u) is not affine in u (contract §5), as the interpreter
//! solves it: the closed-form `input_solution` where the derivation isolated u, else Newton's method on
//! φ(ξ, η, w, u) = y^(r) with the analytic ∂φ/∂u (`phi`), from a start (the previous sample's input, else the
//! middle of the input's bounds), each step halved until |φ − y^(r)| decreases, converged when the step is
//! below 1e-12·(1 + |u|). Also `invert` (ψ⁻¹ and the input), the free wrappers and the constants.

use super::context::Gen;
use super::newton::w_tokens;
use crate::emit;
use invsim_model_api::zero_dynamics::PSI_INV_NEWTON_MAX_ITER;
use proc_macro2::TokenStream;
use quote::quote;

/// What the non-affine input adds to the module: methods of `Precomputed`, free functions, helpers.
pub(super) struct SolveInput {
    pub(super) methods: Vec<TokenStream>,
    pub(super) free: Vec<TokenStream>,
    pub(super) helpers: Vec<TokenStream>,
}

/// The items of a model with a closed-form ψ⁻¹ and a non-affine y^(r).
pub(super) fn solve_input(g: &Gen<'_>) -> SolveInput {
    let (wp, wa) = w_tokens(g);
    let body = if g.d.input_solution.is_some() {
        isolated(&wa)
    } else {
        newton(&wa)
    };
    let methods = quote! {
        /// The input u with y^(r) = φ(ξ, η, u) = `yr`: the closed-form input solution where u was isolated
        /// (a non-finite value is [`ModelError::NoInputSolution`]), else Newton's method with the analytic
        /// ∂φ/∂u ([`Precomputed::phi`]) from `start` (the previous sample's input; NaN: [`U_START`]), each
        /// step halved until |φ − yr| decreases, converged when the step is below 1e-12·(1 + |u|); a y^(r)
        /// it does not reach in [`INPUT_NEWTON_MAX_ITER`] steps is [`ModelError::NoInputSolution`].
        pub fn solve_input(
            &self,
            xi: &[f64; R],
            eta: &[f64; N_ETA],
            #wp
            yr: f64,
            start: f64,
        ) -> Result<f64, ModelError> {
            #body
        }

        /// The inverse at one point: x = ψ⁻¹(ξ, η) and the input that gives y^(r) = `yr`
        /// ([`Precomputed::solve_input`] from `start`).
        pub fn invert(
            &self,
            xi: &[f64; R],
            eta: &[f64; N_ETA],
            #wp
            yr: f64,
            start: f64,
        ) -> Result<([f64; N], f64), ModelError> {
            let u = self.solve_input(xi, eta #wa, yr, start)?;
            Ok((self.psi_inv(xi, eta #wa), u))
        }
    };
    let free = quote! {
        /// The input that gives y^(r) at the parameters `p`; see [`Precomputed::solve_input`].
        #[inline]
        pub fn solve_input(
            p: &Params,
            xi: &[f64; R],
            eta: &[f64; N_ETA],
            #wp
            yr: f64,
            start: f64,
        ) -> Result<f64, ModelError> {
            Precomputed::new(p).solve_input(xi, eta #wa, yr, start)
        }

        /// The inverse (x, u) at one point at the parameters `p`; see [`Precomputed::invert`].
        #[inline]
        pub fn invert(
            p: &Params,
            xi: &[f64; R],
            eta: &[f64; N_ETA],
            #wp
            yr: f64,
            start: f64,
        ) -> Result<([f64; N], f64), ModelError> {
            Precomputed::new(p).invert(xi, eta #wa, yr, start)
        }
    };
    SolveInput {
        methods: vec![methods],
        free: vec![free],
        helpers: vec![constants(g)],
    }
}

/// `solve_input`'s body where u was isolated.
fn isolated(wa: &TokenStream) -> TokenStream {
    quote! {
        let _ = start;
        let u = self.input_solution(xi, eta #wa, yr);
        if !u.is_finite() {
            return Err(ModelError::NoInputSolution { yr, residual: f64::NAN });
        }
        Ok(u)
    }
}

/// `solve_input`'s body by Newton's method (the interpreter's iteration, step for step).
fn newton(wa: &TokenStream) -> TokenStream {
    quote! {
        let mut u = if start.is_finite() { start } else { U_START };
        let (mut phi, mut dphi) = self.phi(xi, eta #wa, u);
        let mut residual = (phi - yr).abs();
        for _ in 0..INPUT_NEWTON_MAX_ITER {
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
                let (p, dp) = self.phi(xi, eta #wa, trial);
                if (p - yr).abs() < residual || lambda < 1e-6 {
                    (u, phi, dphi, residual) = (trial, p, dp, (p - yr).abs());
                    break;
                }
                lambda *= 0.5;
            }
        }
        Err(ModelError::NoInputSolution { yr, residual })
    }
}

/// Newton's start without a guess and its iteration limit.
fn constants(g: &Gen<'_>) -> TokenStream {
    let m = &g.d.model;
    // The middle of [min, max], a bound if only one is given, else 0 (as the interpreter).
    let start = match (m.input.min, m.input.max) {
        (Some(lo), Some(hi)) => 0.5 * (lo + hi),
        (Some(b), None) | (None, Some(b)) => b,
        (None, None) => 0.0,
    };
    let start = emit::float_tokens(start, false);
    let iters = proc_macro2::Literal::usize_unsuffixed(PSI_INV_NEWTON_MAX_ITER);
    quote! {
        /// Where Newton's method for the input starts without a guess: the middle of the input's bounds, a
        /// bound if only one is given, else 0.
        pub const U_START: f64 = #start;
        /// The most Newton steps for the input.
        pub const INPUT_NEWTON_MAX_ITER: usize = #iters;
    }
}
