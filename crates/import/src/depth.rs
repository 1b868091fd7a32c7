//! The nesting depth of a YAML text, measured in one linear pass before the text is parsed: the YAML reader
//! takes time quadratic in the number of open flow collections (10⁵ unclosed `[` take 20 s before failing on
//! its recursion limit), and a vehicle file nests about ten levels. The pass counts open flow collections
//! (`[`, `{` outside quoted scalars and comments) plus block levels (a stack of the indentations of the
//! lines, and a level per compact `- ` entry); a text deeper than [`MAX_YAML_DEPTH`] is refused at the
//! line and column where the limit is crossed. The count is an upper bound of the parser's depth (a plain
//! scalar continued on more indented lines counts a level per line), never below it.

use crate::error::ImportError;

/// Deepest nesting of a vehicle file, in levels (FASTSim's files nest at most 10; the YAML reader's own
/// recursion limit is 128).
pub const MAX_YAML_DEPTH: usize = 64;

/// The state of the pass.
#[derive(Default)]
struct Scan {
    /// Open flow collections.
    flow: usize,
    /// Indentations of the open block levels.
    indents: Vec<usize>,
    /// Inside a quoted scalar: its quote character.
    quote: Option<char>,
    /// Inside a block scalar (`|`, `>`): the indentation of the line that opened it and, once its first
    /// line is read, the indentation of its content (YAML 1.2 §8.1.1.1: detected from the first non-empty
    /// line; a less indented line ends the scalar).
    block_scalar: Option<(usize, Option<usize>)>,
}

/// `Err` with the line and column where the nesting of `text` first exceeds [`MAX_YAML_DEPTH`].
pub fn check(text: &str) -> Result<(), ImportError> {
    let mut s = Scan::default();
    for (i, line) in text.split('\n').enumerate() {
        let line = line.strip_suffix('\r').unwrap_or(line);
        s.line(line).map_err(|column| ImportError::Yaml {
            line: i + 1,
            column,
            message: format!(
                "the text nests deeper than {MAX_YAML_DEPTH} levels (open `[`, `{{` and indented blocks); \
                 a vehicle file nests about 10"
            ),
        })?;
    }
    Ok(())
}

impl Scan {
    fn depth(&self) -> usize {
        self.flow + self.indents.len()
    }

    /// One line; `Err(column)` (1-based, in characters) where the depth exceeds the cap.
    fn line(&mut self, line: &str) -> Result<(), usize> {
        let indent = line.len() - line.trim_start_matches(' ').len();
        let content = line[indent..].trim_end();
        if let Some((opened, content_indent)) = self.block_scalar {
            if content.is_empty() {
                return Ok(());
            }
            match content_indent {
                None if indent > opened => {
                    self.block_scalar = Some((opened, Some(indent)));
                    return Ok(());
                }
                Some(ci) if indent >= ci => return Ok(()),
                _ => self.block_scalar = None,
            }
        }
        if content.is_empty() || content.starts_with('#') {
            return Ok(());
        }
        if self.flow == 0 && self.quote.is_none() {
            if indent == 0 && (content.starts_with("---") || content.starts_with("...")) {
                self.indents.clear();
                return Ok(());
            }
            while self.indents.last().is_some_and(|&top| top > indent) {
                self.indents.pop();
            }
            if self.indents.last().is_none_or(|&top| indent > top) {
                self.indents.push(indent);
                if self.depth() > MAX_YAML_DEPTH {
                    return Err(indent + 1);
                }
            }
        }
        self.scan_chars(&line[..indent + content.len()], indent)
    }

    /// The characters of a line from its indentation on: quotes, comments, flow brackets, compact `- `
    /// entries and block-scalar indicators. Every `[` and `{` outside quotes and comments counts (also in a
    /// plain scalar, where the parser would not open a collection: an overcount, never an undercount of the
    /// flow levels whose scanning is quadratic).
    fn scan_chars(&mut self, line: &str, indent: usize) -> Result<(), usize> {
        // Whether the next character starts a node, where a quote opens a quoted scalar: after the
        // indentation, `- `, `: `, `? `, and in a flow collection after `[`, `{` and `,`.
        let mut node_start = self.quote.is_none();
        let mut prev = ' ';
        let mut chars = line.char_indices().skip(indent).peekable();
        let mut column = indent;
        while let Some((byte, c)) = chars.next() {
            column += 1;
            let next = chars.peek().map_or(' ', |&(_, n)| n);
            if let Some(q) = self.quote {
                // `''` in a single-quoted scalar and `\x` in a double-quoted one do not end it.
                let escaped = (c == q && q == '\'' && next == '\'') || (c == '\\' && q == '"');
                if escaped {
                    chars.next();
                    column += 1;
                } else if c == q {
                    self.quote = None;
                }
                prev = c;
                continue;
            }
            match c {
                '#' if prev == ' ' || prev == '\t' => return Ok(()),
                '"' | '\'' if node_start => self.quote = Some(c),
                '[' | '{' => {
                    self.flow += 1;
                    if self.depth() > MAX_YAML_DEPTH {
                        return Err(column);
                    }
                }
                ']' | '}' if self.flow > 0 => self.flow -= 1,
                '-' | '?' if node_start && self.flow == 0 && (next == ' ' || next == '\t') => {
                    self.indents.push(column + 1);
                    if self.depth() > MAX_YAML_DEPTH {
                        return Err(column);
                    }
                }
                '|' | '>' if node_start && self.flow == 0 => {
                    // A block scalar's header: the indicator, then only `+`, `-`, digits and a comment.
                    let rest = line[byte + 1..]
                        .trim_start_matches(|r: char| r == '+' || r == '-' || r.is_ascii_digit())
                        .trim_start();
                    if rest.is_empty() || rest.starts_with('#') {
                        self.block_scalar = Some((indent, None));
                        return Ok(());
                    }
                }
                _ => {}
            }
            node_start = match c {
                ' ' | '\t' => {
                    node_start || matches!(prev, ':' | '-' | '?') || (prev == ',' && self.flow > 0)
                }
                '[' | '{' => true,
                ',' => self.flow > 0,
                _ => false,
            };
            prev = c;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{check, MAX_YAML_DEPTH};

    #[test]
    fn counts_flow_and_block_levels() {
        assert!(check("a:\n  b: [1, [2, {c: 3}]]\n  'd[': \"[[[\" # [[[\n").is_ok());
        let deep = "[".repeat(MAX_YAML_DEPTH + 10);
        let e = check(&format!("a: 1\nb: {deep}\n"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with(&format!("2:{}:", MAX_YAML_DEPTH + 3)), "{e}");
        let blocks: String = (0..MAX_YAML_DEPTH + 1)
            .map(|i| format!("{}k{i}:\n", " ".repeat(i)))
            .collect();
        let e = check(&blocks).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{}:", MAX_YAML_DEPTH + 1)), "{e}");
        let dashes = "- ".repeat(MAX_YAML_DEPTH + 1);
        assert!(check(&format!("{dashes}x\n")).is_err());
        assert!(check("a: |\n  [[[[\n   [[[\nb: x\n").is_ok());
        // Brackets hidden behind a tag, or after a quote in a block plain scalar, still count.
        let deep = "[".repeat(MAX_YAML_DEPTH);
        assert!(check(&format!("a: !t {deep}\n")).is_err());
        assert!(check(&format!("a: b, 'c\nd: {deep}\n")).is_err());
        // A block scalar ends at its first less indented line.
        assert!(check(&format!("a: |\n    x\n  {deep}\n")).is_err());
    }
}
