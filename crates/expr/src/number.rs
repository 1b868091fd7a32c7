//! Exact rational coefficients (with a floating-point fallback when a rational would overflow).
//!
//! Canonical simplification needs exact arithmetic on numeric coefficients: `0.1 + 0.2` must be exactly
//! `3/10`, and `x^1.8 * x^0.2` exactly `x^2`. Decimal literals in model files are read as exact rationals;
//! only when a numerator or denominator would leave `i128` does a value become an `f64` (and stays one).

use std::cmp::Ordering;
use std::fmt;
use std::hash::{Hash, Hasher};

/// A number in an expression: an exact rational `num/den` (den > 0, gcd 1) or an inexact float.
#[derive(Clone, Copy, Debug)]
pub enum Number {
    Rational(i128, i128),
    Float(f64),
}

fn gcd(mut a: i128, mut b: i128) -> i128 {
    a = a.abs();
    b = b.abs();
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    a
}

impl Number {
    pub const ZERO: Number = Number::Rational(0, 1);
    pub const ONE: Number = Number::Rational(1, 1);
    pub const MINUS_ONE: Number = Number::Rational(-1, 1);

    pub fn int(i: i128) -> Number {
        Number::Rational(i, 1)
    }

    /// `num/den`, reduced; a float if `den == 0` (which callers avoid) would give ±inf.
    pub fn ratio(num: i128, den: i128) -> Number {
        if den == 0 {
            return Number::Float(num as f64 / 0.0);
        }
        let g = gcd(num, den);
        let (mut n, mut d) = (num / g, den / g);
        if d < 0 {
            match (n.checked_neg(), d.checked_neg()) {
                (Some(nn), Some(dd)) => {
                    n = nn;
                    d = dd;
                }
                _ => return Number::Float(num as f64 / den as f64),
            }
        }
        Number::Rational(n, d)
    }

    /// A float, made exact when it is an integer or a short binary fraction that fits.
    pub fn from_f64(x: f64) -> Number {
        if x.is_finite() && x == x.trunc() && x.abs() < 1e30 {
            return Number::int(x as i128);
        }
        Number::Float(x)
    }

    /// Parse a decimal literal (`3`, `0.5`, `1e-3`, `2.5E+4`) exactly when it fits.
    pub fn parse_decimal(text: &str) -> Option<Number> {
        let (mantissa, exp) = match text.find(['e', 'E']) {
            Some(i) => (&text[..i], text[i + 1..].parse::<i32>().ok()?),
            None => (text, 0),
        };
        let (int_part, frac_part) = match mantissa.find('.') {
            Some(i) => (&mantissa[..i], &mantissa[i + 1..]),
            None => (mantissa, ""),
        };
        if int_part.is_empty() && frac_part.is_empty() {
            return None;
        }
        if !int_part
            .chars()
            .chain(frac_part.chars())
            .all(|c| c.is_ascii_digit())
        {
            return None;
        }
        let exact = (|| {
            let digits = format!("{int_part}{frac_part}");
            let digits = digits.trim_start_matches('0');
            let mut num: i128 = if digits.is_empty() {
                0
            } else {
                digits.parse().ok()?
            };
            let scale = exp - frac_part.len() as i32;
            let mut den: i128 = 1;
            if scale >= 0 {
                for _ in 0..scale {
                    num = num.checked_mul(10)?;
                }
            } else {
                for _ in 0..(-scale) {
                    den = den.checked_mul(10)?;
                }
            }
            Some(Number::ratio(num, den))
        })();
        exact.or_else(|| text.parse::<f64>().ok().map(Number::Float))
    }

    pub fn to_f64(self) -> f64 {
        match self {
            Number::Rational(n, d) => {
                if d == 1 {
                    n as f64
                } else {
                    // Divide in a way that keeps full precision for huge parts.
                    n as f64 / d as f64
                }
            }
            Number::Float(x) => x,
        }
    }

    pub fn is_zero(self) -> bool {
        match self {
            Number::Rational(n, _) => n == 0,
            Number::Float(x) => x == 0.0,
        }
    }
    pub fn is_one(self) -> bool {
        matches!(self, Number::Rational(1, 1)) || matches!(self, Number::Float(x) if x == 1.0)
    }
    pub fn is_minus_one(self) -> bool {
        matches!(self, Number::Rational(-1, 1)) || matches!(self, Number::Float(x) if x == -1.0)
    }
    pub fn is_negative(self) -> bool {
        match self {
            Number::Rational(n, _) => n < 0,
            Number::Float(x) => x < 0.0,
        }
    }
    /// The integer value, if exactly an integer.
    pub fn as_integer(self) -> Option<i128> {
        match self {
            Number::Rational(n, 1) => Some(n),
            _ => None,
        }
    }
    pub fn is_exact(self) -> bool {
        matches!(self, Number::Rational(..))
    }

