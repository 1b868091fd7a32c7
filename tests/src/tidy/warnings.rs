//! Where library code makes a warning, for the check that the guide's glossary explains every warning
//! (`tests/tests/tidy.rs`). A warning site is a push onto a vector named `…warnings` (`warnings.push(`,
//! `start_warnings.push(`), a function named `…warning` that returns one (`grade_warning`), or a variant
//! (`#[error(`) of a warning type in one of [`WARNING_TYPE_FILES`]; test code and code templates are not
//! searched.

use super::items::{exempt_regions, in_regions};
use super::lex::{tokenize, Kind, Token};
use super::SourceFile;

/// Files of warning types: each `#[error(` in them is a warning's text (`cycle::Implausible`).
pub const WARNING_TYPE_FILES: &[&str] = &["crates/runtime/src/cycle/plausibility.rs"];

/// One place that makes a warning: the file and the 1-based line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WarningSite {
    pub path: String,
    pub line: usize,
}

/// Every warning site of the library sources (`crates/*/src`) among `files`.
pub fn warning_sites(files: &[SourceFile]) -> Vec<WarningSite> {
    let mut out = Vec::new();
    for f in files.iter().filter(|f| f.path.starts_with("crates/")) {
        let tokens = tokenize(&f.text);
        let exempt = exempt_regions(&tokens);
        let typed = WARNING_TYPE_FILES.contains(&f.path.as_str());
        for (i, t) in tokens.iter().enumerate() {
            let site = is_push(&tokens, i)
                || is_warning_fn(&tokens, i)
                || (typed && is_error_attr(&tokens, i));
            if site && !in_regions(&exempt, t.line) {
                out.push(WarningSite {
                    path: f.path.clone(),
                    line: t.line,
                });
            }
        }
    }
    out
}

/// `…warnings.push(` starting at token `i`.
fn is_push(tokens: &[Token], i: usize) -> bool {
    let ident = &tokens[i];
    ident.kind == Kind::Ident
        && ident.text.ends_with("warnings")
        && tokens.get(i + 1).is_some_and(|t| t.is("."))
        && tokens.get(i + 2).is_some_and(|t| t.is("push"))
        && tokens.get(i + 3).is_some_and(|t| t.is("("))
}

/// `fn …warning` at token `i`.
fn is_warning_fn(tokens: &[Token], i: usize) -> bool {
    tokens[i].is("fn")
        && tokens
            .get(i + 1)
            .is_some_and(|t| t.kind == Kind::Ident && t.text.ends_with("warning"))
}

/// `#[error(` at token `i`.
fn is_error_attr(tokens: &[Token], i: usize) -> bool {
    tokens[i].is("#")
        && tokens.get(i + 1).is_some_and(|t| t.is("["))
        && tokens.get(i + 2).is_some_and(|t| t.is("error"))
        && tokens.get(i + 3).is_some_and(|t| t.is("("))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pushes, warning functions and typed warnings count; other pushes, strings and test code do not.
    #[test]
    fn finds_each_kind_of_site() {
        let text = "//! x\nfn a(w: &mut Vec<String>) { warnings.push(x); start_warnings.push(y); v.push(z); }\n\
                    fn grade_warning() {}\nfn run_warnings() { let s = \"warnings.push(\"; }\n\
                    #[error(\"t\")]\nX,\n#[cfg(test)]\nmod tests { fn t() { warnings.push(1); } }\n";
        let plain = SourceFile {
            path: "crates/a/src/lib.rs".into(),
            text: text.into(),
        };
        let lines: Vec<usize> = warning_sites(std::slice::from_ref(&plain))
            .iter()
            .map(|s| s.line)
            .collect();
        assert_eq!(lines, [2, 2, 3]);
        let typed = SourceFile {
            path: WARNING_TYPE_FILES[0].into(),
            text: text.into(),
        };
        assert_eq!(warning_sites(&[typed]).len(), 4);
    }
}
