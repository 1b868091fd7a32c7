//! A model with operating modes (README "Modes") to one Rust file: one generated module per mode (each an
//! `InverseModel` exactly like a single-mode model's, see [`crate::model`]), nested in a module named after
//! the model, with the table of its modes (`MODES`, in the order of the model file) and `models()`, which
//! builds every mode's model at its default parameters in that order.

use crate::error::{CodegenError, Error};
use crate::format::{self, header};
use crate::names;
use invsim_inversion::{Derivation, ModalModel, ModeRole};
use quote::{format_ident, quote};

/// A model with operating modes with every mode derived, in the model file's order.
pub struct ModalDerivation {
    pub name: String,
    pub source_hash: String,
    /// The declared inputs' names.
    pub inputs: Vec<String>,
    pub modes: Vec<DerivedMode>,
}

/// One mode and its derivation.
pub struct DerivedMode {
    pub name: String,
    pub role: ModeRole,
    /// Index of the free input into [`ModalDerivation::inputs`].
    pub free: usize,
    /// The other inputs' values: (input index, expression).
    pub fixed: Vec<(usize, String)>,
    pub d: Derivation,
}

impl ModalDerivation {
    /// Derive every mode of `m`.
    pub fn new(m: ModalModel) -> Result<ModalDerivation, Error> {
        let modes = m
            .modes
            .into_iter()
            .map(|mode| {
                let d = Derivation::new(mode.model).map_err(invsim_inversion::Error::from)?;
                Ok(DerivedMode {
                    name: mode.name,
                    role: mode.role,
                    free: mode.free,
                    fixed: mode.fixed,
                    d,
                })
            })
            .collect::<Result<_, Error>>()?;
        Ok(ModalDerivation {
            name: m.name,
            source_hash: m.source_hash,
            inputs: m.inputs.into_iter().map(|i| i.name).collect(),
            modes,
        })
    }

    /// The derivation of every mode in Markdown, as `invsim derive MODEL --format markdown` prints it: a
    /// title line, then per mode its role, free input and fixed inputs and
    /// [`Derivation::to_markdown`].
    pub fn to_markdown(&self) -> String {
        let mut s = format!("model {} with {} modes\n", self.name, self.modes.len());
        for mode in &self.modes {
            let fixed: Vec<String> = mode
                .fixed
                .iter()
                .map(|(i, e)| format!("{} = {e}", self.inputs[*i]))
                .collect();
            s.push_str(&format!(
                "\n== mode {} (role {}, free input {}, {}) ==\n",
                mode.name,
                mode.role.as_str(),
                self.inputs[mode.free],
                fixed.join(", ")
            ));
            s.push_str(&mode.d.to_markdown());
        }
        s
    }
}

/// The module name of mode `name`: `mode_<name>` (cannot clash with the table's items).
pub fn mode_module(name: &str) -> String {
    format!("mode_{}", names::module_name(name))
}

/// Formatted Rust source of a model with modes from its modes' derivations.
pub fn generate_modal(m: &ModalDerivation, source_name: &str) -> Result<String, CodegenError> {
    let (name, sha256) = (m.name.as_str(), m.source_hash.as_str());
    let mut items = Vec::new();
    let mut comments = Vec::new();
    for DerivedMode { name: mode, d, .. } in &m.modes {
        if !d.yr_affine && !d.psi_inv_closed() {
            return Err(CodegenError::NonAffine {
                model: format!("{name}, mode {mode}"),
            });
        }
        let out = crate::model::module_named(d, source_name, &mode_module(mode))?;
        items.push(out.tokens);
        comments.extend(out.comments);
    }
    let mode_names: Vec<&str> = m.modes.iter().map(|x| x.name.as_str()).collect();
    let ctors = m.modes.iter().map(|x| {
        let m = format_ident!("{}", mode_module(&x.name));
        quote!(Box::new(#m::Model::default()))
    });
    let doc = format!(
        " Generated code of the model `{name}` with {} operating modes, from {source_name}: one module per \
         mode (an `InverseModel` with that mode's free input), `MODES` and `models()` in the file's order.",
        m.modes.len()
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
