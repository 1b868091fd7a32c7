//! The generated module for one model, assembled from small generators (in the manner of prost-build):
//!
//! * [`catalog`]: which per-point functions the model has, with their equations as docs ([`docs`]);
//! * [`functions`]: their lowering (one invariant arena for all), `Precomputed::new`, the methods and the
//!   free wrappers, operands resolved by [`atoms`];
//! * [`newton`]: ψ⁻¹ by Newton's method when it has no closed form;
//! * [`solve_input`]: the input of a y^(r) that is not affine in it (isolated, or Newton's method), in
//!   (ξ, η) or, where ψ⁻¹ is numeric, in the states at Newton's x;
//! * [`batch`]: `invert_batch` and `outputs_batch` over columns of points;
//! * [`params`]: the constants and `Params`;
//! * [`trait_impl`]: `Model` and its `InverseModel` impl;
//! * [`lints`]: the module's attributes.
//!
//! Which functions exist, and what they compute, mirrors the interpreter (`invsim_inversion::Interpreter`).

mod atoms;
mod batch;
mod catalog;
mod context;
mod docs;
mod functions;
mod lints;
mod maps;
mod newton;
mod params;
mod solve_input;
mod trait_impl;

use crate::error::CodegenError;
use crate::names;
use context::Gen;
use invsim_inversion::Derivation;
use proc_macro2::TokenStream;
use quote::{format_ident, quote};

/// The tokens of one model's module and the comments to place above some of its lines.
pub(crate) struct ModuleOut {
    pub tokens: TokenStream,
    pub comments: Vec<(String, String)>,
}

/// One model's module: constants, `Params`, `Precomputed` (the invariant values, the per-point methods,
/// the batch methods), the free functions, `Model` with its trait impl, and the helpers they call.
pub(crate) fn module(d: &Derivation, source_name: &str) -> Result<ModuleOut, CodegenError> {
    module_named(d, source_name, (&names::module_name(&d.model.name), true))
}

/// [`module`] under the module name `module` (a mode of a model with modes is named after its mode), with
/// `sensitivity_batch` where `sensitivity_batch` says so (the gradient's batch pass runs single-mode models:
/// a mode would only carry its code).
pub(crate) fn module_named(
    d: &Derivation,
    source_name: &str,
    (module, sensitivity_batch): (&str, bool),
) -> Result<ModuleOut, CodegenError> {
    let g = Gen::new(d);
    let lowering = functions::lower_all(&g, catalog::functions(&g))?;
    let pre = functions::precomputed(&g, &lowering);
    let (mut methods, mut free_fns, sign) = functions::methods(&g, &lowering);
    let batch = batch::methods(&g, &lowering.fns, &lowering.k_names, sensitivity_batch);
    let mut helpers = Vec::new();
    if !g.closed {
        let newton = newton::newton(&g);
        methods.extend(newton.methods);
        free_fns.extend(newton.free);
        helpers.extend(newton.helpers);
    }
    if !g.affine {
        let solve = if g.closed {
            solve_input::solve_input(&g)
        } else {
            solve_input::solve_input_x(&g)
        };
        methods.extend(solve.methods);
        free_fns.extend(solve.free);
        helpers.extend(solve.helpers);
    }
    if pre.uses_sign || sign || batch.uses_sign {
        helpers.push(functions::sign_helper());
    }
    // Where ψ⁻¹ is solved by Newton's method and y^(r) is affine in u, `invert_batch` is Newton's (newton.rs).
    let newton_batch = !g.closed && g.affine;
    if batch.any() || newton_batch {
        helpers.push(trait_impl::column_helpers());
    }
    let imports = imports(&g, batch.uses_pow_slice);
    let constants = params::constants(&g, source_name, batch.any());
    let params = params::params(&g);
    let map_tokens = maps::map_tokens(&g);
    let model = trait_impl::model(
        &g,
        (batch.invert || newton_batch, batch.sensitivity),
        map_tokens.as_ref().map(|m| &m.trait_method),
    );
    let (k_fields, pre_lets, k_idents) = (&pre.fields, &pre.lets, &pre.idents);
    let (map_items, map_field, map_init, map_use) = match &map_tokens {
        Some(m) => (
            m.items.clone(),
            m.field.clone(),
            m.init.clone(),
            quote!(
                use invsim_model_api::map::Map;
            ),
        ),
        None => Default::default(),
    };
    let batch_methods = &batch.methods;
    let body = quote! {
        #imports
        #map_use
        #constants
        #params
        #map_items

        /// A parameter set with its parameter-only subexpressions computed once, and the model's functions
        /// evaluated per point.
        #[derive(Debug, Clone, PartialEq)]
        pub struct Precomputed {
            params: Params,
            #map_field
            #(#k_fields)*
        }

        impl Precomputed {
            /// Compute the parameter-only subexpressions for `p`.
            #[inline(always)]
            pub fn new(p: &Params) -> Precomputed {
                #(#pre_lets)*
                Precomputed { params: *p, #map_init #(#k_idents),* }
            }

            /// The parameters.
            pub fn params(&self) -> &Params {
                &self.params
            }

            #(#methods)*

            #(#batch_methods)*
        }

        #(#free_fns)*

        #model

        #(#helpers)*
    };
    let (attrs, comments) = lints::attributes(&g, &body);
    let body = lints::with_pi_import(body);
    let mod_doc = docs::module_doc(&g, source_name);
    let module_ident = format_ident!("{}", module);
    let tokens = quote! {
        #mod_doc
        #attrs
        pub mod #module_ident {
            #body
        }
    };
    Ok(ModuleOut { tokens, comments })
}

/// `d`'s parameter values as a literal of its module's `Params`.
pub(crate) fn params_literal(d: &Derivation) -> TokenStream {
    params::literal(&Gen::new(d))
}

/// The module's `use` items.
fn imports(g: &Gen<'_>, uses_pow_slice: bool) -> TokenStream {
    let imports = if g.d.model.outputs.is_empty() {
        quote!(
            use invsim_model_api::{InverseModel, ModelError, ModelInfo, ReferenceMap};
        )
    } else {
        quote!(
            use invsim_model_api::{InverseModel, ModelError, ModelInfo, OutputInfo, ReferenceMap};
        )
    };
    if uses_pow_slice {
        quote!(#imports use invsim_model_api::math::pow_pos_slice;)
    } else {
        imports
    }
}
