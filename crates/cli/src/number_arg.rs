//! The number rule of every numeric value a user writes in an option or a parameter table (`--set`, `--grid`,
//! `--table`): a decimal that Rust's `f64` parser reads, finite, and not a nonzero literal that underflows to 0
//! (1e-400 would silently become 0; the smallest positive number is 5e-324).

/// Why a written number is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NumberError {
    /// Not a number at all (`abc`, empty).
    NotANumber,
    /// `inf`, `nan` or a literal beyond ±1.8e308.
    NotFinite,
    /// A nonzero literal below 5e-324 in magnitude (reads as 0).
    Underflow,
}

impl NumberError {
    /// What is wrong with `text`, for a message: "`1e-400` is out of range: …".
    pub fn describe(self, text: &str) -> String {
        match self {
            NumberError::NotANumber => format!("`{text}` is not a number"),
            NumberError::NotFinite => format!("`{text}` is not a finite number"),
            NumberError::Underflow => format!(
                "`{text}` is out of range: it underflows to 0 (below 5e-324, the smallest number)"
            ),
        }
    }
}

/// `text` (surrounding blanks ignored) as a finite `f64`; a literal whose mantissa has a nonzero digit but
/// reads as 0 is [`NumberError::Underflow`].
pub fn parse_number(text: &str) -> Result<f64, NumberError> {
    let text = text.trim();
    let v: f64 = text.parse().map_err(|_| NumberError::NotANumber)?;
    if !v.is_finite() {
        return Err(NumberError::NotFinite);
    }
    let mantissa = text.split(['e', 'E']).next().unwrap_or("");
    if v == 0.0 && mantissa.bytes().any(|b| (b'1'..=b'9').contains(&b)) {
        return Err(NumberError::Underflow);
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_number_rule() {
        assert_eq!(parse_number(" 1500 "), Ok(1500.0));
        assert_eq!(parse_number("-0.0"), Ok(0.0));
        assert_eq!(parse_number("0e-400"), Ok(0.0));
        assert_eq!(parse_number("5e-324"), Ok(5e-324));
        assert_eq!(parse_number("1e-400"), Err(NumberError::Underflow));
        assert_eq!(parse_number("-3E-999"), Err(NumberError::Underflow));
        assert_eq!(parse_number("1e999"), Err(NumberError::NotFinite));
        assert_eq!(parse_number("nan"), Err(NumberError::NotFinite));
        assert_eq!(parse_number("x"), Err(NumberError::NotANumber));
        assert_eq!(parse_number(""), Err(NumberError::NotANumber));
    }
}
