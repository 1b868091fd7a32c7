//! Positions in a model file: a byte offset becomes a 1-based line and a column counted in characters
//! (a byte-order mark does not count), an expression's byte becomes its offset in the file ([`Src`]), and
//! the [`Reader`] turns an offset into a positioned [`ModelError`].

use super::error::{ModelError, ModelErrorKind};
use std::ops::Range;
use std::path::Path;

/// 1-based line and column (in characters) of a byte offset.
pub(super) fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut o = offset.min(text.len());
    while !text.is_char_boundary(o) {
        o -= 1;
    }
    let before = &text[..o];
    let line = before.bytes().filter(|&b| b == b'\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    // A byte-order mark is invisible in editors, so it does not count as a column.
    let column = before[line_start..]
        .trim_start_matches('\u{feff}')
        .chars()
        .count()
        + 1;
    (line, column)
}

/// Reads one model file: its path (for messages) and its text (for positions).
pub(super) struct Reader<'a> {
    pub(super) file: &'a Path,
    pub(super) text: &'a str,
}

impl<'a> Reader<'a> {
    /// An error of `kind` at byte offset `at` (none: the error names only the file).
    pub(super) fn err(
        &self,
        at: Option<usize>,
        kind: ModelErrorKind,
        message: impl Into<String>,
    ) -> ModelError {
        let (line, column) = match at {
            Some(o) => {
                let (l, c) = line_col(self.text, o);
                (Some(l), Some(c))
            }
            None => (None, None),
        };
        ModelError {
            file: self.file.to_path_buf(),
            line,
            column,
            message: message.into(),
            kind,
        }
    }

    /// "line 5, column 3" for messages that refer to another place.
    pub(super) fn place(&self, at: Option<usize>) -> String {
        match at {
            Some(o) => {
                let (l, c) = line_col(self.text, o);
                format!("line {l}, column {c}")
            }
            None => "an unknown position".into(),
        }
    }

    /// "line 5" for messages that refer to another line.
    pub(super) fn line(&self, at: Option<usize>) -> String {
        match at {
            Some(o) => format!("line {}", line_col(self.text, o).0),
            None => "an unknown line".into(),
        }
    }
}

/// An expression string and where it is in the file.
#[derive(Debug, Clone)]
pub(super) struct Src {
    pub(super) text: String,
    /// Span of the TOML value (quotes included).
    pub(super) span: Option<Range<usize>>,
    /// Where the expression's bytes are in the file, when the string is written without escapes.
    pub(super) content: Option<Content>,
}

/// The position of a string's content in the file.
#[derive(Debug, Clone)]
pub(super) struct Content {
    /// File offset of the content's first byte.
    pub(super) start: usize,
    /// Offsets (in the value) of line feeds that the file writes as CR LF: TOML reads a multi-line
    /// string's CR LF as LF, which shifts every later byte by one.
    pub(super) crlf: Vec<usize>,
}

impl Src {
    /// File offset of byte `i` of the expression (or of the string value when it has escapes).
    pub(super) fn at(&self, i: usize) -> Option<usize> {
        match &self.content {
            Some(c) => {
                let i = i.min(self.text.len());
                Some(c.start + i + c.crlf.iter().filter(|&&p| p <= i).count())
            }
            None => self.span.as_ref().map(|s| s.start),
        }
    }
    /// File offset of the string value itself.
    pub(super) fn value_start(&self) -> Option<usize> {
        self.span.as_ref().map(|s| s.start)
    }
}

/// Where a string value's content is in the file, when the content is written verbatim (no escapes, no
/// line-ending backslashes).
pub(super) fn string_content(text: &str, span: &Range<usize>, value: &str) -> Option<Content> {
    let raw = text.get(span.clone())?;
    let delim = if raw.starts_with("\"\"\"") || raw.starts_with("'''") {
        3
    } else if raw.starts_with('"') || raw.starts_with('\'') {
        1
    } else {
        return None;
    };
    if raw.len() < 2 * delim {
        return None;
    }
    let mut start = delim;
    if delim == 3 {
        // A newline right after the opening delimiter is not part of the string.
        if raw[3..].starts_with("\r\n") {
            start += 2;
        } else if raw[3..].starts_with('\n') {
            start += 1;
        }
    }
    let inner = raw.get(start..raw.len() - delim)?;
    let start = span.start + start;
    if inner == value {
        return Some(Content {
            start,
            crlf: Vec::new(),
        });
    }
    if delim == 3 && inner.replace("\r\n", "\n") == value {
        let crlf = inner
            .match_indices("\r\n")
            .enumerate()
            .map(|(k, (r, _))| r - k)
            .collect();
        return Some(Content { start, crlf });
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column() {
        let text = "ab\nçd\n";
        assert_eq!(line_col(text, 0), (1, 1));
        assert_eq!(line_col(text, 3), (2, 1));
        assert_eq!(line_col(text, 5), (2, 2));
        assert_eq!(line_col(text, 100), (3, 1));
    }

    #[test]
    fn string_content_only_without_escapes() {
        let text = r#"a = "x + y"
b = "x\ty"
c = 'lit'
"#;
        let at =
            |span: Range<usize>, value: &str| string_content(text, &span, value).map(|c| c.start);
        assert_eq!(at(4..11, "x + y"), Some(5));
        assert_eq!(at(16..22, "x\ty"), None);
        assert_eq!(at(27..32, "lit"), Some(28));

        let text = "a = '''\r\nx +\r\n y'''";
        let c = string_content(text, &(4..text.len()), "x +\n y").expect("verbatim but for CR LF");
        let src = Src {
            text: "x +\n y".into(),
            span: Some(4..text.len()),
            content: Some(c),
        };
        assert_eq!(src.at(0), Some(9));
        assert_eq!(src.at(3), Some(13));
        assert_eq!(src.at(5).and_then(|o| text.get(o..o + 1)), Some("y"));
    }
}
