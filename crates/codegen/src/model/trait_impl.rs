//! The compiled model behind the runtime's trait: `model_info`, `Model` (a `Precomputed` with its parameter
//! values) and its `invsim_model_api::InverseModel` impl, with the slice-to-array helpers it needs.

use super::context::Gen;
use crate::emit;
use proc_macro2::TokenStream;
use quote::quote;

/// `model_info()`, `Model`, its `Default` and `InverseModel` impls and `arr`; `invert_batch`: the model has
/// `Precomputed::invert_batch` (a block kernel in closed form, Newton's method from point to point otherwise).
pub(super) fn model(
    g: &Gen<'_>,
    (invert_batch, sensitivity_batch): (bool, bool),
    set_map: Option<&TokenStream>,
) -> TokenStream {
    let m = &g.d.model;
    let ne = g.d.eta.len();
    let has_outputs = !m.outputs.is_empty();
    let w = WTokens::new(g.has_w());
    let outputs_impl = outputs_impl(has_outputs, &w);
    let invert_batch_impl = invert_batch_impl(invert_batch, !g.closed, &w);
    let sensitivity_batch_impl = sensitivity_batch_impl(sensitivity_batch, &w);
    let outputs_jacobian_impl = if g.d.outputs_jacobian.is_some() {
        let WTokens {
            name: wn, arg: wa, ..
        } = &w;
        quote! {
            fn outputs_jacobian(&self, x: &[f64], #wn: &[f64], u: f64, out: &mut [f64]) -> bool {
                out.copy_from_slice(&self.pre.outputs_jacobian(arr(x) #wa, u));
                true
            }
        }
    } else {
        quote!()
    };
    let (psi_inv_impl, alpha_impl, beta_impl, zero_impl, invert_impl) = if g.closed && !g.affine {
        non_affine(ne, g.d.input_solution.is_some(), &w)
    } else if g.closed {
        let optional = (
            g.d.zero_dynamics_jacobian.is_some(),
            g.d.zero_dynamics_affine.is_some(),
        );
        closed(ne, optional, &w)
    } else if g.affine {
        numeric(ne, &w)
    } else {
        numeric_non_affine(ne, &w)
    };
    let WTokens {
        name: wn, arg: wa, ..
    } = &w;
    let model_info = model_info(g);
    // The maps (replaced by `set_map`) survive a change of the parameters.
    let keep_maps = if set_map.is_some() {
        quote!(let maps = std::mem::take(&mut self.pre.maps); self.pre = Precomputed::new(&params); self.pre.maps = maps;)
    } else {
        quote!(self.pre = Precomputed::new(&params);)
    };
    quote! {
        #model_info
        /// [`model_info`], built once and shared by every instance (a model with modes builds several of
        /// each mode's code, a sweep one per variant).
        static INFO: std::sync::LazyLock<ModelInfo> = std::sync::LazyLock::new(model_info);

        /// The compiled model behind the runtime's [`InverseModel`] trait.
        #[derive(Debug, Clone)]
        pub struct Model {
            pre: Precomputed,
            values: [f64; N_PARAMS],
            info: &'static ModelInfo,
        }

        impl Model {
            /// The model at parameters `params`.
            pub fn new(params: Params) -> Model {
                Model { pre: Precomputed::new(&params), values: params.to_array(), info: &INFO }
            }
            /// The current parameters.
            pub fn parameters(&self) -> &Params {
                self.pre.params()
            }
            /// Replace the parameters (recomputing their subexpressions).
            pub fn set_parameters(&mut self, params: Params) {
                #keep_maps
                self.values = params.to_array();
            }
            /// The precomputed evaluator (typed, array-based access to every function).
            pub fn precomputed(&self) -> &Precomputed {
                &self.pre
            }
        }

        impl Default for Model {
            /// The model at the model file's parameter values.
            fn default() -> Model {
                Model::new(Params::default())
            }
        }

        impl InverseModel for Model {
            fn info(&self) -> &ModelInfo {
                self.info
            }
            fn params(&self) -> &[f64] {
                &self.values
            }
            fn set_param(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
                let mut params = *self.pre.params();
                params.set(name, value)?;
                self.set_parameters(params);
                Ok(())
            }
            fn h(&self, x: &[f64], #wn: &[f64]) -> f64 {
                self.pre.h(arr(x) #wa)
            }
            fn psi(&self, x: &[f64], #wn: &[f64], xi: &mut [f64], eta: &mut [f64]) {
                let (a, b) = self.pre.psi(arr(x) #wa);
                xi.copy_from_slice(&a);
                eta.copy_from_slice(&b);
            }
            #psi_inv_impl
            #alpha_impl
            #beta_impl
            #zero_impl
            fn rhs(&self, x: &[f64], #wn: &[f64], u: f64, dx: &mut [f64]) {
                dx.copy_from_slice(&self.pre.rhs(arr(x) #wa, u));
            }
            #outputs_impl
            fn sensitivity(&self, x: &[f64], #wn: &[f64], u: f64, out: &mut [f64]) -> Result<(), ModelError> {
                out.copy_from_slice(&self.pre.sensitivity(arr(x) #wa, u));
                Ok(())
            }
            #sensitivity_batch_impl
            #outputs_jacobian_impl
            fn reference(&self) -> ReferenceMap {
                REFERENCE
            }
            #invert_impl
            #invert_batch_impl
            #set_map
        }

        /// The fixed-size array behind a slice of one of the model's dimensions (a wrong length is a bug in
        /// the caller, as the trait documents).
        fn arr<const K: usize>(s: &[f64]) -> &[f64; K] {
            s.try_into().expect("slice length matches the model's dimensions")
        }
    }
}

/// `cols` and `cols_mut`, for the batch methods.
pub(super) fn column_helpers() -> TokenStream {
    quote! {
        /// The fixed-size array of columns behind a slice of columns (a wrong count is a bug in the
        /// caller, as the trait documents).
        fn cols<'a, const K: usize>(s: &[&'a [f64]]) -> [&'a [f64]; K] {
            s.try_into().expect("column count matches the model's dimensions")
        }

        /// The same for columns written to.
        fn cols_mut<'a, const K: usize>(s: &'a mut [&mut [f64]]) -> [&'a mut [f64]; K] {
            let s: &'a mut [&mut [f64]; K] = s
                .try_into()
                .expect("column count matches the model's dimensions");
            s.each_mut().map(|c| &mut **c)
        }
    }
}

/// The signal values in the trait impl: the parameter's name (`_w` for a model without signals, whose
/// `Precomputed` functions take none), `, arr(w)` and `, cols(w)` passed on (empty without signals).
struct WTokens {
    name: TokenStream,
    arg: TokenStream,
    cols: TokenStream,
}

impl WTokens {
    fn new(has_w: bool) -> WTokens {
        if has_w {
            WTokens {
                name: quote!(w),
                arg: quote!(, arr(w)),
                cols: quote!(, cols(w)),
            }
        } else {
            WTokens {
                name: quote!(_w),
                arg: quote!(),
                cols: quote!(),
            }
        }
    }
}

/// `psi_inv`, `alpha`, `beta`, `zero_dynamics` and `invert` of the trait impl.
type Impls = (
    TokenStream,
    TokenStream,
    TokenStream,
    TokenStream,
    TokenStream,
);

/// The trait's functions for a closed-form ψ⁻¹ (`zero_jacobian`: the zero dynamics' partial derivatives in the
/// normal-form coordinates too; `zero_affine`: their coefficients A, b where they are affine in η).
fn closed(ne: usize, (zero_jacobian, zero_affine): (bool, bool), w: &WTokens) -> Impls {
    let WTokens {
        name: wn, arg: wa, ..
    } = w;
    (
        quote! {
            fn psi_inv(&self, xi: &[f64], eta: &[f64], #wn: &[f64], x: &mut [f64]) -> Result<(), ModelError> {
                x.copy_from_slice(&self.pre.psi_inv(arr(xi), arr(eta) #wa));
                Ok(())
            }
        },
        quote! {
            fn alpha(&self, xi: &[f64], eta: &[f64], #wn: &[f64]) -> f64 {
                self.pre.alpha(arr(xi), arr(eta) #wa)
            }
        },
        quote! {
            fn beta(&self, xi: &[f64], eta: &[f64], #wn: &[f64]) -> f64 {
                self.pre.beta(arr(xi), arr(eta) #wa)
            }
        },
        if ne > 0 {
            let jacobian = if zero_jacobian {
                quote! {
                    fn zero_dynamics_jacobian(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, out: &mut [f64]) -> bool {
                        out.copy_from_slice(&self.pre.zero_dynamics_jacobian(arr(xi), arr(eta) #wa, yr));
                        true
                    }
                }
            } else {
                quote!()
            };
            let affine = if zero_affine {
                quote! {
                    fn zero_dynamics_affine(&self, xi: &[f64], #wn: &[f64], yr: f64, out: &mut [f64]) -> bool {
                        out.copy_from_slice(&self.pre.zero_dynamics_affine(arr(xi), &[0.0; N_ETA] #wa, yr));
                        true
                    }
                }
            } else {
                quote!()
            };
            quote! {
                fn zero_dynamics(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, deta: &mut [f64]) {
                    deta.copy_from_slice(&self.pre.zero_dynamics(arr(xi), arr(eta) #wa, yr));
                }
                #jacobian
                #affine
            }
        } else {
            quote! {
                fn zero_dynamics(&self, _xi: &[f64], _eta: &[f64], _w: &[f64], _yr: f64, _deta: &mut [f64]) {}
            }
        },
        quote! {
            /// ψ⁻¹, α and β in one evaluation.
            fn invert(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, x: &mut [f64]) -> Result<f64, ModelError> {
                let (states, u) = self.pre.invert(arr(xi), arr(eta) #wa, yr);
                x.copy_from_slice(&states);
                Ok(u)
            }
        },
    )
}

/// The trait's functions for a closed-form ψ⁻¹ and a y^(r) = φ(ξ, η, w, u) not affine in u (as the
/// interpreter: α and β are φ and ∂φ/∂u at u = 0, the linearisation there; the input from
/// `Precomputed::solve_input`, by Newton's method from the guess where it was not isolated).
fn non_affine(ne: usize, isolated: bool, w: &WTokens) -> Impls {
    let WTokens {
        name: wn, arg: wa, ..
    } = w;
    let psi_inv = closed(ne, (false, false), w).0;
    // The zero dynamics take u: none where it is substituted by the input solution, else Newton's.
    let u = if isolated {
        quote!({
            let _ = u_guess;
            0.0
        })
    } else {
        quote!(self.pre.solve_input(arr(xi), arr(eta) #wa, yr, u_guess).unwrap_or(f64::NAN))
    };
    let zero = if ne > 0 {
        quote! {
            fn zero_dynamics(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, deta: &mut [f64]) {
                self.zero_dynamics_from(xi, eta, #wn, yr, f64::NAN, deta);
            }
            /// The zero dynamics at the input solving φ = y^(r) (Newton from `u_guess`).
            fn zero_dynamics_from(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, u_guess: f64, deta: &mut [f64]) {
                let u = #u;
                deta.copy_from_slice(&self.pre.zero_dynamics(arr(xi), arr(eta) #wa, yr, u));
            }
        }
    } else {
        quote! {
            fn zero_dynamics(&self, _xi: &[f64], _eta: &[f64], _w: &[f64], _yr: f64, _deta: &mut [f64]) {}
        }
    };
    (
        psi_inv,
        quote! {
            /// φ at u = 0 (the linearisation y^(r) ≈ α + β·u there, as the interpreter).
            fn alpha(&self, xi: &[f64], eta: &[f64], #wn: &[f64]) -> f64 {
                self.pre.phi(arr(xi), arr(eta) #wa, 0.0).0
            }
        },
        quote! {
            /// ∂φ/∂u at u = 0.
            fn beta(&self, xi: &[f64], eta: &[f64], #wn: &[f64]) -> f64 {
                self.pre.phi(arr(xi), arr(eta) #wa, 0.0).1
            }
        },
        zero,
        quote! {
            /// ψ⁻¹ and the input solving φ = y^(r) (Newton from the middle of the input's bounds).
            fn invert(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, x: &mut [f64]) -> Result<f64, ModelError> {
                self.invert_from(xi, eta, #wn, yr, x, f64::NAN)
            }
            /// ψ⁻¹ and the input solving φ = y^(r), Newton from `u_guess` (the previous sample's input).
            fn invert_from(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, x: &mut [f64], u_guess: f64) -> Result<f64, ModelError> {
                let (states, u) = self.pre.invert(arr(xi), arr(eta) #wa, yr, u_guess)?;
                x.copy_from_slice(&states);
                Ok(u)
            }
        },
    )
}

/// The same through Newton's method (from x = 1, as the interpreter, or from the guess in `x`).
fn numeric(ne: usize, w: &WTokens) -> Impls {
    let WTokens {
        name: wn, arg: wa, ..
    } = w;
    (
        quote! {
            fn psi_inv(&self, xi: &[f64], eta: &[f64], #wn: &[f64], x: &mut [f64]) -> Result<(), ModelError> {
                let states = self.pre.psi_inv(arr(xi), arr(eta) #wa, arr(x))?;
                x.copy_from_slice(&states);
                Ok(())
            }
        },
        quote! {
            /// Newton from x = 1 (as the interpreter); NaN if it does not converge.
            fn alpha(&self, xi: &[f64], eta: &[f64], #wn: &[f64]) -> f64 {
                self.pre.alpha(arr(xi), arr(eta) #wa, &[1.0; N]).unwrap_or(f64::NAN)
            }
        },
        quote! {
            /// Newton from x = 1 (as the interpreter); NaN if it does not converge.
            fn beta(&self, xi: &[f64], eta: &[f64], #wn: &[f64]) -> f64 {
                self.pre.beta(arr(xi), arr(eta) #wa, &[1.0; N]).unwrap_or(f64::NAN)
            }
        },
        if ne > 0 {
            quote! {
                /// Newton from x = 1 (as the interpreter); NaN if it does not converge.
                fn zero_dynamics(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, deta: &mut [f64]) {
                    match self.pre.zero_dynamics(arr(xi), arr(eta) #wa, yr, &[1.0; N]) {
                        Ok(q) => deta.copy_from_slice(&q),
                        Err(_) => deta.fill(f64::NAN),
                    }
                }
            }
        } else {
            quote! {
                fn zero_dynamics(&self, _xi: &[f64], _eta: &[f64], _w: &[f64], _yr: f64, _deta: &mut [f64]) {}
            }
        },
        quote! {
            /// Newton from the guess in `x`, then u = (y^(r) − α)/β at the solution.
            fn invert(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, x: &mut [f64]) -> Result<f64, ModelError> {
                let (states, u) = self.pre.invert(arr(xi), arr(eta) #wa, yr, arr(x))?;
                x.copy_from_slice(&states);
                Ok(u)
            }
        },
    )
}

/// The trait's functions for a numeric ψ⁻¹ and a y^(r) = φ(x, w, u) not affine in u, as the interpreter:
/// x = ψ⁻¹(ξ, η) by Newton's method (from x = 1 for α, β and the zero dynamics, from the guess in `x` for
/// the inverse), then φ and ∂φ/∂u at u = 0 (α, β: the linearisation there) or the input solving
/// φ(x, w, u) = y^(r) (`Precomputed::solve_input_x`, Newton from `u_guess` where it was not isolated).
fn numeric_non_affine(ne: usize, w: &WTokens) -> Impls {
    let WTokens {
        name: wn, arg: wa, ..
    } = w;
    let phi_at_zero = |part: TokenStream| {
        quote! {
            match self.pre.psi_inv(arr(xi), arr(eta) #wa, &[1.0; N]) {
                Ok(x) => self.pre.phi_x(&x #wa, 0.0).#part,
                Err(_) => f64::NAN,
            }
        }
    };
    let (alpha, beta) = (phi_at_zero(quote!(0)), phi_at_zero(quote!(1)));
    let zero = if ne > 0 {
        quote! {
            fn zero_dynamics(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, deta: &mut [f64]) {
                self.zero_dynamics_from(xi, eta, #wn, yr, f64::NAN, deta);
            }
            /// Newton from x = 1 (as the interpreter), the input from `u_guess`; NaN if ψ⁻¹ does not converge.
            fn zero_dynamics_from(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, u_guess: f64, deta: &mut [f64]) {
                match self.pre.zero_dynamics(arr(xi), arr(eta) #wa, yr, &[1.0; N], u_guess) {
                    Ok(q) => deta.copy_from_slice(&q),
                    Err(_) => deta.fill(f64::NAN),
                }
            }
        }
    } else {
        quote! {
            fn zero_dynamics(&self, _xi: &[f64], _eta: &[f64], _w: &[f64], _yr: f64, _deta: &mut [f64]) {}
        }
    };
    (
        numeric(ne, w).0,
        quote! {
            /// φ at u = 0 (the linearisation y^(r) ≈ α + β·u there), x by Newton from x = 1; NaN if it does
            /// not converge.
            fn alpha(&self, xi: &[f64], eta: &[f64], #wn: &[f64]) -> f64 {
                #alpha
            }
        },
        quote! {
            /// ∂φ/∂u at u = 0, x by Newton from x = 1; NaN if it does not converge.
            fn beta(&self, xi: &[f64], eta: &[f64], #wn: &[f64]) -> f64 {
                #beta
            }
        },
        zero,
        quote! {
            /// ψ⁻¹ by Newton from the guess in `x`, then the input solving φ = y^(r) (Newton from the middle
            /// of the input's bounds).
            fn invert(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, x: &mut [f64]) -> Result<f64, ModelError> {
                self.invert_from(xi, eta, #wn, yr, x, f64::NAN)
            }
            /// ψ⁻¹ by Newton from the guess in `x` (written back once converged), then the input solving
            /// φ(x, w, u) = y^(r) there, Newton from `u_guess` (the previous sample's input).
            fn invert_from(&self, xi: &[f64], eta: &[f64], #wn: &[f64], yr: f64, x: &mut [f64], u_guess: f64) -> Result<f64, ModelError> {
                let states = self.pre.psi_inv(arr(xi), arr(eta) #wa, arr(x))?;
                x.copy_from_slice(&states);
                self.pre.solve_input_x(&states #wa, yr, u_guess)
            }
        },
    )
}

fn opt_f64(v: Option<f64>) -> TokenStream {
    match v {
        Some(x) => {
            let t = emit::float_tokens(x, false);
            quote!(Some(#t))
        }
        None => quote!(None),
    }
}

fn opt_string(v: &Option<String>) -> TokenStream {
    match v {
        Some(s) => quote!(Some(#s.to_string())),
        None => quote!(None),
    }
}

/// The trait's `outputs` and `outputs_batch`.
fn outputs_impl(has_outputs: bool, w: &WTokens) -> TokenStream {
    let WTokens {
        name: wn,
        arg: wa,
        cols: wc,
    } = w;
    if has_outputs {
        quote! {
            fn outputs(&self, x: &[f64], #wn: &[f64], u: f64, out: &mut [f64]) {
                out.copy_from_slice(&self.pre.outputs(arr(x) #wa, u));
            }
            /// The outputs over columns, block by block ([`Precomputed::outputs_batch`]).
            fn outputs_batch(&self, x: &[&[f64]], #wn: &[&[f64]], u: &[f64], out: &mut [&mut [f64]]) {
                self.pre.outputs_batch(cols(x) #wc, u, cols_mut(out));
            }
        }
    } else {
        quote! {
            fn outputs(&self, _x: &[f64], _w: &[f64], _u: f64, _out: &mut [f64]) {}
            fn outputs_batch(&self, _x: &[&[f64]], _w: &[&[f64]], _u: &[f64], _out: &mut [&mut [f64]]) {}
        }
    }
}

/// The trait's `sensitivity_batch`, when the model has `Precomputed::sensitivity_batch` (else the trait's
/// default, point by point).
fn sensitivity_batch_impl(has: bool, w: &WTokens) -> TokenStream {
    if !has {
        return quote!();
    }
    let WTokens {
        name: wn, cols: wc, ..
    } = w;
    quote! {
        /// The partial derivatives over columns, block by block ([`Precomputed::sensitivity_batch`]).
        fn sensitivity_batch(
            &self,
            x: &[&[f64]],
            #wn: &[&[f64]],
            u: &[f64],
            (out, invariant): (&mut [&mut [f64]], bool),
        ) -> Result<(), (usize, ModelError)> {
            self.pre.sensitivity_batch(cols(x) #wc, u, cols_mut(out), invariant);
            Ok(())
        }
    }
}

/// The trait's `invert_batch`, when the model has `Precomputed::invert_batch` (which returns the first failing
/// point's error where ψ⁻¹ is solved by Newton's method, nothing where it is in closed form).
fn invert_batch_impl(invert_batch: bool, numeric: bool, w: &WTokens) -> TokenStream {
    let WTokens {
        name: wn, cols: wc, ..
    } = w;
    if !invert_batch {
        return quote!();
    }
    let (doc, call) = if numeric {
        (
            quote!(#[doc = " ψ⁻¹ by Newton's method from point to point, α and β over columns ([`Precomputed::invert_batch`])."]),
            quote!(self.pre.invert_batch(cols(xi), cols(eta) #wc, yr, cols_mut(x), u)),
        )
    } else {
        (
            quote!(#[doc = " ψ⁻¹, α and β over columns, block by block ([`Precomputed::invert_batch`])."]),
            quote!(self.pre.invert_batch(cols(xi), cols(eta) #wc, yr, cols_mut(x), u); Ok(())),
        )
    };
    quote! {
        #doc
        fn invert_batch(
            &self,
            xi: &[&[f64]],
            eta: &[&[f64]],
            #wn: &[&[f64]],
            yr: &[f64],
            x: &mut [&mut [f64]],
            u: &mut [f64],
        ) -> Result<(), (usize, ModelError)> {
            #call
        }
    }
}

/// `model_info()`: the static description (names, sizes, bounds).
fn model_info(g: &Gen<'_>) -> TokenStream {
    let m = &g.d.model;
    let outputs_info: Vec<TokenStream> = m
        .outputs
        .iter()
        .map(|o| {
            let (name, unit, acc) = (&o.name, opt_string(&o.unit), o.accumulate);
            let per_distance = o.per_distance;
            quote!(OutputInfo {
                name: #name.to_string(), unit: #unit, accumulate: #acc, per_distance: #per_distance
            })
        })
        .collect();
    let outputs_vec = if outputs_info.is_empty() {
        quote!(Vec::new())
    } else {
        quote!(Vec::from([#(#outputs_info),*]))
    };
    let (input_min, input_max) = (opt_f64(m.input.min), opt_f64(m.input.max));
    let description = m.description.clone().unwrap_or_default();
    let state_units: Vec<TokenStream> = m.states.iter().map(|s| opt_string(&s.unit)).collect();
    let (input_unit, output_unit) = (opt_string(&m.input.unit), opt_string(&m.output.unit));
    let engine = match &m.engine {
        Some(e) => {
            let (speed, torque) = (e.speed, e.torque);
            let map = match &e.map {
                Some(map) => {
                    let (expr, unit) = (&map.expr, opt_string(&map.unit));
                    let range = match map.range {
                        Some([lo, hi]) => quote!(Some([#lo, #hi])),
                        None => quote!(None),
                    };
                    quote!(Some(invsim_model_api::EngineMapInfo { expr: #expr.to_string(), unit: #unit, range: #range }))
                }
                None => quote!(None),
            };
            quote!(Some(invsim_model_api::EngineInfo { speed: #speed, torque: #torque, map: #map }))
        }
        None => quote!(None),
    };
    let headline = headline_info(m.headline.as_ref());
    let signals = signals_info(m);
    let state_initial: Vec<TokenStream> = m.states.iter().map(|s| opt_f64(s.initial)).collect();
    let eta_states: Vec<proc_macro2::Literal> =
        g.d.eta_states
            .iter()
            .map(|&j| proc_macro2::Literal::usize_unsuffixed(j))
            .collect();
    let lit = proc_macro2::Literal::usize_unsuffixed;
    let calls = g.d.map_calls.iter().map(|c| {
        let (map, i, j) = (lit(c.map), lit(c.orders[0]), lit(c.orders[1]));
        quote!(invsim_model_api::MapCall { map: #map, orders: [#i, #j] })
    });
    let map_calls = if g.d.map_calls.is_empty() {
        quote!(Vec::new())
    } else {
        quote!(Vec::from([#(#calls),*]))
    };
    let eta_free = eta_free_info(&g.d.eta_free());
    let zero_dynamics_affine = g.d.zero_dynamics_affine.is_some();
    quote! {
        /// The model's static description (names, sizes, bounds), as the interpreter reports it.
        pub fn model_info() -> ModelInfo {
            ModelInfo {
                name: NAME.to_string(),
                description: #description.to_string(),
                source_hash: Some(SOURCE_HASH.to_string()),
                states: STATES.iter().map(|s| s.to_string()).collect(),
                state_units: Vec::from([#(#state_units),*]),
                input: INPUT.to_string(),
                input_unit: #input_unit,
                output: OUTPUT.to_string(),
                output_unit: #output_unit,
                relative_degree: R,
                n_eta: N_ETA,
                input_min: #input_min,
                input_max: #input_max,
                outputs: #outputs_vec,
                parameters: PARAMETERS.iter().map(|s| s.to_string()).collect(),
                engine: #engine,
                headline: #headline,
                signals: #signals,
                state_initial: Vec::from([#(#state_initial),*]),
                eta_states: Vec::from([#(#eta_states),*]),
                map_calls: #map_calls,
                eta_free: #eta_free,
                zero_dynamics_affine: #zero_dynamics_affine,
            }
        }

    }
}

/// `ModelInfo::eta_free`: which of u and the extra outputs are free of η.
fn eta_free_info(free: &invsim_model_api::EtaFree) -> TokenStream {
    let input = free.input;
    let outputs = &free.outputs;
    quote!(invsim_model_api::EtaFree { input: #input, outputs: Vec::from([#(#outputs),*]) })
}

/// `ModelInfo::headline`: the model file's `[headline]`, `None` without one.
fn headline_info(h: Option<&invsim_model_api::HeadlineInfo>) -> TokenStream {
    use invsim_model_api::{Carrier, Density, FuelFlow};
    let Some(h) = h else {
        return quote!(None);
    };
    let api = quote!(invsim_model_api);
    let float = |x: f64| emit::float_tokens(x, false);
    let carrier = match &h.carrier {
        Carrier::Electricity { kwh_per_unit } => {
            let k = float(*kwh_per_unit);
            quote!(#api::Carrier::Electricity { kwh_per_unit: #k })
        }
        Carrier::Fuel(f) => {
            let flow = match f.flow {
                FuelFlow::Litres(x) => {
                    let x = float(x);
                    quote!(#api::FuelFlow::Litres(#x))
                }
                FuelFlow::Kilograms(x) => {
                    let x = float(x);
                    quote!(#api::FuelFlow::Kilograms(#x))
                }
            };
            let density = match f.density {
                Density::Value(x) => {
                    let x = float(x);
                    quote!(#api::Density::Value(#x))
                }
                Density::Parameter(i) => quote!(#api::Density::Parameter(#i)),
            };
            let (name, carbon) = (&f.name, float(f.carbon_fraction));
            quote!(#api::Carrier::Fuel(#api::FuelInfo {
                name: #name.to_string(), flow: #flow, density: #density, carbon_fraction: #carbon
            }))
        }
    };
    let output = h.output;
    quote!(Some(#api::HeadlineInfo { output: #output, carrier: #carrier }))
}

/// `ModelInfo::signals`: `Vec::new()` for a model without signals.
fn signals_info(m: &invsim_inversion::Model) -> TokenStream {
    if m.signals.is_empty() {
        return quote!(Vec::new());
    }
    let items: Vec<TokenStream> = m
        .signals
        .iter()
        .map(|s| {
            let (name, unit, doc) = (&s.name, opt_string(&s.unit), opt_string(&s.doc));
            let (default, column) = (opt_f64(s.default), opt_string(&s.column));
            quote!(invsim_model_api::SignalInfo {
                name: #name.to_string(), unit: #unit, doc: #doc, default: #default, column: #column
            })
        })
        .collect();
    quote!(Vec::from([#(#items),*]))
}
