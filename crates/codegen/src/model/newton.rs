//! Newton's method for a ψ⁻¹ without closed form: `psi_inv` iterates on ψ(x) = (ξ, η) with the analytic
//! Jacobian `psi_jacobian` (same iteration limit, tolerance and residual scaling as the interpreter); α, β,
//! the inverse and the zero dynamics are then evaluated in the states at the solution (L_f^r h,
//! L_g L_f^(r−1) h, f_η + g_η·u); where y^(r) is not affine in u, the input at the solution comes from
//! `solve_input.rs` instead. Where y^(r) is affine in u, `invert_batch` runs the inverse along a block of
//! samples: Newton from sample to sample as the runtime runs `invert` (each from the previous solution), every
//! iteration evaluating `psi_jacobian_alpha_beta` (ψ, ∂ψ/∂x, α and β in one pass), so that α and β at the
//! solution come with the last iteration and ψ, ∂ψ/∂x there serve the next sample's first iteration; the same
//! operations in the same order per sample, so the numbers of `invert` bit for bit. Also the free wrappers,
//! the iteration `psi_newton` over a given evaluation, the LU solve and the constants.

use super::context::Gen;
use crate::emit;
use invsim_model_api::zero_dynamics::{
    PSI_INV_NEWTON_MAX_ITER as NEWTON_MAX_ITER, PSI_INV_NEWTON_TOL as NEWTON_TOL,
};
use proc_macro2::TokenStream;
use quote::quote;

/// What Newton's method adds to the module: methods of `Precomputed`, free functions, helpers.
pub(super) struct Newton {
    pub(super) methods: Vec<TokenStream>,
    pub(super) free: Vec<TokenStream>,
    pub(super) helpers: Vec<TokenStream>,
}

