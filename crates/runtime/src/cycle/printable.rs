//! A cell's or a name's text as a cycle-reader message shows it.

/// `text` for a message: control characters (a NUL byte) escaped ([`crate::textfmt::escape_controls`]), at
/// most 40 characters.
pub(super) fn printable(text: &str) -> String {
    let shown: String = text.chars().take(40).collect();
    let mut out = crate::textfmt::escape_controls(&shown, false).into_owned();
    if text.chars().nth(40).is_some() {
        out.push('…');
    }
    out
}
