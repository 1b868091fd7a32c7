//! What the generated module needs to pass `#![deny(clippy::all)]` and to read well: its `#[allow]`
//! attributes with the comments that explain them, and the `PI` import when the code uses it.

use super::context::Gen;
use crate::emit;
use proc_macro2::TokenStream;
use quote::quote;

/// The module's attributes and the comments to place above them, for a module whose items are `body`.
pub(super) fn attributes(g: &Gen<'_>, body: &TokenStream) -> (TokenStream, Vec<(String, String)>) {
    let mut comments: Vec<(String, String)> = Vec::new();
    let mut attrs = TokenStream::new();
    comments.push((
        "#[allow(clippy::manual_clamp)]".to_string(),
        "min(max(x, a), b) as the model language defines it: NaN gives a bound, where `clamp` would give NaN."
            .to_string(),
    ));
    if g.non_snake {
        attrs.extend(quote!(#[allow(non_snake_case)]));
        comments.push((
            "#[allow(non_snake_case)]".to_string(),
            "Parameter and state names are the model file's own (`C_d`, `T_i`), kept as written."
                .to_string(),
        ));
    }
    if resembles_std_constant(body.clone()) {
        attrs.extend(quote!(#[allow(clippy::approx_constant)]));
        comments.push((
            "#[allow(clippy::approx_constant)]".to_string(),
            "Numbers from the model file that resemble `std::f64::consts` values are its data, not approximations."
                .to_string(),
        ));
    }
    (attrs, comments)
}

/// `body`, with `use std::f64::consts::PI;` in front when it uses `PI`.
pub(super) fn with_pi_import(body: TokenStream) -> TokenStream {
    if uses_pi(body.clone(), None) {
        quote!(use std::f64::consts::PI; #body)
    } else {
        body
    }
}

/// Does any float literal in `tokens` look like a `std::f64::consts` value to clippy's `approx_constant`?
fn resembles_std_constant(tokens: TokenStream) -> bool {
    tokens.into_iter().any(|t| match t {
        proc_macro2::TokenTree::Group(g) => resembles_std_constant(g.stream()),
        proc_macro2::TokenTree::Literal(l) => {
            let text = l.to_string();
            let digits = text.trim_end_matches("_f64");
            !text.starts_with('"')
                && digits.contains(['.', 'e'])
                && emit::looks_like_std_constant(digits)
        }
        _ => false,
    })
}

/// Does the code use `PI` as a name of its own (not as a field `p.PI` or a path segment)?
fn uses_pi(tokens: TokenStream, mut prev: Option<char>) -> bool {
    for t in tokens {
        match t {
            proc_macro2::TokenTree::Group(g) => {
                if uses_pi(g.stream(), None) {
                    return true;
                }
                prev = None;
            }
            proc_macro2::TokenTree::Ident(i) => {
                if i == "PI" && !matches!(prev, Some('.' | ':')) {
                    return true;
                }
                prev = None;
            }
            proc_macro2::TokenTree::Punct(p) => prev = Some(p.as_char()),
            proc_macro2::TokenTree::Literal(_) => prev = None,
        }
    }
    false
}
