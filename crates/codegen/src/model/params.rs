//! The module's constants (name, sizes, names, reference map) and `Params`: one documented field per
//! parameter, `Default` = the model file's values, serde, access by name and as an array.

use super::context::Gen;
use super::docs::{escape_doc, number_text};
use crate::emit;
use proc_macro2::{Ident, TokenStream};
use quote::quote;

/// `NAME`, `N`, `STATES`, `REFERENCE`, … for the model; `source_name` is the model file's name.
pub(super) fn constants(g: &Gen<'_>, source_name: &str, batch: bool) -> TokenStream {
    let d = g.d;
    let m = &d.model;
    let lit = proc_macro2::Literal::usize_unsuffixed;
    let (n_lit, r_lit, ne_lit) = (lit(d.n()), lit(d.relative_degree), lit(d.eta.len()));
    let (np_lit, no_lit) = (lit(m.parameters.len()), lit(m.outputs.len()));
    let ns_lit = lit(d.sensitivity.len());
    let name = &m.name;
    let hash = &m.source_hash;
    let description_lit = m.description.clone().unwrap_or_default();
    let state_names: Vec<&str> = m.states.iter().map(|s| s.name.as_str()).collect();
    let param_names: Vec<&str> = m.parameters.iter().map(|p| p.name.as_str()).collect();
    let output_names: Vec<&str> = m.outputs.iter().map(|o| o.name.as_str()).collect();
    let input_name = &m.input.name;
    let output_name = &m.output.name;
    let ref_offset = emit::float_tokens(m.output.reference_offset, false);
    let ref_scale = emit::float_tokens(m.output.reference_scale, false);
    let block_const = if batch {
        quote! {
            /// Points per block of the batch methods of [`Precomputed`] (`*_batch`): their block buffers hold
            /// this many values each, on the stack.
            pub const BLOCK: usize = 256;
        }
    } else {
        quote!()
    };
    // Only a model whose zero dynamics or outputs have closed-form partial derivatives has their counts.
    let count = |e: &Option<Vec<invsim_expr::Id>>| e.as_ref().map(|e| lit(e.len()));
    let zdj_const = match count(&d.zero_dynamics_jacobian) {
        Some(n) => quote! {
            /// Number of partial derivatives `zero_dynamics_jacobian` returns: N_ETA·(N_ETA + R + 1 + N_PARAMS).
            pub const N_ZDJ: usize = #n;
        },
        None => quote!(),
    };
    let zda_const = match count(&d.zero_dynamics_affine) {
        Some(n) => quote! {
            /// Number of values `zero_dynamics_affine` returns: N_ETA·(N_ETA + 1), A row-major then b.
            pub const N_ZDA: usize = #n;
        },
        None => quote!(),
    };
    let oj_const = match count(&d.outputs_jacobian) {
        Some(n) => quote! {
            /// Number of partial derivatives `outputs_jacobian` returns: N_OUTPUTS·(N_ETA + R + 1 + N_PARAMS).
            pub const N_OJ: usize = #n;
        },
        None => quote!(),
    };
    // Only a model with signals has them (the code of every other model is unchanged).
    let signal_consts = if g.d.w.is_empty() {
        quote!()
    } else {
        let nw = proc_macro2::Literal::usize_unsuffixed(g.d.w.len());
        let names: Vec<String> = g.d.model.signals.iter().map(|s| s.name.clone()).collect();
        let ns = proc_macro2::Literal::usize_unsuffixed(names.len());
        quote! {
            /// Length of the signal values `w`: S, S_d1, …, S_dr for each signal S.
            pub const NW: usize = #nw;
            /// The signals' names, in the model file's order.
            pub const SIGNALS: [&str; #ns] = [#(#names),*];
        }
    };
    quote! {
        /// Model name.
        pub const NAME: &str = #name;
        /// One-line description from the model file.
        pub const DESCRIPTION: &str = #description_lit;
        /// The model file this code was generated from.
        pub const SOURCE_FILE: &str = #source_name;
        /// SHA-256 of the model file's bytes (lower-case hex).
        pub const SOURCE_HASH: &str = #hash;
        /// Number of states n.
        pub const N: usize = #n_lit;
        /// Relative degree r.
        pub const R: usize = #r_lit;
        /// Number of internal coordinates η (n − r).
        pub const N_ETA: usize = #ne_lit;
        /// Number of parameters.
        pub const N_PARAMS: usize = #np_lit;
        /// Number of extra outputs.
        pub const N_OUTPUTS: usize = #no_lit;
        /// Number of partial derivatives `sensitivity` returns: (R + 1 + N_ETA + N_OUTPUTS)·(N + 1 + N_PARAMS + C)
        /// + 2·C, with C the map calls of `model_info().map_calls` (their columns and arguments).
        pub const N_SENS: usize = #ns_lit;
        /// State names, in the model file's order.
        pub const STATES: [&str; N] = [#(#state_names),*];
        /// The input's name.
        pub const INPUT: &str = #input_name;
        /// The tracked output's name.
        pub const OUTPUT: &str = #output_name;
        /// Parameter names, in the model file's order (the order of [`InverseModel::params`]).
        pub const PARAMETERS: [&str; N_PARAMS] = [#(#param_names),*];
        /// Names of the extra outputs.
        pub const OUTPUTS: [&str; N_OUTPUTS] = [#(#output_names),*];
        /// How a drive cycle defines the tracked output's reference: y_d = offset + scale · (smoothed cycle).
        pub const REFERENCE: ReferenceMap = ReferenceMap { offset: #ref_offset, scale: #ref_scale };
        #block_const
        #zdj_const
        #zda_const
        #oj_const
        #signal_consts
    }
}

/// The model file's parameter values as a `Params` literal (`Params { m: 1300.0, … }`).
pub(super) fn literal(g: &Gen<'_>) -> TokenStream {
    let values = g.d.model.parameters.iter().map(|p| {
        let id = &g.fields[&p.symbol].ident;
        let v = emit::float_tokens(p.value, false);
        quote!(#id: #v,)
    });
    quote!(Params { #(#values)* })
}

/// `Params`, its `Default` and its methods.
pub(super) fn params(g: &Gen<'_>) -> TokenStream {
    let m = &g.d.model;
    let field_defs: Vec<TokenStream> = m
        .parameters
        .iter()
        .map(|p| {
            let f = &g.fields[&p.symbol];
            let id = &f.ident;
            let mut text = p
                .doc
                .clone()
                .unwrap_or_else(|| format!("Parameter `{}`", p.name));
            if let Some(u) = &p.unit {
                text.push_str(&format!(" ({u})"));
            }
            text.push_str(&format!("; default {}.", number_text(p.value)));
            let text = format!(" {}", escape_doc(&text));
            let rename = f
                .serde_rename
                .as_ref()
                .map(|n| quote!(#[serde(rename = #n)]));
            quote!(#[doc = #text] #rename pub #id: f64,)
        })
        .collect();
    let all_zero = m
        .parameters
        .iter()
        .all(|p| p.value == 0.0 && p.value.is_sign_positive());
    let defaults: Vec<TokenStream> = m
        .parameters
        .iter()
        .map(|p| {
            let id = &g.fields[&p.symbol].ident;
            let v = emit::float_tokens(p.value, false);
            quote!(#id: #v,)
        })
        .collect();
    let field_ids: Vec<&Ident> = m
        .parameters
        .iter()
        .map(|p| &g.fields[&p.symbol].ident)
        .collect();
    let (derive_default, default_impl) = if all_zero {
        (quote!(Default,), quote!())
    } else {
        (
            quote!(),
            quote! {
                impl Default for Params {
                    /// The model file's values.
                    fn default() -> Params {
                        Params { #(#defaults)* }
                    }
                }
            },
        )
    };
    let (get_fn, set_fn, from_array_fn) = accessors(g);
    quote! {
        /// The model's parameters; [`Default`] gives the model file's values.
        #[derive(Debug, Clone, Copy, PartialEq, #derive_default serde::Serialize, serde::Deserialize)]
        #[serde(default, deny_unknown_fields)]
        pub struct Params {
            #(#field_defs)*
        }

        #default_impl

        impl Params {
            /// The values in [`PARAMETERS`] order.
            pub fn to_array(&self) -> [f64; N_PARAMS] {
                [#(self.#field_ids),*]
            }
            #from_array_fn
            #get_fn
            #set_fn
        }

    }
}

/// `get`, `set` and `from_array` of `Params`.
fn accessors(g: &Gen<'_>) -> (TokenStream, TokenStream, TokenStream) {
    let m = &g.d.model;
    let np = m.parameters.len();
    let lit = proc_macro2::Literal::usize_unsuffixed;
    let param_names: Vec<&str> = m.parameters.iter().map(|p| p.name.as_str()).collect();
    let field_ids: Vec<&Ident> = m
        .parameters
        .iter()
        .map(|p| &g.fields[&p.symbol].ident)
        .collect();
    let idx: Vec<proc_macro2::Literal> = (0..np).map(lit).collect();
    if np == 0 {
        (
            quote! {
                /// The value of the parameter called `name` (this model has none).
                pub fn get(&self, _name: &str) -> Option<f64> {
                    None
                }
            },
            quote! {
                /// Set the parameter called `name` (this model has none: always an error).
                pub fn set(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
                    if !value.is_finite() {
                        return Err(ModelError::NonFiniteParameter { name: name.to_string(), value });
                    }
                    Err(ModelError::UnknownParameter { name: name.to_string(), known: String::new() })
                }
            },
            quote! {
                /// Parameters from values in [`PARAMETERS`] order (this model has none).
                pub fn from_array(_values: &[f64; N_PARAMS]) -> Params {
                    Params {}
                }
            },
        )
    } else {
        (
            quote! {
                /// The value of the parameter called `name`, as written in the model file.
                pub fn get(&self, name: &str) -> Option<f64> {
                    match name {
                        #(#param_names => Some(self.#field_ids),)*
                        _ => None,
                    }
                }
            },
            quote! {
                /// Set the parameter called `name` (as written in the model file) to a finite value.
                pub fn set(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
                    if !value.is_finite() {
                        return Err(ModelError::NonFiniteParameter { name: name.to_string(), value });
                    }
                    match name {
                        #(#param_names => self.#field_ids = value,)*
                        _ => {
                            return Err(ModelError::UnknownParameter {
                                name: name.to_string(),
                                known: PARAMETERS.join(", "),
                            })
                        }
                    }
                    Ok(())
                }
            },
            quote! {
                /// Parameters from values in [`PARAMETERS`] order.
                pub fn from_array(values: &[f64; N_PARAMS]) -> Params {
                    Params { #(#field_ids: values[#idx],)* }
                }
            },
        )
    }
}