/// The Newton items of a model whose ψ⁻¹ is solved numerically (ψ⁻¹ alone where y^(r) is not affine in u).
pub(super) fn newton(g: &Gen<'_>) -> Newton {
    let helpers = vec![psi_newton_fn(), lu_solve(), constants()];
    if !g.affine {
        return Newton {
            methods: vec![psi_inv_method(g)],
            free: vec![psi_inv_free(g)],
            helpers,
        };
    }
    let ne = g.d.eta.len();
    let (wp, wa) = w_tokens(g);
    let mut methods = vec![psi_inv_method(g), methods(g), invert_batch_method(g)];
    if ne > 0 {
        methods.push(quote! {
            /// The zero dynamics dη/dt at x = ψ⁻¹(ξ, η) (Newton from `guess`); see
            /// [`Precomputed::zero_dynamics_x`].
            pub fn zero_dynamics(
                &self,
                xi: &[f64; R],
                eta: &[f64; N_ETA],
                #wp
                yr: f64,
                guess: &[f64; N],
            ) -> Result<[f64; N_ETA], ModelError> {
                Ok(self.zero_dynamics_x(&self.psi_inv(xi, eta #wa, guess)? #wa, yr))
            }
        });
    }
    let mut free = vec![psi_inv_free(g), free_functions(g)];
    if ne > 0 {
        free.push(quote! {
            /// The zero dynamics at the parameters `p`; see [`Precomputed::zero_dynamics`].
            #[inline]
            pub fn zero_dynamics(
                p: &Params,
                xi: &[f64; R],
                eta: &[f64; N_ETA],
                #wp
                yr: f64,
                guess: &[f64; N],
            ) -> Result<[f64; N_ETA], ModelError> {
                Precomputed::new(p).zero_dynamics(xi, eta #wa, yr, guess)
            }
        });
    }
    Newton {
        methods,
        free,
        helpers,
    }
}

/// The signal values' parameter `w: &[f64; NW],` and the argument `, w` passed on, for a model with signals
/// (both empty otherwise, so that the code of a model without signals is unchanged).
pub(super) fn w_tokens(g: &Gen<'_>) -> (TokenStream, TokenStream) {
    if g.has_w() {
        (quote!(w: &[f64; NW],), quote!(, w))
    } else {
        (quote!(), quote!())
    }
}

/// ψ⁻¹'s target (ξ, η) as an array of N tokens, `xi[i]` and `eta[j]` followed by `index` (`[k]` for the
/// columns of a batch, nothing for one point).
fn target_tokens(g: &Gen<'_>, index: &TokenStream) -> Vec<TokenStream> {
    let (r, ne) = (g.d.relative_degree, g.d.eta.len());
    let lit = proc_macro2::Literal::usize_unsuffixed;
    (0..r)
        .map(|i| {
            let i = lit(i);
            quote!(xi[#i] #index)
        })
        .chain((0..ne).map(|j| {
            let j = lit(j);
            quote!(eta[#j] #index)
        }))
        .collect()
}

/// `psi_inv` by Newton's method, and the iteration itself (`psi_newton`), which can start from ψ and its
/// Jacobian at the guess when they are known.
fn psi_inv_method(g: &Gen<'_>) -> TokenStream {
    let (wp, wa) = w_tokens(g);
    let (r, ne) = (g.d.relative_degree, g.d.eta.len());
    let target = target_tokens(g, &quote!());
    let xi_name = if r > 0 { quote!(xi) } else { quote!(_xi) };
    let eta_name = if ne > 0 { quote!(eta) } else { quote!(_eta) };
    quote! {
        /// The states at normal-form coordinates, x = ψ⁻¹(ξ, η), by Newton's method on ψ(x) = (ξ, η) with
        /// the analytic Jacobian, started from `guess`.
        ///
        /// Stops when max_i |ψ_i(x) − target_i| / max(|target_i|, 1) < [`NEWTON_TOL`] (as the interpreter); after
        /// [`NEWTON_MAX_ITER`] iterations, a singular Jacobian or a non-finite iterate it returns
        /// [`ModelError::NewtonDidNotConverge`], never an unconverged x.
        pub fn psi_inv(
            &self,
            #xi_name: &[f64; R],
            #eta_name: &[f64; N_ETA],
            #wp
            guess: &[f64; N],
        ) -> Result<[f64; N], ModelError> {
            let target: [f64; N] = [#(#target),*];
            let jacobian = |x: &[f64; N]| {
                let (value, jacobian) = self.psi_jacobian(x #wa);
                (value, jacobian, ())
            };
            psi_newton(&target, guess, None, jacobian).map(|(x, _)| x)
        }
    }
}

/// The free function `psi_newton`: Newton's iteration of `psi_inv`, with the function that evaluates ψ and
/// ∂ψ/∂x (and whatever else is wanted at the solution) as an argument.
fn psi_newton_fn() -> TokenStream {
    quote! {
        /// Newton's iteration of [`Precomputed::psi_inv`] on ψ(x) = `target` from `guess`:
        /// x ← x − (∂ψ/∂x)⁻¹ (ψ(x) − target) until max_i |ψ_i(x) − target_i| / max(|target_i|, 1) <
        /// [`NEWTON_TOL`]. `eval(x)` gives (ψ, ∂ψ/∂x, extra) at x; `at_guess`, when given, is `eval(guess)`
        /// (known from elsewhere: the previous point's solution), used for the first iteration instead of
        /// evaluating there again. Returns the solution with `eval` at it, which the last iteration evaluated.
        #[allow(clippy::type_complexity)]
        fn psi_newton<T>(
            target: &[f64; N],
            guess: &[f64; N],
            at_guess: Option<([f64; N], [[f64; N]; N], T)>,
            eval: impl Fn(&[f64; N]) -> ([f64; N], [[f64; N]; N], T),
        ) -> Result<([f64; N], ([f64; N], [[f64; N]; N], T)), ModelError> {
            let mut x = *guess;
            let mut known = at_guess;
            let mut residual = f64::INFINITY;
            for _ in 0..NEWTON_MAX_ITER {
                let (value, jacobian, extra) = match known.take() {
                    Some(at) => at,
                    None => eval(&x),
                };
                let mut step = [0.0; N];
                residual = 0.0;
                for ((s, v), t) in step.iter_mut().zip(value).zip(*target) {
                    *s = v - t;
                    let scaled = (*s / t.abs().max(1.0)).abs();
                    if scaled.is_nan() || scaled > residual {
                        residual = scaled;
                    }
                }
                if residual < NEWTON_TOL {
                    return Ok((x, (value, jacobian, extra)));
                }
                if !lu_solve(jacobian, &mut step) {
                    break;
                }
                for (xk, s) in x.iter_mut().zip(step) {
                    *xk -= s;
                }
                if !x.iter().all(|v| v.is_finite()) {
                    break;
                }
            }
            Err(ModelError::NewtonDidNotConverge { iterations: NEWTON_MAX_ITER, residual })
        }
    }
}

/// `invert_batch` for an affine y^(r): the points in order, each Newton iteration started from the previous
/// point's solution with ψ and ∂ψ/∂x there reused, α and β from the last iteration (see the generated doc).
fn invert_batch_method(g: &Gen<'_>) -> TokenStream {
    let ne = g.d.eta.len();
    let (_, wa) = w_tokens(g);
    let target = target_tokens(g, &quote!([k]));
    let eta_name = if ne > 0 { quote!(eta) } else { quote!(_eta) };
    // With signals, ψ and its Jacobian at the guess are reused only where the signal values are the same.
    let (w_cols, w_point, w_bits, reuse, keep) = if g.has_w() {
        (
            quote!(w: [&[f64]; NW],),
            quote!(let w: [f64; NW] = w.map(|c| c[k]);),
            quote!([u64; NW]),
            quote!(known
                .take()
                .filter(|(bits, _)| *bits == w.map(f64::to_bits))
                .map(|(_, at)| at)),
            quote!(Some((w.map(f64::to_bits), at))),
        )
    } else {
        (
            quote!(),
            quote!(),
            quote!(()),
            quote!(known.take().map(|((), at)| at)),
            quote!(Some(((), at))),
        )
    };
    quote! {
        /// [`Precomputed::invert`] at many points, stored column-wise: ξ_i at point k is `xi[i][k]`, η_j is
        /// `eta[j][k]`, the signal value w_l is `w[l][k]`, y^(r) is `yr[k]`; x_s is written to `x[s][k]` and
        /// u to `u[k]`.
        ///
        /// Point by point in order, each Newton iteration for ψ⁻¹ started from the previous point's solution
        /// (the first from `x[s][0]`), as the runtime runs [`Precomputed::invert`] along a reference. Each
        /// iteration evaluates [`Precomputed::psi_jacobian_alpha_beta`], so α and β at the solution,
        /// u = (y^(r) − α)/β, come with the last iteration; ψ and ∂ψ/∂x there also serve the next point's
        /// first iteration instead of being evaluated again at the same x (and the same signal values). The
        /// same numbers as [`Precomputed::invert`] bit for bit.
        ///
        /// Returns the index of the first point whose Newton iteration fails, with its error (the points
        /// before it are written).
        ///
        /// # Panics
        ///
        /// If a column is shorter than `yr`.
        #[allow(clippy::type_complexity)]
        pub fn invert_batch(
            &self,
            xi: [&[f64]; R],
            #eta_name: [&[f64]; N_ETA],
            #w_cols
            yr: &[f64],
            mut x: [&mut [f64]; N],
            u: &mut [f64],
        ) -> Result<(), (usize, ModelError)> {
            let mut guess: [f64; N] = std::array::from_fn(|s| x[s].first().copied().unwrap_or(0.0));
            // ψ and ∂ψ/∂x at `guess`, from the previous point's last Newton iteration.
            let mut known: Option<(#w_bits, ([f64; N], [[f64; N]; N], (f64, f64)))> = None;
            for k in 0..yr.len() {
                let target: [f64; N] = [#(#target),*];
                #w_point
                let at_guess = #reuse;
                let eval = |x: &[f64; N]| {
                    let (value, jacobian, alpha, beta) = self.psi_jacobian_alpha_beta(x #wa);
                    (value, jacobian, (alpha, beta))
                };
                let (states, at) = psi_newton(&target, &guess, at_guess, eval).map_err(|e| (k, e))?;
                let (alpha, beta) = at.2;
                u[k] = (yr[k] - alpha) / beta;
                for (column, s) in x.iter_mut().zip(states) {
                    column[k] = s;
                }
                guess = states;
                known = #keep;
            }
            Ok(())
        }
    }
}

/// α, β and the inverse at the solution of `psi_inv`.
fn methods(g: &Gen<'_>) -> TokenStream {
    let (wp, wa) = w_tokens(g);
    quote! {
        /// α(ξ, η) = L_f^r h at x = ψ⁻¹(ξ, η) (Newton from `guess`); see [`Precomputed::alpha_x`].
        pub fn alpha(&self, xi: &[f64; R], eta: &[f64; N_ETA], #wp guess: &[f64; N]) -> Result<f64, ModelError> {
            Ok(self.alpha_x(&self.psi_inv(xi, eta #wa, guess)? #wa))
        }

        /// β(ξ, η) = L_g L_f^(r−1) h at x = ψ⁻¹(ξ, η) (Newton from `guess`); see [`Precomputed::beta_x`].
        pub fn beta(&self, xi: &[f64; R], eta: &[f64; N_ETA], #wp guess: &[f64; N]) -> Result<f64, ModelError> {
            Ok(self.beta_x(&self.psi_inv(xi, eta #wa, guess)? #wa))
        }

        /// The inverse at one point (paper eq. 26): x = ψ⁻¹(ξ, η) by Newton from `guess`, and
        /// u = (y^(r) − α)/β at that x.
        ///
        /// ```math
        /// u = \frac{y^{(r)} - \alpha(x)}{\beta(x)}
        /// ```
        pub fn invert(
            &self,
            xi: &[f64; R],
            eta: &[f64; N_ETA],
            #wp
            yr: f64,
            guess: &[f64; N],
        ) -> Result<([f64; N], f64), ModelError> {
            let x = self.psi_inv(xi, eta #wa, guess)?;
            Ok((x, (yr - self.alpha_x(&x #wa)) / self.beta_x(&x #wa)))
        }
    }
}

/// The free wrapper of `psi_inv`.
fn psi_inv_free(g: &Gen<'_>) -> TokenStream {
    let (wp, wa) = w_tokens(g);
    quote! {
        /// x = ψ⁻¹(ξ, η) by Newton's method at the parameters `p`; see [`Precomputed::psi_inv`].
        #[inline]
        pub fn psi_inv(p: &Params, xi: &[f64; R], eta: &[f64; N_ETA], #wp guess: &[f64; N]) -> Result<[f64; N], ModelError> {
            Precomputed::new(p).psi_inv(xi, eta #wa, guess)
        }
    }
}

/// The free wrappers of α, β and the inverse.
fn free_functions(g: &Gen<'_>) -> TokenStream {
    let (wp, wa) = w_tokens(g);
    quote! {
        /// α(ξ, η) at the parameters `p`; see [`Precomputed::alpha`].
        #[inline]
        pub fn alpha(p: &Params, xi: &[f64; R], eta: &[f64; N_ETA], #wp guess: &[f64; N]) -> Result<f64, ModelError> {
            Precomputed::new(p).alpha(xi, eta #wa, guess)
        }
        /// β(ξ, η) at the parameters `p`; see [`Precomputed::beta`].
        #[inline]
        pub fn beta(p: &Params, xi: &[f64; R], eta: &[f64; N_ETA], #wp guess: &[f64; N]) -> Result<f64, ModelError> {
            Precomputed::new(p).beta(xi, eta #wa, guess)
        }
        /// The inverse at one point at the parameters `p`; see [`Precomputed::invert`].
        #[inline]
        pub fn invert(
            p: &Params,
            xi: &[f64; R],
            eta: &[f64; N_ETA],
            #wp
            yr: f64,
            guess: &[f64; N],
        ) -> Result<([f64; N], f64), ModelError> {
            Precomputed::new(p).invert(xi, eta #wa, yr, guess)
        }
    }
}

/// Gaussian elimination for Newton's step.
fn lu_solve() -> TokenStream {
    quote! {
        /// Solves a·s = b in place of `b` by Gaussian elimination with partial pivoting; `false` when `a`
        /// is singular.
        ///
        /// The pivot of column k is the first row i ≥ k of largest |a_ik|, exchanged with row k. The rows are
        /// indexed by loop counters only (the exchange is a select per row i > k: whether i is the pivot), so
        /// for a model's fixed N the loops unroll and the matrix stays in registers.
        #[inline(always)]
        fn lu_solve(mut a: [[f64; N]; N], b: &mut [f64; N]) -> bool {
            for k in 0..N {
                let (mut pivot, mut largest) = (k, a[k][k].abs());
                for (i, ai) in a.iter().enumerate().skip(k + 1) {
                    if ai[k].abs() > largest {
                        (pivot, largest) = (i, ai[k].abs());
                    }
                }
                if largest == 0.0 {
                    return false;
                }
                for i in k + 1..N {
                    let swap = i == pivot;
                    let (x, y) = (a[k], a[i]);
                    (a[k], a[i]) = if swap { (y, x) } else { (x, y) };
                    let (x, y) = (b[k], b[i]);
                    (b[k], b[i]) = if swap { (y, x) } else { (x, y) };
                }
                let (row, bk) = (a[k], b[k]);
                for (ai, bi) in a.iter_mut().zip(b.iter_mut()).skip(k + 1) {
                    let factor = ai[k] / row[k];
                    for (aij, rj) in ai.iter_mut().zip(row).skip(k) {
                        *aij -= factor * rj;
                    }
                    *bi -= factor * bk;
                }
            }
            for k in (0..N).rev() {
                b[k] /= a[k][k];
                let bk = b[k];
                for (bi, ai) in b.iter_mut().zip(a).take(k) {
                    *bi -= ai[k] * bk;
                }
            }
            true
        }
    }
}

/// `NEWTON_MAX_ITER` and `NEWTON_TOL`: the values of `invsim_model_api::zero_dynamics`, shared with the interpreter.
fn constants() -> TokenStream {
    let tol = emit::float_tokens(NEWTON_TOL, false);
    let lit = proc_macro2::Literal::usize_unsuffixed;
    let iter = lit(NEWTON_MAX_ITER);
    quote! {
        /// Largest number of Newton iterations for ψ⁻¹ (the interpreter's limit).
        pub const NEWTON_MAX_ITER: usize = #iter;
        /// Newton's method for ψ⁻¹ stops when the scaled residual is below this (the interpreter's tolerance).
        pub const NEWTON_TOL: f64 = #tol;
    }
}
