//! Rust identifiers for the names of a model: module, parameter fields and local variables.
//!
//! Model names follow the contract's identifier rule `[A-Za-z_][A-Za-z0-9_]*` and are kept as written
//! wherever Rust allows it, so the generated code reads like the model file (`p.C_d`, `let [v, p_i] = *x;`).
//! A name that would clash with Rust — a keyword, a name the generated module itself defines (`N`, `Params`,
//! `alpha`, …), a prelude variant such as `None` (which a `let` pattern would match instead of binding), or a
//! temporary `t3` — gets a trailing underscore until it is unique.

use proc_macro2::{Ident, Span};
use std::collections::HashSet;

/// Strict and reserved keywords of every Rust edition up to 2024.
const KEYWORDS: &[&str] = &[
    "as", "async", "await", "break", "const", "continue", "crate", "dyn", "else", "enum", "extern",
    "false", "fn", "for", "gen", "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut",
    "pub", "ref", "return", "self", "Self", "static", "struct", "super", "trait", "true", "type",
    "unsafe", "use", "where", "while", "abstract", "become", "box", "do", "final", "macro",
    "override", "priv", "typeof", "unsized", "virtual", "yield", "try", "union", "_",
];

/// Keywords that cannot be raw identifiers.
const NOT_RAW: &[&str] = &["crate", "self", "Self", "super", "_"];

/// Names the generated module defines or uses as locals; a model local may not shadow them.
pub(crate) const RESERVED_LOCALS: &[&str] = &[
    // module items
    "NAME",
    "SOURCE_FILE",
    "SOURCE_HASH",
    "DESCRIPTION",
    "N",
    "R",
    "N_ETA",
    "N_PARAMS",
    "N_OUTPUTS",
    "NW",
    "SIGNALS",
    "STATES",
    "INPUT",
    "OUTPUT",
    "PARAMETERS",
    "OUTPUTS",
    "REFERENCE",
    "ReferenceMap",
    "NEWTON_MAX_ITER",
    "NEWTON_TOL",
    "Params",
    "Precomputed",
    "Model",
    "model_info",
    "h",
    "psi",
    "psi_inv",
    "psi_jacobian",
    "alpha",
    "beta",
    "alpha_x",
    "beta_x",
    "invert",
    "zero_dynamics",
    "zero_dynamics_x",
    "rhs",
    "outputs",
    "lu_solve",
    "sign",
    "arr",
    // imports and the prelude's patterns
    "InverseModel",
    "ModelError",
    "ModelInfo",
    "OutputInfo",
    "None",
    "Some",
    "Ok",
    "Err",
    "Option",
    "Result",
    "String",
    "Vec",
    "Box",
    "std",
    "core",
    "f64",
    "serde",
    "PI",
    // argument and local names of generated functions
    "p",
    "x",
    "xi",
    "eta",
    "yr",
    "alpha",
    "beta",
    "guess",
    "target",
    "value",
    "jacobian",
    "step",
    "residual",
    // names clippy's `disallowed_names` rejects by default
    "foo",
    "baz",
    "quux",
    // The batch methods' own names.
    "invert_batch",
    "outputs_batch",
    "BLOCK",
    "cols",
    "cols_mut",
    "pow_pos_slice",
    "start",
    "end",
    "len",
    "k",
    "c",
    "base",
    "power",
    "kept",
    "states",
    "input",
    "values",
    "column",
    "buffer",
];

pub(crate) fn is_keyword(s: &str) -> bool {
    KEYWORDS.contains(&s)
}

/// `t0`, `t17`, … (temporaries) and `k0`, … (precomputed constants).
fn is_temporary(s: &str) -> bool {
    let mut chars = s.chars();
    matches!(chars.next(), Some('t' | 'k')) && s.len() > 1 && chars.all(|c| c.is_ascii_digit())
}

/// Does `s` follow Rust's snake-case convention (what `non_snake_case` checks)?
pub(crate) fn is_snake_case(s: &str) -> bool {
    let s = s.trim_start_matches("r#").trim_matches('_');
    !s.chars().any(|c| c.is_ascii_uppercase()) && !s.contains("__")
}

/// The module (and file) name for a model name: lower-case, non-identifier characters as `_`, never a
/// keyword or empty.
pub fn module_name(model_name: &str) -> String {
    let mut s: String = model_name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        s.insert_str(0, "model_");
    }
    while is_keyword(&s) || s.chars().all(|c| c == '_') {
        s.push_str("_model");
    }
    s
}

/// The Rust spelling of a parameter field: the name itself, a raw identifier for a keyword, or the name
/// with a trailing underscore (renamed back for serde) when even that is impossible.
pub(crate) struct FieldName {
    pub ident: Ident,
    /// `Some(name)` when the field needs `#[serde(rename = "name")]`.
    pub serde_rename: Option<String>,
}

pub(crate) fn field_name(name: &str, taken: &HashSet<String>) -> FieldName {
    if NOT_RAW.contains(&name) {
        let mut s = format!("{name}_");
        while taken.contains(&s) {
            s.push('_');
        }
        return FieldName {
            ident: Ident::new(&s, Span::call_site()),
            serde_rename: Some(name.to_string()),
        };
    }
    if is_keyword(name) {
        return FieldName {
            ident: Ident::new_raw(name, Span::call_site()),
            serde_rename: None,
        };
    }
    FieldName {
        ident: Ident::new(name, Span::call_site()),
        serde_rename: None,
    }
}

/// Local-variable names for model symbols, unique among themselves and clear of everything the generated
/// code defines.
pub(crate) struct Locals {
    used: HashSet<String>,
}

impl Locals {
    /// `all_model_names`: every name the model declares (so that a renamed `p_` cannot hit a real `p_`).
    pub fn new(all_model_names: &[&str]) -> Locals {
        Locals {
            used: all_model_names.iter().map(|s| s.to_string()).collect(),
        }
    }

    /// The local identifier for model name `name`.
    pub fn local(&mut self, name: &str) -> String {
        let clashes = |s: &str| is_keyword(s) || RESERVED_LOCALS.contains(&s) || is_temporary(s);
        if !clashes(name) {
            return name.to_string();
        }
        let mut s = format!("{name}_");
        while clashes(&s) || self.used.contains(&s) {
            s.push('_');
        }
        self.used.insert(s.clone());
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn module_names() {
        assert_eq!(module_name("si_engine"), "si_engine");
        assert_eq!(module_name("My-Model 2"), "my_model_2");
        assert_eq!(module_name("2stroke"), "model_2stroke");
        assert_eq!(module_name("type"), "type_model");
    }

    #[test]
    fn locals_avoid_clashes() {
        let mut l = Locals::new(&["p", "p_", "v", "t1", "None"]);
        assert_eq!(l.local("v"), "v");
        assert_eq!(l.local("p"), "p__");
        assert_eq!(l.local("t1"), "t1_");
        assert_eq!(l.local("None"), "None_");
        assert_eq!(l.local("type"), "type_");
        assert_eq!(l.local("xi_aux"), "xi_aux");
    }

    #[test]
    fn fields() {
        let taken = HashSet::new();
        assert_eq!(field_name("type", &taken).ident.to_string(), "r#type");
        let f = field_name("self", &taken);
        assert_eq!(f.ident.to_string(), "self_");
        assert_eq!(f.serde_rename.as_deref(), Some("self"));
        assert!(is_snake_case("p_i") && !is_snake_case("C_d") && is_snake_case("r#type"));
    }
}
