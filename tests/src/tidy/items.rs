//! Items found in a token stream: function bodies with their line spans, and the regions that are test code
//! (`#[cfg(test)]` and `#[test]` items).

use super::lex::{Kind, Token};

/// A function with a body: its name and the lines of its `fn` keyword and closing brace.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Function {
    pub name: String,
    pub first_line: usize,
    pub last_line: usize,
}

impl Function {
    /// Lines from the `fn` line to the closing brace, both included.
    pub fn lines(&self) -> usize {
        self.last_line + 1 - self.first_line
    }
}

/// The index of the token that closes the bracket opened at `open` (or the last token if it is never closed).
pub fn matching(tokens: &[Token], open: usize) -> usize {
    let mut depth = 0usize;
    for (i, t) in tokens.iter().enumerate().skip(open) {
        if t.kind != Kind::Punct {
            continue;
        }
        match t.text.as_str() {
            "{" | "(" | "[" => depth += 1,
            "}" | ")" | "]" => {
                depth = depth.saturating_sub(1);
                if depth == 0 {
                    return i;
                }
            }
            _ => {}
        }
    }
    tokens.len().saturating_sub(1)
}

/// The end of the item starting at `start`: the brace closing its first body `{` outside parentheses and
/// brackets, or its `;`. `None` when the item has no body (`fn f();`) — then the `;`'s index is the end.
fn item_end(tokens: &[Token], start: usize) -> (usize, bool) {
    let mut i = start;
    while i < tokens.len() {
        let t = &tokens[i];
        if t.is("(") || t.is("[") {
            i = matching(tokens, i) + 1;
            continue;
        }
        if t.is("{") {
            return (matching(tokens, i), true);
        }
        if t.is(";") {
            return (i, false);
        }
        i += 1;
    }
    (tokens.len().saturating_sub(1), false)
}

/// Every `fn name … { … }` (free functions, methods, nested functions), in source order.
pub fn functions(tokens: &[Token]) -> Vec<Function> {
    let mut out = Vec::new();
    for (i, t) in tokens.iter().enumerate() {
        if !t.is("fn") {
            continue;
        }
        let Some(name) = tokens.get(i + 1).filter(|n| n.kind == Kind::Ident) else {
            continue; // `fn(f64) -> f64`, a function-pointer type
        };
        let (end, has_body) = item_end(tokens, i + 2);
        if has_body {
            out.push(Function {
                name: name.text.clone(),
                first_line: t.line,
                last_line: tokens[end].line,
            });
        }
    }
    out
}

/// Whether the attribute whose `#` is at `i` marks test code: `#[test]`, `#[cfg(test)]`, `#[cfg(all(test, …))]`.
fn is_test_attribute(tokens: &[Token], i: usize) -> bool {
    let words: Vec<&str> = tokens[i..]
        .iter()
        .take(6)
        .map(|t| t.text.as_str())
        .collect();
    matches!(
        words.as_slice(),
        ["#", "[", "test", "]", ..] | ["#", "[", "cfg", "(", "test", ")"]
    ) || matches!(words.as_slice(), ["#", "[", "cfg", "(", "all", "("] if tokens.get(i + 6).is_some_and(|t| t.is("test")))
}

/// Line ranges (inclusive) of test items: from a test attribute to the end of the item it is attached to.
pub fn test_regions(tokens: &[Token]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < tokens.len() {
        if tokens[i].is("#") && is_test_attribute(tokens, i) {
            let attr_end = matching(tokens, i + 1);
            let (end, _) = item_end(tokens, skip_attributes(tokens, attr_end + 1));
            out.push((tokens[i].line, tokens[end].line));
            i = end + 1;
        } else {
            i += 1;
        }
    }
    out
}

/// Line ranges (inclusive) of code templates, `quote! { … }` and `quote_spanned! { … }` bodies: generated code,
/// not the generator's own.
pub fn template_regions(tokens: &[Token]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for i in 0..tokens.len().saturating_sub(2) {
        let is_quote = tokens[i].is("quote") || tokens[i].is("quote_spanned");
        if is_quote && tokens[i + 1].is("!") && tokens[i + 2].kind == Kind::Punct {
            out.push((tokens[i].line, tokens[matching(tokens, i + 2)].line));
        }
    }
    out
}

/// Test regions and code templates: the lines the habits do not apply to.
pub fn exempt_regions(tokens: &[Token]) -> Vec<(usize, usize)> {
    let mut out = test_regions(tokens);
    out.extend(template_regions(tokens));
    out
}

/// The index of the first token after the attributes that start at `i`.
fn skip_attributes(tokens: &[Token], mut i: usize) -> usize {
    while tokens.get(i).is_some_and(|t| t.is("#")) && tokens.get(i + 1).is_some_and(|t| t.is("[")) {
        i = matching(tokens, i + 1) + 1;
    }
    i
}

/// Whether `line` lies in one of `regions`.
pub fn in_regions(regions: &[(usize, usize)], line: usize) -> bool {
    regions.iter().any(|&(a, b)| a <= line && line <= b)
}

#[cfg(test)]
mod tests {
    use super::super::lex::tokenize;
    use super::*;

    #[test]
    fn functions_span_from_fn_to_closing_brace() {
        let src = "fn a() {\n  let s = \"}\";\n}\ntrait T { fn b(&self); }\nfn c<F: Fn(u8) -> u8>(f: F) -> [u8; 2]\nwhere F: Copy\n{\n  fn d() {}\n}\n";
        let f = functions(&tokenize(src));
        let spans: Vec<(&str, usize, usize)> = f
            .iter()
            .map(|f| (f.name.as_str(), f.first_line, f.last_line))
            .collect();
        assert_eq!(spans, [("a", 1, 3), ("c", 5, 9), ("d", 8, 8)]);
    }

    #[test]
    fn test_modules_and_test_functions_are_regions() {
        let src = "fn a() {}\n#[cfg(test)]\nmod tests {\n  #[test]\n  fn t() {}\n}\n#[test]\n#[ignore]\nfn u() {\n}\n";
        assert_eq!(test_regions(&tokenize(src)), [(2, 6), (7, 10)]);
    }

    #[test]
    fn code_templates_are_exempt() {
        let src = "fn gen() {\n  quote! {\n    fn f() { x.unwrap() }\n  }\n}\n";
        assert_eq!(exempt_regions(&tokenize(src)), [(2, 4)]);
    }
}