    #[allow(clippy::should_implement_trait)] // the operator traits below delegate here
    pub fn add(self, o: Number) -> Number {
        if let (Number::Rational(a, b), Number::Rational(c, d)) = (self, o) {
            let g = gcd(b, d);
            let exact = (|| {
                let l = (b / g).checked_mul(d)?;
                let n = a.checked_mul(l / b)?.checked_add(c.checked_mul(l / d)?)?;
                Some(Number::ratio(n, l))
            })();
            if let Some(r) = exact {
                return r;
            }
        }
        Number::Float(self.to_f64() + o.to_f64())
    }
    #[allow(clippy::should_implement_trait)] // the operator traits below delegate here
    pub fn mul(self, o: Number) -> Number {
        if let (Number::Rational(a, b), Number::Rational(c, d)) = (self, o) {
            let g1 = gcd(a, d).max(1);
            let g2 = gcd(c, b).max(1);
            let exact = (|| {
                let n = (a / g1).checked_mul(c / g2)?;
                let den = (b / g2).checked_mul(d / g1)?;
                Some(Number::ratio(n, den))
            })();
            if let Some(r) = exact {
                return r;
            }
        }
        Number::Float(self.to_f64() * o.to_f64())
    }
    #[allow(clippy::should_implement_trait)] // the operator traits below delegate here
    pub fn neg(self) -> Number {
        match self {
            Number::Rational(n, d) => match n.checked_neg() {
                Some(m) => Number::Rational(m, d),
                None => Number::Float(-(n as f64) / d as f64),
            },
            Number::Float(x) => Number::Float(-x),
        }
    }
    /// 1/x, or `None` for zero.
    pub fn recip(self) -> Option<Number> {
        if self.is_zero() {
            return None;
        }
        Some(match self {
            Number::Rational(n, d) => Number::ratio(d, n),
            Number::Float(x) => Number::Float(1.0 / x),
        })
    }
    /// self^k for an integer k, exactly when it fits; `None` for 0^negative.
    pub fn powi(self, k: i128) -> Option<Number> {
        if k < 0 {
            return self.recip()?.powi(-k);
        }
        if let Number::Rational(n, d) = self {
            let exact = (|| {
                let e = u32::try_from(k).ok()?;
                Some(Number::ratio(n.checked_pow(e)?, d.checked_pow(e)?))
            })();
            if let Some(r) = exact {
                return Some(r);
            }
        }
        Some(Number::Float(self.to_f64().powf(k as f64)))
    }
}

impl std::ops::Add for Number {
    type Output = Number;
    fn add(self, o: Number) -> Number {
        Number::add(self, o)
    }
}

impl std::ops::Mul for Number {
    type Output = Number;
    fn mul(self, o: Number) -> Number {
        Number::mul(self, o)
    }
}

impl std::ops::Neg for Number {
    type Output = Number;
    fn neg(self) -> Number {
        Number::neg(self)
    }
}

impl PartialEq for Number {
    fn eq(&self, o: &Number) -> bool {
        match (self, o) {
            (Number::Rational(a, b), Number::Rational(c, d)) => a == c && b == d,
            (Number::Float(x), Number::Float(y)) => x.to_bits() == y.to_bits(),
            _ => false,
        }
    }
}
impl Eq for Number {}
impl Hash for Number {
    fn hash<H: Hasher>(&self, h: &mut H) {
        match self {
            Number::Rational(a, b) => {
                0u8.hash(h);
                a.hash(h);
                b.hash(h);
            }
            Number::Float(x) => {
                1u8.hash(h);
                x.to_bits().hash(h);
            }
        }
    }
}

impl Number {
    /// Total order by value (exact comparison for rationals).
    pub fn cmp_value(&self, o: &Number) -> Ordering {
        match (self, o) {
            (Number::Rational(a, b), Number::Rational(c, d)) => {
                match (a.checked_mul(*d), c.checked_mul(*b)) {
                    (Some(l), Some(r)) => l.cmp(&r),
                    _ => self.to_f64().total_cmp(&o.to_f64()),
                }
            }
            _ => self
                .to_f64()
                .total_cmp(&o.to_f64())
                .then(self.is_exact().cmp(&o.is_exact())),
        }
    }
}

