//! Parser for the contract's expression language (section 1), with byte spans for every node and error.
//!
//! Grammar (precedence climbing; `^` is right-associative and binds tighter than unary minus, so
//! `-x^2 = -(x^2)` and `2^3^2 = 2^9`):
//!
//! ```text
//! expr    := term (("+" | "-") term)*
//! term    := unary (("*" | "/") unary)*
//! unary   := ("-" | "+") unary | power
//! power   := atom ("^" unary)?
//! atom    := NUMBER | IDENT | IDENT "(" expr ("," expr)* ")" | "(" expr ")"
//! ```
//!
//! Parsing produces an [`Ast`] (so callers can check names with their spans), which
//! [`Pool::from_ast`] interns into canonical form.

use crate::func::{Func, Func2, FUNCTIONS};
use crate::number::Number;
use crate::pool::{Id, Pool};
use std::ops::Range;
use thiserror::Error;

/// A parse error: what was expected and where (byte range in the parsed text). `opened` is the span of an
/// unclosed `(` when the error is a missing `)`, so a caller can point at both places.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{message}")]
pub struct ParseError {
    pub span: Range<usize>,
    pub message: String,
    pub opened: Option<Range<usize>>,
}

/// Binary operators.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
}

/// Syntax tree node with its byte span in the source.
#[derive(Debug, Clone, PartialEq)]
pub struct Ast {
    pub kind: AstKind,
    pub span: Range<usize>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum AstKind {
    Num(Number),
    /// A name: a parameter, state, input, definition or `pi`.
    Ident(String),
    Neg(Box<Ast>),
    Binary(BinOp, Box<Ast>, Box<Ast>),
    /// A function call; the name is one of the language's functions (checked by the parser).
    Call(String, Vec<Ast>),
}

impl Ast {
    /// Every identifier (not function names) with its span, in source order.
    pub fn identifiers(&self) -> Vec<(&str, Range<usize>)> {
        let mut out = Vec::new();
        self.walk(&mut |a| {
            if let AstKind::Ident(name) = &a.kind {
                out.push((name.as_str(), a.span.clone()));
            }
        });
        out
    }

    /// Every function call name with the span of the call, in source order.
    pub fn calls(&self) -> Vec<(&str, Range<usize>)> {
        let mut out = Vec::new();
        self.walk(&mut |a| {
            if let AstKind::Call(name, _) = &a.kind {
                out.push((name.as_str(), a.span.start..a.span.start + name.len()));
            }
        });
        out
    }

    fn walk<'a>(&'a self, visit: &mut impl FnMut(&'a Ast)) {
        visit(self);
        match &self.kind {
            AstKind::Num(_) | AstKind::Ident(_) => {}
            AstKind::Neg(a) => a.walk(visit),
            AstKind::Binary(_, a, b) => {
                a.walk(visit);
                b.walk(visit);
            }
            AstKind::Call(_, args) => args.iter().for_each(|a| a.walk(visit)),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(Number),
    Ident(String),
    Op(char),
    End,
}

/// Deepest nesting the parser descends into (parentheses, unary signs, powers, calls): deeper input is an
/// error rather than a stack overflow. Model files are limited further by the reader (64 levels).
pub const MAX_PARSE_DEPTH: usize = 500;

/// The arity of a declared lookup map by name (`None`: not a map); see [`parse_with_maps`].
pub type MapArity<'m> = &'m dyn Fn(&str) -> Option<usize>;

struct Parser<'s> {
    src: &'s str,
    maps: MapArity<'s>,
    pos: usize,
    tok: Tok,
    tok_span: Range<usize>,
    /// Current nesting, counted in [`Parser::unary`] (every nested sub-expression passes through it).
    depth: usize,
}

fn describe(t: &Tok) -> String {
    match t {
        Tok::Num(_) => "a number".into(),
        Tok::Ident(s) => format!("`{s}`"),
        Tok::Op(c) => format!("`{c}`"),
        Tok::End => "the end of the expression".into(),
    }
}

impl<'s> Parser<'s> {
    fn err<T>(&self, span: Range<usize>, message: impl Into<String>) -> Result<T, ParseError> {
        Err(ParseError {
            span,
            message: message.into(),
            opened: None,
        })
    }

