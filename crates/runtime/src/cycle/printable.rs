//! A cell's or a name's text as a cycle-reader message shows it.

/// `text` for a message: control characters (a NUL byte) escaped, at most 40 characters.
pub(super) fn printable(text: &str) -> String {
    let mut out = String::new();
    for (i, c) in text.chars().enumerate() {
        if i == 40 {
            out.push('…');
            break;
        }
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}
