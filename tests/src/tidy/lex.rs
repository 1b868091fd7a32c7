//! A small Rust lexer for the tidy checks: comments dropped, string, char and raw-string literals kept as one
//! token each (so nothing inside them is mistaken for code), every token with its 1-based line.

/// What a token is; the checks only need identifiers, punctuation and "something else".
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// An identifier or keyword (`fn`, `crate`, `unwrap`, a raw `r#name` without its `r#`).
    Ident,
    /// One punctuation character, or `::` as one token.
    Punct,
    /// A string, byte string, raw string, char, byte or number literal.
    Literal,
    /// A lifetime or label (`'a`).
    Lifetime,
}

/// One token of source text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Token {
    pub kind: Kind,
    pub text: String,
    /// 1-based line of the token's first character.
    pub line: usize,
}

impl Token {
    /// Whether this is the identifier or punctuation `s`.
    pub fn is(&self, s: &str) -> bool {
        self.kind != Kind::Literal && self.text == s
    }
}

/// A cursor over the characters of a file that counts lines.
struct Cursor {
    chars: Vec<char>,
    pos: usize,
    line: usize,
}

impl Cursor {
    fn peek(&self, k: usize) -> Option<char> {
        self.chars.get(self.pos + k).copied()
    }
    fn bump(&mut self) -> Option<char> {
        let c = self.peek(0)?;
        self.pos += 1;
        if c == '\n' {
            self.line += 1;
        }
        Some(c)
    }
    fn text_from(&self, start: usize) -> String {
        self.chars[start..self.pos].iter().collect()
    }
    /// Skip `//…` to the end of the line.
    fn line_comment(&mut self) {
        while self.peek(0).is_some_and(|c| c != '\n') {
            self.bump();
        }
    }
    /// Skip a (nested) `/* … */` comment; the cursor is on its `/`.
    fn block_comment(&mut self) {
        let mut depth = 0usize;
        while let Some(c) = self.peek(0) {
            if c == '/' && self.peek(1) == Some('*') {
                depth += 1;
                self.pos += 2;
            } else if c == '*' && self.peek(1) == Some('/') {
                self.pos += 2;
                depth -= 1;
                if depth == 0 {
                    return;
                }
            } else {
                self.bump();
            }
        }
    }
    /// Skip a quoted literal whose opening quote `q` is under the cursor (escapes with `\`).
    fn quoted(&mut self, q: char) {
        self.bump();
        while let Some(c) = self.bump() {
            if c == '\\' {
                self.bump();
            } else if c == q {
                return;
            }
        }
    }
    /// Skip a raw string `#…#"…"#…#` whose first `#` or `"` is under the cursor.
    fn raw_string(&mut self) {
        let mut hashes = 0;
        while self.peek(0) == Some('#') {
            hashes += 1;
            self.bump();
        }
        self.bump(); // the opening quote
        while let Some(c) = self.bump() {
            if c == '"' && (0..hashes).all(|k| self.peek(k) == Some('#')) {
                self.pos += hashes;
                return;
            }
        }
    }
    /// After `'`: a char literal (`'a'`, `'\n'`, `'é'`) or a lifetime (`'a`).
    fn quote(&mut self) -> Kind {
        if self.peek(1) == Some('\\') || self.peek(2) == Some('\'') {
            self.quoted('\'');
            return Kind::Literal;
        }
        self.bump();
        while self.peek(0).is_some_and(is_ident_char) {
            self.bump();
        }
        Kind::Lifetime
    }
    fn ident(&mut self) {
        while self.peek(0).is_some_and(is_ident_char) {
            self.bump();
        }
    }
    fn number(&mut self) {
        self.ident();
        if self.peek(0) == Some('.') && self.peek(1).is_some_and(|c| c.is_ascii_digit()) {
            self.bump();
            self.ident();
        }
    }
}

fn is_ident_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// What follows an identifier `prefix` that makes it a literal prefix: `b"…"`, `br#"…"#`, `r"…"`, `b'x'`, `c"…"`.
fn literal_after_prefix(cur: &mut Cursor, prefix: &str) -> bool {
    match (prefix, cur.peek(0)) {
        ("b" | "c", Some('"')) => cur.quoted('"'),
        ("b", Some('\'')) => cur.quoted('\''),
        ("r" | "br" | "cr", Some('"')) => cur.raw_string(),
        ("r" | "br" | "cr", Some('#')) if matches!(cur.peek(1), Some('"' | '#')) => {
            cur.raw_string()
        }
        _ => return false,
    }
    true
}

/// The tokens of `src`, comments dropped.
pub fn tokenize(src: &str) -> Vec<Token> {
    let mut cur = Cursor {
        chars: src.chars().collect(),
        pos: 0,
        line: 1,
    };
    let mut out = Vec::new();
    while let Some(c) = cur.peek(0) {
        let (start, line) = (cur.pos, cur.line);
        let kind = match c {
            _ if c.is_whitespace() => {
                cur.bump();
                continue;
            }
            '/' if cur.peek(1) == Some('/') => {
                cur.line_comment();
                continue;
            }
            '/' if cur.peek(1) == Some('*') => {
                cur.block_comment();
                continue;
            }
            '"' => {
                cur.quoted('"');
                Kind::Literal
            }
            '\'' => cur.quote(),
            _ if c.is_ascii_digit() => {
                cur.number();
                Kind::Literal
            }
            _ if is_ident_char(c) => {
                cur.ident();
                let prefix = cur.text_from(start);
                if literal_after_prefix(&mut cur, &prefix) {
                    Kind::Literal
                } else if prefix == "r" && cur.peek(0) == Some('#') {
                    // A raw identifier r#name: the token is the name.
                    cur.bump();
                    let name_start = cur.pos;
                    cur.ident();
                    out.push(Token {
                        kind: Kind::Ident,
                        text: cur.text_from(name_start),
                        line,
                    });
                    continue;
                } else {
                    Kind::Ident
                }
            }
            ':' if cur.peek(1) == Some(':') => {
                cur.pos += 2;
                Kind::Punct
            }
            _ => {
                cur.bump();
                Kind::Punct
            }
        };
        out.push(Token {
            kind,
            text: cur.text_from(start),
            line,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texts(src: &str) -> Vec<String> {
        tokenize(src).into_iter().map(|t| t.text).collect()
    }

    #[test]
    fn literals_and_comments_hide_code() {
        let src = "let s = \"fn x() { .unwrap() }\"; // fn y\n/* fn /* z */ */ let r = r#\"a\"b\"#; 'q'; 'a: loop {}";
        let t = texts(src);
        assert!(!t.iter().any(|s| s == "fn" || s == "unwrap"), "{t:?}");
        assert!(t.contains(&"r#\"a\"b\"#".to_string()), "{t:?}");
        assert!(
            t.contains(&"'q'".to_string()) && t.contains(&"'a".to_string()),
            "{t:?}"
        );
    }

    #[test]
    fn lines_are_counted_through_literals_and_comments() {
        let toks = tokenize("a\n\"x\ny\"\n/* \n */ b::c");
        let b = toks.iter().find(|t| t.text == "b").map(|t| t.line);
        assert_eq!(b, Some(5));
        assert!(toks.iter().any(|t| t.text == "::"));
    }
}