    fn advance(&mut self) -> Result<(), ParseError> {
        let bytes = self.src.as_bytes();
        while self.pos < bytes.len() && (bytes[self.pos] as char).is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        if start >= bytes.len() {
            self.tok = Tok::End;
            self.tok_span = start..start;
            return Ok(());
        }
        let c = self.src[start..].chars().next().unwrap_or('\0');
        if c.is_ascii_digit()
            || (c == '.' && bytes.get(start + 1).is_some_and(|b| b.is_ascii_digit()))
        {
            let mut i = start;
            while i < bytes.len() && bytes[i].is_ascii_digit() {
                i += 1;
            }
            if i < bytes.len() && bytes[i] == b'.' {
                i += 1;
                while i < bytes.len() && bytes[i].is_ascii_digit() {
                    i += 1;
                }
            }
            if i < bytes.len() && (bytes[i] == b'e' || bytes[i] == b'E') {
                let mut j = i + 1;
                if j < bytes.len() && (bytes[j] == b'+' || bytes[j] == b'-') {
                    j += 1;
                }
                if j < bytes.len() && bytes[j].is_ascii_digit() {
                    while j < bytes.len() && bytes[j].is_ascii_digit() {
                        j += 1;
                    }
                    i = j;
                } else {
                    return self.err(
                        start..j,
                        "malformed number: expected digits after the exponent `e`",
                    );
                }
            }
            if i < bytes.len()
                && (bytes[i].is_ascii_alphabetic() || bytes[i] == b'_' || bytes[i] == b'.')
            {
                return self.err(
                    start..i + 1,
                    "malformed number: expected an operator after it",
                );
            }
            let text = &self.src[start..i];
            let n = Number::parse_decimal(text).ok_or_else(|| ParseError {
                span: start..i,
                message: format!("malformed number `{text}`"),
                opened: None,
            })?;
            self.tok = Tok::Num(n);
            self.tok_span = start..i;
            self.pos = i;
            return Ok(());
        }
        if c.is_ascii_alphabetic() || c == '_' {
            let mut i = start;
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            self.tok = Tok::Ident(self.src[start..i].to_string());
            self.tok_span = start..i;
            self.pos = i;
            return Ok(());
        }
        if "+-*/^(),".contains(c) {
            self.tok = Tok::Op(c);
            self.tok_span = start..start + 1;
            self.pos = start + 1;
            return Ok(());
        }
        let end = start + c.len_utf8();
        if c == '*' || c == '%' || c == '=' || c == '[' || c == '{' {
            return self.err(start..end, format!("unexpected character `{c}`"));
        }
        self.err(
            start..end,
            format!("unexpected character `{c}`; expected a number, a name, an operator (+ - * / ^) or parentheses"),
        )
    }

    fn expect_op(&mut self, op: char, context: &str) -> Result<(), ParseError> {
        if self.tok == Tok::Op(op) {
            self.advance()
        } else {
            self.err(
                self.tok_span.clone(),
                format!("expected `{op}` {context}, found {}", describe(&self.tok)),
            )
        }
    }

    fn expr(&mut self) -> Result<Ast, ParseError> {
        let mut lhs = self.term()?;
        while let Tok::Op(c @ ('+' | '-')) = self.tok {
            self.advance()?;
            let rhs = self.term()?;
            let op = if c == '+' { BinOp::Add } else { BinOp::Sub };
            let span = lhs.span.start..rhs.span.end;
            lhs = Ast {
                kind: AstKind::Binary(op, Box::new(lhs), Box::new(rhs)),
                span,
            };
        }
        Ok(lhs)
    }

