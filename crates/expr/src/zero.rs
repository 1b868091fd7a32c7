//! Deciding whether an expression is identically zero: canonical form, then expansion, then randomised
//! numeric probing. The verdict says which step decided, so a caller can report how sure it is.
//!
//! Probing (Schwartz–Zippel in spirit: a nonzero analytic function vanishes on a measure-zero set) evaluates
//! the expression at random points around the nominal parameter values and random values of every other
//! symbol. A sum is taken as zero at a point when its value is below 1e-10 of the sum of its terms'
//! magnitudes, which absorbs rounding.

use crate::pool::{Id, Node, Pool, Symbol};
use std::collections::HashMap;

/// Which step of the zero test decided.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecidedBy {
    /// The canonical form is the number 0 (or a nonzero number).
    Canonical,
    /// The expanded form is 0.
    Expanded,
    /// Random numeric probing.
    Probing,
}

/// The outcome of [`zero_test`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ZeroVerdict {
    Zero(DecidedBy),
    NonZero(DecidedBy),
}

impl ZeroVerdict {
    pub fn is_zero(&self) -> bool {
        matches!(self, ZeroVerdict::Zero(_))
    }
    pub fn decided_by(&self) -> DecidedBy {
        match self {
            ZeroVerdict::Zero(d) | ZeroVerdict::NonZero(d) => *d,
        }
    }
}

/// Number of random points probed.
pub const PROBES: usize = 24;
/// Relative tolerance of a probe (against the magnitude of the expression's terms).
pub const PROBE_RTOL: f64 = 1e-10;

/// A small deterministic generator (SplitMix64), so that verdicts are reproducible.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    }
}

/// Value and magnitude scale (sum of absolute values of a sum's terms) at a point.
fn value_and_scale(pool: &Pool, e: Id, values: &HashMap<Symbol, f64>) -> Option<(f64, f64)> {
    let v = pool.eval(e, values).ok()?;
    let scale = match pool.node(e) {
        Node::Add(ts) => {
            let mut s = 0.0;
            for &t in ts.iter() {
                s += pool.eval(t, values).ok()?.abs();
            }
            s
        }
        _ => v.abs(),
    };
    Some((v, scale))
}

/// Is `e` identically zero? Symbols in `nominal` (parameters) are probed within ±20 % of their value,
/// every other symbol (states, inputs) uniformly in ±[0.2, 3].
pub fn zero_test(pool: &mut Pool, e: Id, nominal: &HashMap<Symbol, f64>) -> ZeroVerdict {
    if let Some(n) = pool.as_number(e) {
        return if n.is_zero() { ZeroVerdict::Zero(DecidedBy::Canonical) } else { ZeroVerdict::NonZero(DecidedBy::Canonical) };
    }
    let expanded = pool.expand(e).ok();
    if let Some(x) = expanded {
        if pool.is_zero(x) {
            return ZeroVerdict::Zero(DecidedBy::Expanded);
        }
        if let Some(n) = pool.as_number(x) {
            if !n.is_zero() {
                return ZeroVerdict::NonZero(DecidedBy::Expanded);
            }
        }
    }
    let probe = expanded.unwrap_or(e);
    let syms: Vec<Symbol> = pool.free_symbols(probe).to_vec();
    let mut rng = Rng::new(0x5EED_1234 ^ e.index() as u64);
    let mut finite_probes = 0;
    let mut attempts = 0;
    while finite_probes < PROBES && attempts < PROBES * 8 {
        attempts += 1;
        // The first half of the attempts use positive values only (many physical expressions need them).
        let positive_only = attempts <= PROBES * 4;
        let mut values = HashMap::with_capacity(syms.len());
        for &s in &syms {
            let v = match nominal.get(&s) {
                Some(&v) if v != 0.0 => v * rng.uniform(0.8, 1.2),
                _ => {
                    let m = rng.uniform(0.2, 3.0);
                    if positive_only || rng.next_u64() & 1 == 0 {
                        m
                    } else {
                        -m
                    }
                }
            };
            values.insert(s, v);
        }
        let Some((v, scale)) = value_and_scale(pool, probe, &values) else { continue };
        if !v.is_finite() || !scale.is_finite() {
            continue;
        }
        finite_probes += 1;
        if v.abs() > PROBE_RTOL * scale.max(f64::MIN_POSITIVE) && v != 0.0 {
            return ZeroVerdict::NonZero(DecidedBy::Probing);
        }
    }
    if finite_probes == 0 {
        // Nowhere finite on the probed region: treat as nonzero (the caller will meet it again numerically).
        return ZeroVerdict::NonZero(DecidedBy::Probing);
    }
    ZeroVerdict::Zero(DecidedBy::Probing)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decides_and_says_how() {
        let mut p = Pool::new();
        let nominal = HashMap::new();
        let e = p.parse("x - x").unwrap();
        assert_eq!(zero_test(&mut p, e, &nominal), ZeroVerdict::Zero(DecidedBy::Canonical));
        let e = p.parse("(x + 1)^2 - x^2 - 2*x - 1").unwrap();
        assert_eq!(zero_test(&mut p, e, &nominal), ZeroVerdict::Zero(DecidedBy::Expanded));
        let e = p.parse("sin(x)^2 + cos(x)^2 - 1").unwrap();
        assert_eq!(zero_test(&mut p, e, &nominal), ZeroVerdict::Zero(DecidedBy::Probing));
        let e = p.parse("sin(x)^2 + cos(x)^2 - 1.000001").unwrap();
        assert_eq!(zero_test(&mut p, e, &nominal), ZeroVerdict::NonZero(DecidedBy::Probing));
        let e = p.parse("exp(log(x)) - x").unwrap();
        assert_eq!(zero_test(&mut p, e, &nominal), ZeroVerdict::Zero(DecidedBy::Canonical));
    }
}
