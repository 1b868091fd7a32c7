//! Deciding whether an expression is identically zero: canonical form, then expansion, then randomised
//! numeric probing. The verdict says which step decided, so a caller can report how sure it is.
//!
//! Probing (Schwartz–Zippel in spirit: a nonzero analytic function vanishes on a measure-zero set) evaluates
//! the expression at random points around the nominal parameter values and random values of every other
//! symbol. A point is consistent with zero when the computed value is within a small multiple of its own
//! rounding-error bound (running error analysis, [`eval_with_error`]), so ill-conditioned identities such
//! as log(1 + x^12) + log(1/(1 + x^12)) are not mistaken for nonzero.

use crate::func::Func;
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

/// Unit roundoff of f64.
const U: f64 = f64::EPSILON / 2.0;

/// A probe is taken as zero when |value| ≤ this multiple of its rounding-error bound.
pub const PROBE_SAFETY: f64 = 16.0;

/// Value and a bound on its rounding error, by running error analysis over the DAG (Higham, *Accuracy and
/// Stability of Numerical Algorithms*, 2nd ed., §3.3): inputs are exact, every operation adds one rounding
/// relative to its result, and errors propagate through the first-order sensitivity of each operation
/// (|∂f/∂a|·err(a)). `None` if a symbol has no value.
pub fn eval_with_error(pool: &Pool, e: Id, values: &HashMap<Symbol, f64>) -> Option<(f64, f64)> {
    let mut memo: crate::fxhash::FxHashMap<Id, (f64, f64)> = Default::default();
    for id in pool.topological(&[e]) {
        let ve = match pool.node(id) {
            Node::Num(n) => {
                let v = n.to_f64();
                (
                    v,
                    if n.as_integer().is_some_and(|i| i.abs() < 1 << 53) {
                        0.0
                    } else {
                        U * v.abs()
                    },
                )
            }
            Node::Pi => (std::f64::consts::PI, U * std::f64::consts::PI),
            Node::Sym(s) => (*values.get(s)?, 0.0),
            Node::Add(ts) => {
                let (mut v, mut err, mut mag) = (0.0, 0.0, 0.0);
                for t in ts.iter() {
                    let (tv, te) = memo[t];
                    v += tv;
                    err += te;
                    mag += tv.abs();
                }
                (v, err + ts.len() as f64 * U * mag)
            }
            Node::Mul(fs) => {
                let vals: Vec<(f64, f64)> = fs.iter().map(|f| memo[f]).collect();
                let v: f64 = vals.iter().map(|x| x.0).product();
                let mut err = 0.0;
                for (i, &(_, ei)) in vals.iter().enumerate() {
                    if ei > 0.0 {
                        let others: f64 = vals
                            .iter()
                            .enumerate()
                            .filter(|(j, _)| *j != i)
                            .map(|(_, x)| x.0.abs())
                            .product();
                        err += ei * others;
                    }
                }
                (v, err + fs.len() as f64 * U * v.abs())
            }
            Node::Pow(b, p) => {
                let ((bv, be), (pv, pe)) = (memo[b], memo[p]);
                let v = crate::number::pow_f64(bv, pool.as_number(*p), pv);
                let db = if bv != 0.0 { (pv * v / bv).abs() } else { 0.0 };
                let dp = if bv > 0.0 { (v * bv.ln()).abs() } else { 0.0 };
                (
                    v,
                    db * be + dp * pe + (2.0 + pv.abs().min(64.0)) * U * v.abs(),
                )
            }
            Node::Call(f, a) => {
                let (av, ae) = memo[a];
                let v = f.eval(av);
                let slope = match f {
                    Func::Exp => v.abs(),
                    Func::Log => 1.0 / av.abs(),
                    Func::Sin => av.cos().abs(),
                    Func::Cos => av.sin().abs(),
                    Func::Tan => 1.0 + v * v,
                    Func::Sinh => av.cosh(),
                    Func::Cosh => av.sinh().abs(),
                    Func::Tanh => 1.0 - v * v,
                    Func::Atan => 1.0 / (1.0 + av * av),
                    Func::Abs => 1.0,
                    Func::Sign => 0.0,
                };
                (v, slope * ae + 2.0 * U * v.abs())
            }
            Node::Call2(f, a, b) => {
                let ((av, ae), (bv, be)) = (memo[a], memo[b]);
                (f.eval(av, bv), ae.max(be))
            }
            // A map is probed through its generic surrogate, never its data (see `crate::map`).
            Node::Map(m, o, a) => map_with_error(pool, *m, *o, &[memo[a]]),
            Node::Map2(m, o, a, b) => map_with_error(pool, *m, *o, &[memo[a], memo[b]]),
        };
        memo.insert(id, ve);
    }
    memo.get(&e).copied()
}

/// A map call's surrogate value with its error bound: the arguments' errors through the slopes, and a few
/// roundings of the sines' arguments (`c·a` carries |c·a|·U).
fn map_with_error(
    pool: &Pool,
    m: crate::map::MapId,
    o: crate::map::MapOrders,
    args: &[(f64, f64)],
) -> (f64, f64) {
    let values: Vec<f64> = args.iter().map(|x| x.0).collect();
    let (v, slope) = pool.map_decl(m).surrogate(o, &values);
    let mut err = 4.0 * U * v.abs();
    for (k, &(av, ae)) in args.iter().enumerate() {
        err += slope[k] * (ae + 4.0 * U * (1.0 + av.abs()));
    }
    (v, err)
}

/// Is `e` identically zero? Symbols in `nominal` (parameters) are probed within ±20 % of their value,
/// every other symbol (states, inputs) uniformly in ±[0.2, 3].
pub fn zero_test(pool: &mut Pool, e: Id, nominal: &HashMap<Symbol, f64>) -> ZeroVerdict {
    if let Some(n) = pool.as_number(e) {
        return if n.is_zero() {
            ZeroVerdict::Zero(DecidedBy::Canonical)
        } else {
            ZeroVerdict::NonZero(DecidedBy::Canonical)
        };
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
        let Some((v, err)) = eval_with_error(pool, probe, &values) else {
            continue;
        };
        if !v.is_finite() || !err.is_finite() {
            continue;
        }
        finite_probes += 1;
        if v.abs() > PROBE_SAFETY * err {
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
        assert_eq!(
            zero_test(&mut p, e, &nominal),
            ZeroVerdict::Zero(DecidedBy::Canonical)
        );
        let e = p.parse("(x + 1)^2 - x^2 - 2*x - 1").unwrap();
        assert_eq!(
            zero_test(&mut p, e, &nominal),
            ZeroVerdict::Zero(DecidedBy::Expanded)
        );
        let e = p.parse("sin(x)^2 + cos(x)^2 - 1").unwrap();
        assert_eq!(
            zero_test(&mut p, e, &nominal),
            ZeroVerdict::Zero(DecidedBy::Probing)
        );
        let e = p.parse("sin(x)^2 + cos(x)^2 - 1.000001").unwrap();
        assert_eq!(
            zero_test(&mut p, e, &nominal),
            ZeroVerdict::NonZero(DecidedBy::Probing)
        );
        let e = p.parse("exp(log(x)) - x").unwrap();
        assert_eq!(
            zero_test(&mut p, e, &nominal),
            ZeroVerdict::Zero(DecidedBy::Canonical)
        );
    }
}