    fn term(&mut self) -> Result<Ast, ParseError> {
        let mut lhs = self.unary()?;
        while let Tok::Op(c @ ('*' | '/')) = self.tok {
            self.advance()?;
            if self.tok == Tok::Op('*') {
                return self.err(
                    self.tok_span.clone(),
                    "`**` is not an operator here: write powers as `a^b`",
                );
            }
            let rhs = self.unary()?;
            let op = if c == '*' { BinOp::Mul } else { BinOp::Div };
            let span = lhs.span.start..rhs.span.end;
            lhs = Ast {
                kind: AstKind::Binary(op, Box::new(lhs), Box::new(rhs)),
                span,
            };
        }
        Ok(lhs)
    }

    fn unary(&mut self) -> Result<Ast, ParseError> {
        if self.depth >= MAX_PARSE_DEPTH {
            return self.err(
                self.tok_span.clone(),
                format!("expression nested more than {MAX_PARSE_DEPTH} levels deep"),
            );
        }
        self.depth += 1;
        let ast = self.unary_inner();
        self.depth -= 1;
        ast
    }

    fn unary_inner(&mut self) -> Result<Ast, ParseError> {
        if let Tok::Op(c @ ('-' | '+')) = self.tok {
            let start = self.tok_span.start;
            self.advance()?;
            let inner = self.unary()?;
            let span = start..inner.span.end;
            return Ok(if c == '-' {
                Ast {
                    kind: AstKind::Neg(Box::new(inner)),
                    span,
                }
            } else {
                inner
            });
        }
        self.power()
    }

    fn power(&mut self) -> Result<Ast, ParseError> {
        let base = self.atom()?;
        if self.tok == Tok::Op('^') {
            self.advance()?;
            let exp = self.unary()?;
            let span = base.span.start..exp.span.end;
            return Ok(Ast {
                kind: AstKind::Binary(BinOp::Pow, Box::new(base), Box::new(exp)),
                span,
            });
        }
        Ok(base)
    }

