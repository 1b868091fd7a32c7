//! User strings (file names, a model's `description`, names) in messages and the text summary: control
//! characters are escaped, so that a file name holding ESC or CR cannot move the cursor, recolour or rewrite
//! the terminal. Used by the text summary here and by every message of the command line.

use std::borrow::Cow;

/// `s` with every control character (Unicode category Cc: U+0000–U+001F, U+007F–U+009F) written as Rust's
/// escape (`char::escape_default`: ESC → `\u{1b}`, CR → `\r`, tab → `\t`), except line feeds where
/// `keep_newlines` (a multi-line text such as the summary, whose lines are its own). Borrowed when there is
/// nothing to escape (the common case).
pub fn escape_controls(s: &str, keep_newlines: bool) -> Cow<'_, str> {
    let escaped = |c: char| c.is_control() && !(keep_newlines && c == '\n');
    if !s.chars().any(escaped) {
        return Cow::Borrowed(s);
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        if escaped(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

#[cfg(test)]
mod tests {
    use super::escape_controls;

    #[test]
    fn control_characters_are_escaped() {
        assert_eq!(escape_controls("plain.csv", false), "plain.csv");
        assert_eq!(escape_controls("a\u{1b}[2Jb", false), "a\\u{1b}[2Jb");
        assert_eq!(escape_controls("x\ry\u{7}", false), "x\\ry\\u{7}");
        assert_eq!(escape_controls("a\nb\t", false), "a\\nb\\t");
        assert_eq!(escape_controls("a\nb\u{9b}", true), "a\nb\\u{9b}");
        assert_eq!(escape_controls("kein Ärger ✓", false), "kein Ärger ✓");
    }
}
