//! A model with operating modes (docs/reference.md §2.5) to one Rust file: one generated module per mode (each an
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
    /// The states the mode couples (`couple`): (state index, coupling as written).
    pub coupled: Vec<(usize, String)>,
    /// The inputs a strategy decides (`decided`), by input index.
    pub decided: Vec<usize>,
    pub d: Derivation,
}

impl ModalDerivation {
    /// Derive every mode of `m`.
    pub fn new(m: ModalModel) -> Result<ModalDerivation, Error> {
        let names: Vec<String> = m.inputs.iter().map(|i| i.name.clone()).collect();
        let modes = m
            .modes
            .into_iter()
            .map(|mode| {
                let d = Derivation::new(mode.model).map_err(invsim_inversion::Error::from)?;
                let decided: Vec<(String, Option<(usize, usize)>)> = mode
                    .decided
                    .iter()
                    .zip(&mode.decided_at)
                    .map(|(i, at)| (names[*i].clone(), *at))
                    .collect();
                invsim_inversion::check_decided(&mode.name, &decided, &d)
                    .map_err(invsim_inversion::Error::from)?;
                Ok(DerivedMode {
                    name: mode.name,
                    role: mode.role,
                    free: mode.free,
                    fixed: mode.fixed,
                    coupled: mode.coupled,
                    decided: mode.decided,
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
        let mut s = invsim_inversion::render::modal_title(&self.name, self.modes.len());
        for mode in &self.modes {
            let fixed: Vec<String> = mode
                .fixed
                .iter()
                .map(|(i, e)| format!("{} = {e}", self.inputs[*i]))
                .chain(mode.coupled.iter().map(|(s, e)| {
                    invsim_inversion::render::coupling_text(&mode.d.model.states[*s].name, e)
                }))
                .chain(
                    mode.decided
                        .iter()
                        .map(|i| format!("{} decided by the strategy", self.inputs[*i])),
                )
                .collect();
            s.push_str(&invsim_inversion::render::mode_heading(
                &mode.name,
                mode.role.as_str(),
                &self.inputs[mode.free],
                &fixed,
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

/// Formatted Rust source of a model with modes from its modes' derivations. A mode whose equations are
/// those of an earlier mode (the gears of one `[modes.NAME]` table differ in parameter values only) is not
/// generated again: its module re-exports the earlier mode's `Model` and `Params` and gives its own
/// parameter values (`params()`, `model()`).
pub fn generate_modal(m: &ModalDerivation, source_name: &str) -> Result<String, CodegenError> {
    let (name, sha256) = (m.name.as_str(), m.source_hash.as_str());
    let mut items = Vec::new();
    let mut comments = Vec::new();
    // (mode index, canonical tokens) of every mode generated in full.
    let mut primaries: Vec<(usize, String)> = Vec::new();
    let mut ctors = Vec::new();
    for (i, mode) in m.modes.iter().enumerate() {
        let ident = format_ident!("{}", mode_module(&mode.name));
        if let Some(j) = shares_code_with(m, i, &primaries, source_name)? {
            let code = format_ident!("{}", mode_module(&m.modes[j].name));
            items.push(sharer(&mode.name, &ident, &code, &mode.d));
            ctors.push(quote!(Box::new(#ident::model())));
            continue;
        }
        let out =
            crate::model::module_named(&mode.d, source_name, (&mode_module(&mode.name), false))?;
        primaries.push((i, canonical(&mode.d, source_name)?));
        items.push(out.tokens);
        comments.extend(out.comments);
        ctors.push(quote!(Box::new(#ident::Model::default())));
    }
    let mode_names: Vec<&str> = m.modes.iter().map(|x| x.name.as_str()).collect();
    let doc = format!(
        " Generated code of the model `{name}` with {} operating modes, from {source_name}: one module per \
         mode (an `InverseModel` with that mode's free input; modes with the same equations share one), \
         `MODES` and `models()` in the file's order.",
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

/// The module of mode `d` under a fixed name, as text: two modes with equal text have the same code.
fn canonical(d: &Derivation, source_name: &str) -> Result<String, CodegenError> {
    Ok(crate::model::module_named(d, source_name, ("mode", false))?
        .tokens
        .to_string())
}

/// The earlier mode generated in full whose code mode `i` has: the same parameters (names, in order) and,
/// given that mode's parameter values, the same generated module.
fn shares_code_with(
    m: &ModalDerivation,
    i: usize,
    primaries: &[(usize, String)],
    source_name: &str,
) -> Result<Option<usize>, CodegenError> {
    let d = &m.modes[i].d;
    let names = |d: &Derivation| -> Vec<String> {
        d.model.parameters.iter().map(|p| p.name.clone()).collect()
    };
    for (j, text) in primaries {
        let p = &m.modes[*j].d;
        if names(p) != names(d) {
            continue;
        }
        let mut with_values = d.clone();
        for (a, b) in with_values
            .model
            .parameters
            .iter_mut()
            .zip(&p.model.parameters)
        {
            a.value = b.value;
        }
        if canonical(&with_values, source_name)? == *text {
            return Ok(Some(*j));
        }
    }
    Ok(None)
}

/// The module of a mode that runs the code of the mode module `code` with its own parameter values.
fn sharer(
    mode: &str,
    ident: &proc_macro2::Ident,
    code: &proc_macro2::Ident,
    d: &Derivation,
) -> proc_macro2::TokenStream {
    let doc = format!(
        " Mode `{mode}`: the equations of the mode module `{code}` beside this one (generated once), with \
         this mode's parameter values."
    );
    let values = crate::model::params_literal(d);
    // The parent module, as a token (the path is the generated file's, not this crate's).
    let parent = format_ident!("super");
    quote! {
        #[doc = #doc]
        #[allow(clippy::approx_constant)]
        pub mod #ident {
            pub use #parent::#code::{Model, Params};

            /// This mode's parameter values (the model file's, with the mode's and the gearbox's).
            pub fn params() -> Params {
                #values
            }

            /// This mode's model at its parameter values.
            pub fn model() -> Model {
                Model::new(params())
            }
        }
    }
}