    fn atom(&mut self) -> Result<Ast, ParseError> {
        let span = self.tok_span.clone();
        match self.tok.clone() {
            Tok::Num(n) => {
                self.advance()?;
                Ok(Ast {
                    kind: AstKind::Num(n),
                    span,
                })
            }
            Tok::Ident(name) => {
                self.advance()?;
                let map = crate::map::resolve_call_name(&name, self.maps);
                if self.tok != Tok::Op('(') {
                    if map.is_some() {
                        return self.err(
                            span,
                            format!(
                                "map `{name}` must be called with its arguments, e.g. `{name}(x)`"
                            ),
                        );
                    }
                    if FUNCTIONS.iter().any(|(f, _)| *f == name) {
                        return self.err(
                            span,
                            format!("function `{name}` must be called with parentheses"),
                        );
                    }
                    return Ok(Ast {
                        kind: AstKind::Ident(name),
                        span,
                    });
                }
                let builtin = FUNCTIONS.iter().find(|(f, _)| *f == name).map(|&(_, n)| n);
                let Some(arity) = builtin.or(map.map(|m| m.1)) else {
                    let known: Vec<&str> = FUNCTIONS.iter().map(|(f, _)| *f).collect();
                    return self.err(
                        span,
                        format!(
                            "unknown function `{name}`; expected one of {}",
                            known.join(", ")
                        ),
                    );
                };
                self.advance()?;
                let mut args = Vec::new();
                if self.tok != Tok::Op(')') {
                    args.push(self.expr()?);
                    while self.tok == Tok::Op(',') {
                        self.advance()?;
                        args.push(self.expr()?);
                    }
                }
                let close = self.tok_span.clone();
                self.expect_op(')', &format!("to close the call of `{name}`"))?;
                let full = span.start..close.end;
                if args.len() != arity {
                    return self.err(
                        full,
                        format!(
                            "`{name}` takes {arity} argument{}, found {}",
                            if arity == 1 { "" } else { "s" },
                            args.len()
                        ),
                    );
                }
                Ok(Ast {
                    kind: AstKind::Call(name, args),
                    span: full,
                })
            }
            Tok::Op('(') => {
                self.advance()?;
                if self.tok == Tok::Op(')') {
                    return self.err(
                        self.tok_span.clone(),
                        "empty parentheses: expected an expression",
                    );
                }
                let inner = self.expr()?;
                let close = self.tok_span.clone();
                if self.tok != Tok::Op(')') {
                    return Err(ParseError {
                        span: close,
                        message: format!(
                            "expected `)` to close the `(`, found {}",
                            describe(&self.tok)
                        ),
                        opened: Some(span.start..span.start + 1),
                    });
                }
                self.advance()?;
                Ok(Ast {
                    kind: inner.kind,
                    span: span.start..close.end,
                })
            }
            other => self.err(
                span,
                format!(
                    "expected a number, a name or `(`, found {}",
                    describe(&other)
                ),
            ),
        }
    }
}

/// Parse an expression of the contract's language into a syntax tree.
pub fn parse(src: &str) -> Result<Ast, ParseError> {
    parse_with_maps(src, &|_| None)
}

/// Parse with lookup maps declared (contract §6): a call of a map `M` or of a derivative map `M_dK`,
/// `M_dIJ` is a [`AstKind::Call`] of that name with the map's arity.
pub fn parse_with_maps(src: &str, maps: MapArity<'_>) -> Result<Ast, ParseError> {
    if src.trim().is_empty() {
        return Err(ParseError {
            span: 0..src.len(),
            message: "empty expression".into(),
            opened: None,
        });
    }
    let mut p = Parser {
        src,
        maps,
        pos: 0,
        tok: Tok::End,
        tok_span: 0..0,
        depth: 0,
    };
    p.advance()?;
    let ast = p.expr()?;
    if p.tok != Tok::End {
        let msg = match &p.tok {
            Tok::Op(')') => "unmatched `)`".to_string(),
            t => format!(
                "expected an operator or the end of the expression, found {}",
                describe(t)
            ),
        };
        return p.err(p.tok_span.clone(), msg);
    }
    Ok(ast)
}

impl Pool {
    /// Intern a syntax tree in canonical form. Identifiers become symbols, except `pi`.
    pub fn from_ast(&mut self, ast: &Ast) -> Id {
        let children: Vec<Id> = match &ast.kind {
            AstKind::Num(_) | AstKind::Ident(_) => Vec::new(),
            AstKind::Neg(a) => vec![self.from_ast(a)],
            AstKind::Binary(_, a, b) => vec![self.from_ast(a), self.from_ast(b)],
            AstKind::Call(_, args) => args.iter().map(|a| self.from_ast(a)).collect(),
        };
        self.from_ast_node(ast, &children)
    }

    /// Intern one node of a syntax tree whose operands are already interned as `children` (in order: the
    /// operand of a sign, the two of a binary operator, a call's arguments), as [`Pool::from_ast`] does.
    pub fn from_ast_node(&mut self, ast: &Ast, children: &[Id]) -> Id {
        match &ast.kind {
            AstKind::Num(n) => self.num(*n),
            AstKind::Ident(name) if name == "pi" => self.pi(),
            AstKind::Ident(name) => self.sym(name),
            AstKind::Neg(_) => self.neg(children[0]),
            AstKind::Binary(op, ..) => {
                let (a, b) = (children[0], children[1]);
                match op {
                    BinOp::Add => self.add2(a, b),
                    BinOp::Sub => self.sub(a, b),
                    BinOp::Mul => self.mul2(a, b),
                    BinOp::Div => self.div(a, b),
                    BinOp::Pow => self.pow(a, b),
                }
            }
            AstKind::Call(name, _) => {
                let xs = children;
                match name.as_str() {
                    "sqrt" => self.sqrt(xs[0]),
                    "pow" => self.pow(xs[0], xs[1]),
                    n => {
                        if let Some(f) = Func::from_name(n) {
                            self.call(f, xs[0])
                        } else if let Some(f) = Func2::from_name(n) {
                            self.call2(f, xs[0], xs[1])
                        } else if let Some((m, orders)) = self.resolve_map(n) {
                            self.map_call(m, orders, xs)
                        } else {
                            // The parser accepts only names from FUNCTIONS, all handled above.
                            unreachable!("function `{n}` accepted by the parser but not interned")
                        }
                    }
                }
            }
        }
    }