impl fmt::Display for Number {
    /// Prints in the contract's expression language: integers as integers, terminating fractions as
    /// decimals, other rationals as `n/d` (the caller parenthesises), floats in shortest round-trip form.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Number::Rational(n, 1) => write!(f, "{n}"),
            Number::Rational(n, d) => {
                // Terminating decimal iff d = 2^a 5^b.
                let mut r = d;
                let (mut twos, mut fives) = (0u32, 0u32);
                while r % 2 == 0 {
                    r /= 2;
                    twos += 1;
                }
                while r % 5 == 0 {
                    r /= 5;
                    fives += 1;
                }
                if r == 1 {
                    let digits = twos.max(fives);
                    if digits <= 30 {
                        // n/d = n * (10^digits / d) / 10^digits
                        if let Some(scaled) = 10i128
                            .checked_pow(digits)
                            .and_then(|p| n.checked_mul(p / d))
                        {
                            let neg = scaled < 0;
                            let s = scaled.unsigned_abs().to_string();
                            let digits = digits as usize;
                            let s = if s.len() <= digits {
                                format!("{}{}", "0".repeat(digits - s.len() + 1), s)
                            } else {
                                s
                            };
                            let (ip, fp) = s.split_at(s.len() - digits);
                            let fp = fp.trim_end_matches('0');
                            return write!(f, "{}{}.{}", if neg { "-" } else { "" }, ip, fp);
                        }
                    }
                }
                write!(f, "{n}/{d}")
            }
            Number::Float(x) => {
                if x.is_finite() {
                    let s = format!("{x:e}");
                    let plain = format!("{x}");
                    if plain.len() <= s.len() && !plain.contains("inf") {
                        if plain.contains('.') {
                            write!(f, "{plain}")
                        } else {
                            write!(f, "{plain}.0")
                        }
                    } else {
                        write!(f, "{s}")
                    }
                } else {
                    write!(f, "{x}")
                }
            }
        }
    }
}

/// b^p in f64 as every evaluator in invsim computes it: integer exponents by `powi`, ½ by `sqrt`,
/// anything else by `powf`.
pub fn pow_f64(b: f64, exact: Option<Number>, p: f64) -> f64 {
    match exact {
        Some(n) if n.as_integer().is_some_and(|k| k.abs() <= i32::MAX as i128) => b.powi(p as i32),
        Some(n) if n == Number::ratio(1, 2) => b.sqrt(),
        Some(n) if n == Number::ratio(-1, 2) => 1.0 / b.sqrt(),
        _ => b.powf(p),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimals_are_exact() {
        assert_eq!(Number::parse_decimal("0.1").unwrap(), Number::ratio(1, 10));
        assert_eq!(Number::parse_decimal("2.5E+4").unwrap(), Number::int(25000));
        assert_eq!(
            Number::parse_decimal("1e-3").unwrap(),
            Number::ratio(1, 1000)
        );
        assert_eq!(
            Number::parse_decimal("0.1")
                .unwrap()
                .add(Number::parse_decimal("0.2").unwrap()),
            Number::ratio(3, 10)
        );
        assert!(matches!(
            Number::parse_decimal("1e-300").unwrap(),
            Number::Float(_)
        ));
    }

    #[test]
    fn display_round_trips() {
        for s in [
            "0.5",
            "-0.0072",
            "44000000",
            "1/3",
            "-2/7",
            "0.4439938161680794",
        ] {
            let n = if let Some((a, b)) = s.split_once('/') {
                Number::ratio(a.parse().unwrap(), b.parse().unwrap())
            } else {
                Number::parse_decimal(s.trim_start_matches('-')).unwrap()
            };
            let n = if s.starts_with('-') && !s.contains('/') {
                n.neg()
            } else {
                n
            };
            assert_eq!(n.to_string(), s);
        }
    }

    #[test]
    fn overflow_falls_back_to_float() {
        let big = Number::ratio(i128::MAX / 3, 7);
        let p = big.mul(big);
        assert!(matches!(p, Number::Float(_)));
        assert!((p.to_f64() / (big.to_f64() * big.to_f64()) - 1.0).abs() < 1e-15);
    }
}
