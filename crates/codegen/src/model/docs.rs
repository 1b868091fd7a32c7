//! Documentation of the generated module: doc attributes, equation blocks (plain text in the contract's
//! language and LaTeX), the left-hand sides of the model's equations, and the module's own doc comment.

use super::context::Gen;
use invsim_expr::{latex_symbol, Id};
use proc_macro2::TokenStream;
use quote::quote;

/// `#[doc = …]` attributes, one per line.
pub(super) fn doc_attrs(lines: &[String]) -> TokenStream {
    let attrs = lines.iter().map(|l| {
        let l = if l.is_empty() {
            String::new()
        } else {
            format!(" {l}")
        };
        quote!(#[doc = #l])
    });
    quote!(#(#attrs)*)
}

/// A LaTeX equation block: one line, or an `aligned` environment.
fn math_block(rows: &[(String, String)]) -> Vec<String> {
    let mut doc = vec!["```math".to_string()];
    if rows.len() == 1 {
        doc.push(format!("{} = {}", rows[0].0, rows[0].1));
    } else {
        doc.push("\\begin{aligned}".into());
        for (i, (tex, rhs)) in rows.iter().enumerate() {
            let end = if i + 1 < rows.len() { " \\\\" } else { "" };
            doc.push(format!("{tex} &= {rhs}{end}"));
        }
        doc.push("\\end{aligned}".into());
    }
    doc.push("```".into());
    doc
}

/// Doc lines for the equations `lhs_i = es_i`: a plain-text block in the contract's language, then the same
/// in LaTeX. Each left-hand side is (plain, LaTeX).
pub(super) fn equations(g: &Gen<'_>, lhs: &[(String, String)], es: &[Id]) -> Vec<String> {
    let mut doc = vec!["```text".to_string()];
    for ((plain, _), &e) in lhs.iter().zip(es) {
        doc.push(format!("{plain} = {}", g.pool.display(e)));
    }
    doc.push("```".into());
    doc.push(String::new());
    let tex: Vec<(String, String)> = lhs
        .iter()
        .zip(es)
        .map(|((_, t), &e)| (t.clone(), g.pool.latex(e)))
        .collect();
    doc.extend(math_block(&tex));
    doc
}

/// The left-hand sides of the model's equations, (plain, LaTeX) each.
pub(super) struct Lhs {
    pub(super) xi: Vec<(String, String)>,
    pub(super) eta: Vec<(String, String)>,
    pub(super) states: Vec<(String, String)>,
    pub(super) dot: Vec<(String, String)>,
    pub(super) deta: Vec<(String, String)>,
    pub(super) outputs: Vec<(String, String)>,
}

impl Lhs {
    pub(super) fn new(g: &Gen<'_>) -> Lhs {
        let m = &g.d.model;
        let ne = g.d.eta.len();
        let named = |name: &str| (name.to_string(), latex_symbol(name));
        Lhs {
            xi: (1..=g.d.relative_degree)
                .map(|k| (format!("xi{k}"), format!("\\xi_{{{k}}}")))
                .collect(),
            eta: (1..=ne)
                .map(|k| (format!("eta{k}"), format!("\\eta_{{{k}}}")))
                .collect(),
            states: m.states.iter().map(|s| named(&s.name)).collect(),
            dot: m
                .states
                .iter()
                .map(|s| {
                    (
                        format!("d({})/dt", s.name),
                        format!("\\dot{{{}}}", latex_symbol(&s.name)),
                    )
                })
                .collect(),
            deta: (1..=ne)
                .map(|k| (format!("d(eta{k})/dt"), format!("\\dot\\eta_{{{k}}}")))
                .collect(),
            outputs: m.outputs.iter().map(|o| named(&o.name)).collect(),
        }
    }

    /// ψ's components: ξ then η.
    pub(super) fn psi(&self) -> Vec<(String, String)> {
        self.xi.iter().chain(&self.eta).cloned().collect()
    }
}

/// Brackets in doc text would read as intra-doc links.
pub(super) fn escape_doc(s: &str) -> String {
    s.replace('[', "\\[").replace(']', "\\]")
}

/// A parameter value for reading: `1300`, `0.32`, `4.4e7`.
pub(super) fn number_text(x: f64) -> String {
    let plain = format!("{x}");
    if plain.len() <= 12 {
        plain
    } else {
        format!("{x:e}")
    }
}

/// The module's doc comment.
pub(super) fn module_doc(g: &Gen<'_>, source_name: &str) -> TokenStream {
    let m = &g.d.model;
    let (n, r, ne) = (g.d.n(), g.d.relative_degree, g.d.eta.len());
    let name = &m.name;
    let description = m.description.clone().unwrap_or_default();
    let states_list = m
        .states
        .iter()
        .map(|s| s.name.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    let psi_inv_note = if g.closed {
        "ψ⁻¹ is in closed form."
    } else {
        "ψ⁻¹ is solved by Newton's method on the analytic Jacobian (no closed form was found)."
    };
    let mut doc = vec![format!("Compiled `{name}` model.")];
    if !description.is_empty() {
        doc.push(String::new());
        doc.push(escape_doc(&description));
    }
    doc.push(String::new());
    doc.push(format!(
        "States x = ({states_list}), input u = `{}`, output y = `{}`: n = {n}, relative \
         degree r = {r}, {ne} internal state(s) η. {psi_inv_note}",
        m.input.name, m.output.name
    ));
    doc.push(String::new());
    // Links in a module's outer docs resolve from the enclosing module, hence the module-qualified paths.
    let md = crate::names::module_name(&m.name);
    doc.push(format!(
        "[`Model`]({md}::Model) implements the runtime's [`InverseModel`](invsim_model_api::InverseModel). \
         [`Precomputed`]({md}::Precomputed) holds a parameter set with its parameter-only subexpressions and \
         evaluates every function per point; the free functions take [`Params`]({md}::Params) directly. Each \
         method's documentation shows its equation."
    ));
    doc.push(String::new());
    doc.push(format!(
        "Generated from `{source_name}` (sha256 `{}`).",
        m.source_hash
    ));
    doc_attrs(&doc)
}