    /// Parse and intern in one step; the pool's declared maps may be called.
    pub fn parse(&mut self, src: &str) -> Result<Id, ParseError> {
        let ast = {
            let arity = |n: &str| self.find_map(n).map(|m| self.map_decl(m).arity());
            parse_with_maps(src, &arity)?
        };
        Ok(self.from_ast(&ast))
    }

    /// The map and derivative orders a called name denotes (`eta_vol_d10` → eta_vol, [1, 0]).
    pub fn resolve_map(&self, called: &str) -> Option<(crate::map::MapId, crate::map::MapOrders)> {
        let arity = |n: &str| self.find_map(n).map(|m| self.map_decl(m).arity());
        let (name, _, orders) = crate::map::resolve_call_name(called, arity)?;
        Some((self.find_map(&name)?, orders))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn precedence_and_associativity() {
        let mut p = Pool::new();
        let a = p.parse("-x^2").unwrap();
        let b = p.parse("-(x^2)").unwrap();
        assert_eq!(a, b);
        assert_eq!(p.parse("2^3^2").unwrap(), p.int(512));
        assert_eq!(p.parse("pow(2, 9)").unwrap(), p.int(512));
        assert_eq!(p.parse("1 - 2 - 3").unwrap(), p.int(-4));
        assert_eq!(p.parse("8/2/2").unwrap(), p.int(2));
    }

    #[test]
    fn nesting_is_bounded() {
        let deep = |n: usize| format!("{}x{}", "(".repeat(n), ")".repeat(n));
        assert!(parse(&deep(MAX_PARSE_DEPTH - 1)).is_ok());
        for n in [MAX_PARSE_DEPTH + 1, 2_000, 100_000] {
            let e = parse(&deep(n)).unwrap_err();
            assert!(
                e.message.contains("nested more than 500 levels"),
                "{}",
                e.message
            );
        }
        let tower = format!("x{}", "^x".repeat(5_000));
        assert!(parse(&tower).unwrap_err().message.contains("nested"));
        assert!(parse(&"-".repeat(50_000))
            .unwrap_err()
            .message
            .contains("nested"));
    }

    #[test]
    fn errors_have_spans() {
        let e = parse("a + * b").unwrap_err();
        assert_eq!(e.span, 4..5);
        let e = parse("foo(x)").unwrap_err();
        assert!(
            e.message.contains("unknown function `foo`"),
            "{}",
            e.message
        );
        assert_eq!(e.span, 0..3);
        let e = parse("sin(x, y)").unwrap_err();
        assert!(e.message.contains("takes 1 argument"), "{}", e.message);
        let e = parse("(a + b").unwrap_err();
        assert!(e.message.contains("expected `)`"), "{}", e.message);
        let e = parse("a b").unwrap_err();
        assert_eq!(e.span, 2..3);
        let e = parse("1.2.3").unwrap_err();
        assert!(e.message.contains("malformed number"), "{}", e.message);
        let e = parse("a $ b").unwrap_err();
        assert_eq!(e.span, 2..3);
        assert!(parse("   ").is_err());
        assert!(parse("a)").unwrap_err().message.contains("unmatched"));
    }

    #[test]
    fn identifiers_with_spans() {
        let ast = parse("c1*x1 + c9*u").unwrap();
        let ids = ast.identifiers();
        assert_eq!(ids[3], ("u", 11..12));
        assert_eq!(ids[2], ("c9", 8..10));
    }
}
