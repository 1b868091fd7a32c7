//! A model with operating modes (README "Modes") to one Rust file: one generated module per mode (each an
//! `InverseModel` exactly like a single-mode model's, see [`crate::model`]), nested in a module named after
//! the model, with the table of its modes (`MODES`, in the order of the model file) and `models()`, which
//! builds every mode's model at its default parameters in that order.

use crate::error::{CodegenError, Error};
use crate::format;
use crate::generate::header;
use crate::names;
use invsim_inversion::{Derivation, ModalModel};
use quote::{format_ident, quote};

/// Every mode of `m` derived, in the model file's order: (mode name, derivation).
pub fn derive_modes(m: ModalModel) -> Result<Vec<(String, Derivation)>, Error> {
    m.modes
        .into_iter()
        .map(|mode| {
            let d = Derivation::new(mode.model).map_err(invsim_inversion::Error::from)?;
            Ok((mode.name, d))
        })
        .collect()
}

/// The module name of mode `name`: `mode_<name>` (cannot clash with the table's items).
pub fn mode_module(name: &str) -> String {
    format!("mode_{}", names::module_name(name))
}

/// Formatted Rust source of a model with modes from its modes' derivations (`derive_modes`).
pub fn generate_modal(
    name: &str,
    sha256: &str,
    modes: &[(String, Derivation)],
    source_name: &str,
) -> Result<String, CodegenError> {
    let mut items = Vec::new();
    let mut comments = Vec::new();
    for (mode, d) in modes {
        if !d.yr_affine && !d.psi_inv_closed() {
            return Err(CodegenError::NonAffine {
                model: format!("{name}, mode {mode}"),
            });
        }
        let out = crate::model::module_named(d, source_name, &mode_module(mode))?;
        items.push(out.tokens);
        comments.extend(out.comments);
    }
    let mode_names: Vec<&str> = modes.iter().map(|(n, _)| n.as_str()).collect();
    let ctors = modes.iter().map(|(n, _)| {
        let m = format_ident!("{}", mode_module(n));
        quote!(Box::new(#m::Model::default()))
    });
    let doc = format!(
        " Generated code of the model `{name}` with {} operating modes, from {source_name}: one module per \
         mode (an `InverseModel` with that mode's free input), `MODES` and `models()` in the file's order.",
        modes.len()
    );
    let ident = format_ident!("{}", names::module_name(name));
    let tokens = quote! {
        #[doc = #doc]
        pub mod #ident {
            /// SHA-256 of the model file this module was generated from.
            pub const SOURCE_HASH: &str = #sha256;

            /// The modes' names, in the model file's order.
            pub const MODES: &[&str] = &[#(#mode_names),*];

            /// Every mode's model at its default parameters, in the order of [`MODES`].
            pub fn models() -> Vec<Box<dyn invsim_model_api::InverseModel>> {
                vec![#(#ctors),*]
            }

            #(#items)*
        }
    };
    format::format_file(tokens, &header(source_name, sha256), &comments, name)
}
