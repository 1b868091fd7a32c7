//! Numbers in messages: at most six significant digits, with an exponent for very large or small magnitudes,
//! so that no message prints a 301-digit time or a 320-digit step. Used by every error of the runtime (the
//! numerics below it too: it imports nothing).

/// Significant digits a number in a message keeps at most.
const MESSAGE_DIGITS: usize = 6;

/// `v` for a message: as written when that takes at most [`MESSAGE_DIGITS`] significant digits (0.1, 1180,
/// 1000000000 below 1e15), else rounded to them, positional for 1e-4 ≤ |v| < 1e6 and with an exponent
/// otherwise (1e300, not 301 digits).
pub fn num(v: f64) -> String {
    if !v.is_finite() || v == 0.0 {
        return format!("{v}");
    }
    let a = v.abs();
    if (1e-4..1e15).contains(&a) {
        let s = format!("{v}");
        let digits = s
            .trim_start_matches(['-', '0', '.'])
            .chars()
            .filter(char::is_ascii_digit)
            .count();
        if digits <= MESSAGE_DIGITS {
            return s;
        }
    }
    if (1e-4..1e6).contains(&a) {
        let mag = a.log10().floor() as i32;
        let decimals = (MESSAGE_DIGITS as i32 - 1 - mag).max(0) as usize;
        let s = format!("{v:.decimals$}");
        return if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        };
    }
    let s = format!("{:.*e}", MESSAGE_DIGITS - 1, v);
    match s.split_once('e') {
        Some((m, e)) if m.contains('.') => {
            format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
        }
        _ => s,
    }
}

#[cfg(test)]
mod tests {
    use super::num;

    #[test]
    fn message_numbers_are_short() {
        assert_eq!(num(0.1), "0.1");
        assert_eq!(num(1180.0), "1180");
        assert_eq!(num(-2.5e-9), "-2.5e-9");
        assert_eq!(num(1e300), "1e300");
        assert_eq!(num(1.0 / 3.0), "0.333333");
        assert_eq!(num(123_456_789.123), "1.23457e8");
        assert_eq!(num(12_345_678.0), "1.23457e7");
        assert_eq!(num(1e9), "1e9");
        assert_eq!(num(-1.0 / 3.0), "-0.333333");
        assert_eq!(num(5e-324), "4.94066e-324");
        assert_eq!(num(f64::MAX), "1.79769e308");
        for v in [1e-320, 7.0e22, 0.1 + 0.2, 1e15 / 3.0] {
            let s = num(v);
            assert!(s.len() <= 14, "{v}: {s}");
        }
    }
}
