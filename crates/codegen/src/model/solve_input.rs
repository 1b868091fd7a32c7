//! The input of a model whose y^(r) = φ(ξ, η, w, u) is not affine in u (contract §5), as the interpreter
//! solves it: the closed-form `input_solution` where the derivation isolated u, else Newton's method on
//! φ(ξ, η, w, u) = y^(r) with the analytic ∂φ/∂u (`phi`), from a start (the previous sample's input, else the
//! middle of the input's bounds), each step halved until |φ − y^(r)| decreases, converged when the step is
//! below 1e-12·(1 + |u|). Also `invert` (ψ⁻¹ and the input), the free wrappers and the constants. Where ψ⁻¹
//! is solved numerically ([`solve_input_x`]) the same iteration runs in the states: x = ψ⁻¹(ξ, η) by Newton's
//! method (`newton.rs`), then u from φ(x, w, u) = y^(r) (`phi_x`, `input_solution_x`), as the interpreter.

use super::context::Gen;
use super::newton::w_tokens;
use crate::emit;
use invsim_model_api::zero_dynamics::{ISOLATED_INPUT_TOL, PSI_INV_NEWTON_MAX_ITER};
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
        isolated(
            quote!(self.input_solution(xi, eta #wa, yr)),
            quote!(self.phi(xi, eta #wa, u)),
        )
    } else {
        newton(|u| quote!(self.phi(xi, eta #wa, #u)))
    };
    let methods = quote! {
        /// The input u with y^(r) = φ(ξ, η, u) = `yr`: the closed-form input solution where u was isolated
        /// (a non-finite value, or one off the closed form's domain where |φ − yr| exceeds 1e-6 relative, is
        /// [`ModelError::NoInputSolution`]), else Newton's method with the analytic
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

/// `solve_input`'s body where u was isolated (`solution`: the call of the input solution; `phi`: of (φ, ∂φ/∂u) at
/// `u`, to check that u solves φ = yr, off the closed form's domain it does not).
fn isolated(solution: TokenStream, phi: TokenStream) -> TokenStream {
    let tol = emit::float_tokens(ISOLATED_INPUT_TOL, false);
    quote! {
        let _ = start;
        let u = #solution;
        if !u.is_finite() {
            return Err(ModelError::NoInputSolution { yr, residual: f64::NAN });
        }
        // The closed form holds on its branch's domain only (sqrt(P) = R gives P = R² for R ≥ 0).
        let (phi, _) = #phi;
        let residual = (phi - yr).abs();
        let solves = residual <= #tol * (1.0 + yr.abs() + phi.abs());
        if !solves {
            return Err(ModelError::NoInputSolution { yr, residual });
        }
        Ok(u)
    }
}

/// `solve_input`'s body by Newton's method (the interpreter's iteration, step for step); `phi(u)` is the
/// call of (φ, ∂φ/∂u) at the input `u`.
fn newton(phi: impl Fn(TokenStream) -> TokenStream) -> TokenStream {
    let (at_u, at_trial) = (phi(quote!(u)), phi(quote!(trial)));
    quote! {
        let mut u = if start.is_finite() { start } else { U_START };
        let (mut phi, mut dphi) = #at_u;
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
                let (p, dp) = #at_trial;
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

/// The items of a model with a numeric ψ⁻¹ and a non-affine y^(r): `solve_input_x` in the states, `invert`
/// (ψ⁻¹ by Newton's method from a guess for x, then the input) and the zero dynamics at that point.
pub(super) fn solve_input_x(g: &Gen<'_>) -> SolveInput {
    let (wp, wa) = w_tokens(g);
    let isolated_x = g.d.input_solution_x.is_some();
    let body = if isolated_x {
        isolated(
            quote!(self.input_solution_x(x #wa, yr)),
            quote!(self.phi_x(x #wa, u)),
        )
    } else {
        newton(|u| quote!(self.phi_x(x #wa, #u)))
    };
    let mut methods = vec![quote! {
        /// The input u with y^(r) = φ(x, u) = `yr` in the states: the closed-form input solution where u was
        /// isolated (a non-finite value, or one off the closed form's domain where |φ − yr| exceeds 1e-6
        /// relative, is [`ModelError::NoInputSolution`]), else Newton's method with the
        /// analytic ∂φ/∂u ([`Precomputed::phi_x`]) from `start` (the previous sample's input; NaN:
        /// [`U_START`]), each step halved until |φ − yr| decreases, converged when the step is below
        /// 1e-12·(1 + |u|); a y^(r) it does not reach in [`INPUT_NEWTON_MAX_ITER`] steps is
        /// [`ModelError::NoInputSolution`].
        pub fn solve_input_x(&self, x: &[f64; N], #wp yr: f64, start: f64) -> Result<f64, ModelError> {
            #body
        }

        /// The inverse at one point: x = ψ⁻¹(ξ, η) by Newton's method from `guess`
        /// ([`Precomputed::psi_inv`]), then the input that gives y^(r) = `yr` there
        /// ([`Precomputed::solve_input_x`] from `start`).
        pub fn invert(
            &self,
            xi: &[f64; R],
            eta: &[f64; N_ETA],
            #wp
            yr: f64,
            guess: &[f64; N],
            start: f64,
        ) -> Result<([f64; N], f64), ModelError> {
            let x = self.psi_inv(xi, eta #wa, guess)?;
            Ok((x, self.solve_input_x(&x #wa, yr, start)?))
        }
    }];
    let mut free = vec![quote! {
        /// The input in the states at the parameters `p`; see [`Precomputed::solve_input_x`].
        #[inline]
        pub fn solve_input_x(p: &Params, x: &[f64; N], #wp yr: f64, start: f64) -> Result<f64, ModelError> {
            Precomputed::new(p).solve_input_x(x #wa, yr, start)
        }

        /// The inverse (x, u) at one point at the parameters `p`; see [`Precomputed::invert`].
        #[inline]
        pub fn invert(
            p: &Params,
            xi: &[f64; R],
            eta: &[f64; N_ETA],
            #wp
            yr: f64,
            guess: &[f64; N],
            start: f64,
        ) -> Result<([f64; N], f64), ModelError> {
            Precomputed::new(p).invert(xi, eta #wa, yr, guess, start)
        }
    }];
    if !g.d.eta.is_empty() {
        let (m, f) = zero_dynamics_x(g, isolated_x);
        methods.push(m);
        free.push(f);
    }
    SolveInput {
        methods,
        free,
        helpers: vec![constants(g)],
    }
}

/// The zero dynamics at x = ψ⁻¹(ξ, η) (Newton from `guess`) and the input there (none where it was
/// isolated and substituted, else [`Precomputed::solve_input_x`] from `start`, NaN where it fails, as the
/// interpreter): the method and its free wrapper.
fn zero_dynamics_x(g: &Gen<'_>, isolated: bool) -> (TokenStream, TokenStream) {
    let (wp, wa) = w_tokens(g);
    let u = if isolated {
        quote!({
            let _ = start;
            0.0
        })
    } else {
        quote!(self.solve_input_x(&x #wa, yr, start).unwrap_or(f64::NAN))
    };
    let method = quote! {
        /// The zero dynamics dη/dt at x = ψ⁻¹(ξ, η) (Newton from `guess`) and the input that gives y^(r)
        /// there (Newton from `start` where it was not isolated); see [`Precomputed::zero_dynamics_x`].
        pub fn zero_dynamics(
            &self,
            xi: &[f64; R],
            eta: &[f64; N_ETA],
            #wp
            yr: f64,
            guess: &[f64; N],
            start: f64,
        ) -> Result<[f64; N_ETA], ModelError> {
            let x = self.psi_inv(xi, eta #wa, guess)?;
            let u = #u;
            Ok(self.zero_dynamics_x(&x #wa, yr, u))
        }
    };
    let free = quote! {
        /// The zero dynamics at the parameters `p`; see [`Precomputed::zero_dynamics`].
        #[inline]
        pub fn zero_dynamics(
            p: &Params,
            xi: &[f64; R],
            eta: &[f64; N_ETA],
            #wp
            yr: f64,
            guess: &[f64; N],
            start: f64,
        ) -> Result<[f64; N_ETA], ModelError> {
            Precomputed::new(p).zero_dynamics(xi, eta #wa, yr, guess, start)
        }
    };
    (method, free)
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
