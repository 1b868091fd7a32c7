//! Differentiation, substitution, expansion and reference evaluation on the DAG.
//!
//! Each traversal memoises per node, so shared subterms are visited once and results stay shared.

use crate::func::{Func, Func2};
use crate::fxhash::FxHashMap;
use crate::number::pow_f64;
use crate::number::Number;
use crate::pool::{Id, Node, Pool, Symbol};
use std::collections::HashMap;
use thiserror::Error;

/// Evaluation failed because a symbol had no value.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("no value for symbol `{0}`")]
pub struct UnboundSymbol(pub String);

/// Result of [`Pool::expand`] when the expansion would exceed its term limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error("expansion exceeds {0} terms")]
pub struct ExpansionTooLarge(pub usize);

/// Largest product (nodes written out) that [`Pool::tidy`] tries to distribute: it compares printed
/// lengths, so on larger ones it would spend its time printing.
const TIDY_MAX_WRITTEN: u64 = 10_000;

/// Deepest product that [`Pool::tidy`] tries to distribute (printing recurses).
const TIDY_MAX_DEPTH: u32 = 100;

/// Hard limit on the number of terms [`Pool::expand`] may produce.
pub const EXPAND_TERM_LIMIT: usize = 20_000;

impl Pool {
    /// d e / d x, by the rules of differential calculus applied node by node (chain rule):
    ///
    /// * (Σ uᵢ)' = Σ uᵢ',  (Π uᵢ)' = Σᵢ uᵢ' Πⱼ≠ᵢ uⱼ;
    /// * (u^c)' = c u^(c−1) u' for u-free c; (c^v)' = c^v log(c) v'; in general
    ///   (u^v)' = u^v (v' log u + v u'/u);
    /// * exp' = exp, log' = 1/u, sin' = cos, cos' = −sin, tan' = 1 + tan², sinh' = cosh, cosh' = sinh,
    ///   tanh' = 1 − tanh², atan' = 1/(1 + u²), abs' = sign, sign' = 0 (almost everywhere);
    /// * min(a, b) = (a + b − |a − b|)/2 and max(a, b) = (a + b + |a − b|)/2 differentiated as such;
    /// * a map call (contract §6): ∂/∂x M_dIJ(a, b) = M_d(I+1)J(a, b) ∂a/∂x + M_dI(J+1)(a, b) ∂b/∂x
    ///   (1-D: d/dx M_dK(a) = M_d(K+1)(a) a'), the derivative maps.
    pub fn diff(&mut self, e: Id, x: Symbol) -> Id {
        let mut memo = FxHashMap::default();
        for id in self.deep_order(e) {
            self.diff_memo(id, x, &mut memo);
        }
        self.diff_memo(e, x, &mut memo)
    }

    fn diff_memo(&mut self, e: Id, x: Symbol, memo: &mut FxHashMap<Id, Id>) -> Id {
        if !self.depends_on(e, x) {
            // d/dx of an undefined constant is undefined: 0·(1/0), never 0 (`crate::undefined`).
            let zero = self.zero();
            return if self.is_undefined(e) {
                self.mul(&[zero, e])
            } else {
                zero
            };
        }
        if let Some(&d) = memo.get(&e) {
            return d;
        }
        let d = match self.node(e).clone() {
            Node::Num(_) | Node::Pi => self.zero(),
            Node::Sym(s) => {
                if s == x {
                    self.one()
                } else {
                    self.zero()
                }
            }
            Node::Add(ts) => {
                let ds: Vec<Id> = ts.iter().map(|&t| self.diff_memo(t, x, memo)).collect();
                self.add(&ds)
            }
            Node::Mul(fs) => {
                let mut terms = Vec::with_capacity(fs.len());
                for i in 0..fs.len() {
                    if !self.depends_on(fs[i], x) {
                        continue;
                    }
                    let di = self.diff_memo(fs[i], x, memo);
                    let mut prod: Vec<Id> = Vec::with_capacity(fs.len());
                    prod.push(di);
                    prod.extend(
                        fs.iter()
                            .enumerate()
                            .filter(|(j, _)| *j != i)
                            .map(|(_, &f)| f),
                    );
                    terms.push(self.mul(&prod));
                }
                self.add(&terms)
            }
            Node::Pow(b, p) => {
                let db = self.diff_memo(b, x, memo);
                if !self.depends_on(p, x) {
                    // c u^(c−1) u'
                    let m1 = self.int(-1);
                    let pm1 = self.add(&[p, m1]);
                    let bp = self.pow(b, pm1);
                    self.mul(&[p, bp, db])
                } else {
                    let dp = self.diff_memo(p, x, memo);
                    let lb = self.call(Func::Log, b);
                    let t1 = self.mul(&[dp, lb]);
                    let rb = self.recip(b);
                    let t2 = self.mul(&[p, db, rb]);
                    let s = self.add(&[t1, t2]);
                    self.mul(&[e, s])
                }
            }
            Node::Call(f, a) => {
                let da = self.diff_memo(a, x, memo);
                let outer = match f {
                    Func::Exp => e,
                    Func::Log => self.recip(a),
                    Func::Sin => self.call(Func::Cos, a),
                    Func::Cos => {
                        let s = self.call(Func::Sin, a);
                        self.neg(s)
                    }
                    Func::Tan => {
                        let one = self.one();
                        let t2 = self.powi(e, 2);
                        self.add(&[one, t2])
                    }
                    Func::Sinh => self.call(Func::Cosh, a),
                    Func::Cosh => self.call(Func::Sinh, a),
                    Func::Tanh => {
                        let one = self.one();
                        let t2 = self.powi(e, 2);
                        let mt2 = self.neg(t2);
                        self.add(&[one, mt2])
                    }
                    Func::Atan => {
                        let one = self.one();
                        let a2 = self.powi(a, 2);
                        let s = self.add(&[one, a2]);
                        self.recip(s)
                    }
                    Func::Abs => self.call(Func::Sign, a),
                    Func::Sign => self.zero(),
                };
                self.mul(&[outer, da])
            }
            Node::Call2(f, a, b) => {
                let da = self.diff_memo(a, x, memo);
                let db = self.diff_memo(b, x, memo);
                let amb = self.sub(a, b);
                let sg = self.call(Func::Sign, amb);
                let dd = self.sub(da, db);
                let sdd = self.mul(&[sg, dd]);
                let s = self.add(&[da, db]);
                let half = self.rational(1, 2);
                let r = match f {
                    Func2::Min => self.sub(s, sdd),
                    Func2::Max => self.add(&[s, sdd]),
                };
                self.mul(&[half, r])
            }
            Node::Map(m, o, a) => {
                let da = self.diff_memo(a, x, memo);
                let outer = self.map_call(m, [o[0].saturating_add(1), 0], &[a]);
                self.mul(&[outer, da])
            }
            Node::Map2(m, o, a, b) => {
                let (da, db) = (self.diff_memo(a, x, memo), self.diff_memo(b, x, memo));
                let ma = self.map_call(m, [o[0].saturating_add(1), o[1]], &[a, b]);
                let mb = self.map_call(m, [o[0], o[1].saturating_add(1)], &[a, b]);
                let (ta, tb) = (self.mul(&[ma, da]), self.mul(&[mb, db]));
                self.add(&[ta, tb])
            }
        };
        memo.insert(e, d);
        d
    }

    /// Simultaneous substitution of symbols by expressions, rebuilt in canonical form.
    pub fn substitute(&mut self, e: Id, map: &HashMap<Symbol, Id>) -> Id {
        let keys: Vec<Symbol> = map.keys().copied().collect();
        let mut memo = FxHashMap::default();
        for id in self.deep_order(e) {
            self.subs_memo(id, map, &keys, &mut memo);
        }
        self.subs_memo(e, map, &keys, &mut memo)
    }

    fn subs_memo(
        &mut self,
        e: Id,
        map: &HashMap<Symbol, Id>,
        keys: &[Symbol],
        memo: &mut FxHashMap<Id, Id>,
    ) -> Id {
        if !self.depends_on_any(e, keys) {
            return e;
        }
        if let Some(&r) = memo.get(&e) {
            return r;
        }
        let node = self.node(e).clone();
        let r = match node {
            Node::Sym(s) => map.get(&s).copied().unwrap_or(e),
            _ => {
                let kids: Vec<Id> = self
                    .children(e)
                    .into_iter()
                    .map(|c| self.subs_memo(c, map, keys, memo))
                    .collect();
                self.rebuild(&node, &kids)
            }
        };
        memo.insert(e, r);
        r
    }

    /// Replace every occurrence of the subexpression `from` by `to`, rebuilt in canonical form.
    pub fn replace(&mut self, e: Id, from: Id, to: Id) -> Id {
        let mut memo = FxHashMap::default();
        for id in self.deep_order(e) {
            self.replace_memo(id, from, to, &mut memo);
        }
        self.replace_memo(e, from, to, &mut memo)
    }

    fn replace_memo(&mut self, e: Id, from: Id, to: Id, memo: &mut FxHashMap<Id, Id>) -> Id {
        if e == from {
            return to;
        }
        if let Some(&r) = memo.get(&e) {
            return r;
        }
        let node = self.node(e).clone();
        let kids = self.children(e);
        let r = if kids.is_empty() {
            e
        } else {
            let new: Vec<Id> = kids
                .iter()
                .map(|&c| self.replace_memo(c, from, to, memo))
                .collect();
            if new == kids {
                e
            } else {
                self.rebuild(&node, &new)
            }
        };
        memo.insert(e, r);
        r
    }

    /// The factors of a product as (base, numeric exponent); `None` if an exponent is symbolic.
    fn factor_powers(&self, e: Id) -> Option<Vec<(Id, Number)>> {
        let fs: Vec<Id> = match self.node(e) {
            Node::Mul(fs) => fs.to_vec(),
            _ => vec![e],
        };
        let mut out = Vec::with_capacity(fs.len());
        for f in fs {
            match self.node(f) {
                Node::Pow(b, p) => out.push((*b, self.as_number(*p)?)),
                Node::Num(_) => out.push((f, Number::ONE)),
                _ => out.push((f, Number::ONE)),
            }
        }
        Some(out)
    }

    /// Replace a product `target` by `to` wherever all of its factors occur inside a larger product:
    /// with target = N·M⁻¹, the product A·N·M⁻² becomes A·M⁻¹·to. A factor b^k of the target matches b^j
    /// in the product when k and j are integers of the same sign with |k| ≤ |j| (or k = j); a numeric
    /// coefficient of the target must divide the product's. Sums equal to `target` are replaced whole.
    pub fn replace_product(&mut self, e: Id, target: Id, to: Id) -> Id {
        let Some(tf) = self.factor_powers(target) else {
            return self.replace(e, target, to);
        };
        let mut memo = FxHashMap::default();
        for id in self.deep_order(e) {
            self.replace_product_memo(id, target, &tf, to, &mut memo);
        }
        self.replace_product_memo(e, target, &tf, to, &mut memo)
    }

    fn replace_product_memo(
        &mut self,
        e: Id,
        target: Id,
        tf: &[(Id, Number)],
        to: Id,
        memo: &mut FxHashMap<Id, Id>,
    ) -> Id {
        if e == target {
            return to;
        }
        if let Some(&r) = memo.get(&e) {
            return r;
        }
        let node = self.node(e).clone();
        let kids = self.children(e);
        let mut r = if kids.is_empty() {
            e
        } else {
            let new: Vec<Id> = kids
                .iter()
                .map(|&c| self.replace_product_memo(c, target, tf, to, memo))
                .collect();
            if new == kids {
                e
            } else {
                self.rebuild(&node, &new)
            }
        };
        if matches!(self.node(r), Node::Mul(_)) {
            if let Some(mut have) = self.factor_powers(r) {
                let mut ok = true;
                for &(b, k) in tf {
                    if let Node::Num(c) = self.node(b) {
                        // Numeric coefficient: divide it out.
                        let c = *c;
                        match have
                            .iter_mut()
                            .find(|(hb, _)| matches!(self.node(*hb), Node::Num(_)))
                        {
                            Some(entry) => {
                                let hc = self.as_number(entry.0).unwrap_or(Number::ONE);
                                let q = c.recip().map(|ci| hc.mul(ci)).unwrap_or(hc);
                                entry.0 = self.num(q);
                            }
                            None => {
                                let q = c.recip().unwrap_or(Number::ONE);
                                let qn = self.num(q);
                                have.push((qn, Number::ONE));
                            }
                        }
                        continue;
                    }
                    let Some(entry) = have.iter_mut().find(|(hb, _)| *hb == b) else {
                        ok = false;
                        break;
                    };
                    let j = entry.1;
                    let fits = k == j
                        || match (k.as_integer(), j.as_integer()) {
                            (Some(ki), Some(ji)) => {
                                ki.signum() == ji.signum() && ki.abs() <= ji.abs()
                            }
                            _ => false,
                        };
                    if !fits {
                        ok = false;
                        break;
                    }
                    entry.1 = j.add(k.neg());
                }
                if ok {
                    let mut parts: Vec<Id> = Vec::with_capacity(have.len() + 1);
                    for (b, k) in have {
                        let kk = self.num(k);
                        parts.push(self.pow(b, kk));
                    }
                    parts.push(to);
                    r = self.mul(&parts);
                }
            }
        }
        memo.insert(e, r);
        r
    }

    /// A size-reducing tidy-up: bottom-up, a product with a sum factor is distributed over that sum when
    /// the printed result is shorter (`J*(xi3 - X/J)/K → J*xi3/K - X/K`). Never grows an expression.
    pub fn tidy(&mut self, e: Id) -> Id {
        let mut memo = FxHashMap::default();
        for id in self.deep_order(e) {
            self.tidy_memo(id, &mut memo);
        }
        self.tidy_memo(e, &mut memo)
    }

    fn tidy_memo(&mut self, e: Id, memo: &mut FxHashMap<Id, Id>) -> Id {
        if let Some(&r) = memo.get(&e) {
            return r;
        }
        let node = self.node(e).clone();
        let kids = self.children(e);
        let mut r = if kids.is_empty() {
            e
        } else {
            let new: Vec<Id> = kids.iter().map(|&c| self.tidy_memo(c, memo)).collect();
            if new == kids {
                e
            } else {
                self.rebuild(&node, &new)
            }
        };
        // Only where printing is cheap: the comparison prints both forms.
        let printable = self.written_size(r) <= TIDY_MAX_WRITTEN && self.depth(r) <= TIDY_MAX_DEPTH;
        if let (Node::Mul(fs), true) = (self.node(r).clone(), printable) {
            let best = self.display(r).len();
            for (i, &f) in fs.iter().enumerate() {
                let Node::Add(ts) = self.node(f).clone() else {
                    continue;
                };
                let others: Vec<Id> = fs
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != i)
                    .map(|(_, &x)| x)
                    .collect();
                let terms: Vec<Id> = ts
                    .iter()
                    .map(|&t| {
                        let mut v = others.clone();
                        v.push(t);
                        self.mul(&v)
                    })
                    .collect();
                let cand = self.add(&terms);
                let size = self.display(cand).len();
                if size < best {
                    r = self.tidy_memo(cand, memo);
                    break;
                }
            }
        }
        memo.insert(e, r);
        r
    }

    /// Distribute products over sums and expand positive integer powers of sums (up to
    /// [`EXPAND_TERM_LIMIT`] terms). Function arguments are expanded too.
    pub fn expand(&mut self, e: Id) -> Result<Id, ExpansionTooLarge> {
        let mut memo = FxHashMap::default();
        for id in self.deep_order(e) {
            self.expand_memo(id, &mut memo)?;
        }
        self.expand_memo(e, &mut memo)
    }

    fn terms_of(&self, e: Id) -> Vec<Id> {
        match self.node(e) {
            Node::Add(ts) => ts.to_vec(),
            _ => vec![e],
        }
    }

    fn expand_product(&mut self, a: Id, b: Id) -> Result<Id, ExpansionTooLarge> {
        let (ta, tb) = (self.terms_of(a), self.terms_of(b));
        if ta.len() * tb.len() > EXPAND_TERM_LIMIT {
            return Err(ExpansionTooLarge(EXPAND_TERM_LIMIT));
        }
        let mut out = Vec::with_capacity(ta.len() * tb.len());
        for &x in &ta {
            for &y in &tb {
                out.push(self.mul(&[x, y]));
            }
        }
        Ok(self.add(&out))
    }

    fn expand_memo(
        &mut self,
        e: Id,
        memo: &mut FxHashMap<Id, Id>,
    ) -> Result<Id, ExpansionTooLarge> {
        if let Some(&r) = memo.get(&e) {
            return Ok(r);
        }
        let node = self.node(e).clone();
        let r = match node {
            Node::Num(_) | Node::Pi | Node::Sym(_) => e,
            Node::Add(ts) => {
                let mut out = Vec::with_capacity(ts.len());
                for &t in ts.iter() {
                    out.push(self.expand_memo(t, memo)?);
                }
                self.add(&out)
            }
            Node::Mul(fs) => {
                let mut acc = self.one();
                for &f in fs.iter() {
                    let ef = self.expand_memo(f, memo)?;
                    acc = self.expand_product(acc, ef)?;
                }
                acc
            }
            Node::Pow(b, p) => {
                let eb = self.expand_memo(b, memo)?;
                let ep = self.expand_memo(p, memo)?;
                match self.as_number(ep).and_then(|n| n.as_integer()) {
                    Some(k) if (2..=32).contains(&k) && matches!(self.node(eb), Node::Add(_)) => {
                        let mut acc = eb;
                        for _ in 1..k {
                            acc = self.expand_product(acc, eb)?;
                        }
                        acc
                    }
                    _ => self.pow(eb, ep),
                }
            }
            Node::Call(f, a) => {
                let ea = self.expand_memo(a, memo)?;
                self.call(f, ea)
            }
            Node::Call2(f, a, b) => {
                let (ea, eb) = (self.expand_memo(a, memo)?, self.expand_memo(b, memo)?);
                self.call2(f, ea, eb)
            }
            Node::Map(m, o, a) => {
                let ea = self.expand_memo(a, memo)?;
                self.map_call(m, o, &[ea])
            }
            Node::Map2(m, o, a, b) => {
                let (ea, eb) = (self.expand_memo(a, memo)?, self.expand_memo(b, memo)?);
                self.map_call(m, o, &[ea, eb])
            }
        };
        memo.insert(e, r);
        Ok(r)
    }

    /// Evaluate in f64 with `value(symbol)` giving every free symbol's value. A reference implementation
    /// (memoised recursion), independent of the [`crate::Tape`].
    pub fn eval_with(
        &self,
        e: Id,
        value: &dyn Fn(Symbol) -> Option<f64>,
    ) -> Result<f64, UnboundSymbol> {
        let mut memo: FxHashMap<Id, f64> = FxHashMap::default();
        for id in self.topological(&[e]) {
            let v = match self.node(id) {
                Node::Num(n) => n.to_f64(),
                Node::Pi => std::f64::consts::PI,
                Node::Sym(s) => {
                    value(*s).ok_or_else(|| UnboundSymbol(self.symbol_name(*s).to_string()))?
                }
                Node::Add(ts) => ts.iter().map(|t| memo[t]).sum(),
                Node::Mul(fs) => fs.iter().map(|f| memo[f]).product(),
                Node::Pow(b, p) => pow_f64(memo[b], self.as_number(*p), memo[p]),
                Node::Call(f, a) => f.eval(memo[a]),
                Node::Call2(f, a, b) => f.eval(memo[a], memo[b]),
                Node::Map(m, o, a) => self.map_decl(*m).data.partial(&[memo[a]], map_orders(*o)),
                Node::Map2(m, o, a, b) => self
                    .map_decl(*m)
                    .data
                    .partial(&[memo[a], memo[b]], map_orders(*o)),
            };
            memo.insert(id, v);
        }
        Ok(memo[&e])
    }

    /// Evaluate with symbol values from a map.
    pub fn eval(&self, e: Id, values: &HashMap<Symbol, f64>) -> Result<f64, UnboundSymbol> {
        self.eval_with(e, &|s| values.get(&s).copied())
    }
}

/// Derivative orders of a map call as the kernel's map takes them.
pub fn map_orders(o: crate::map::MapOrders) -> [usize; 2] {
    [o[0] as usize, o[1] as usize]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_of_known_functions() {
        let mut p = Pool::new();
        let x = p.symbol("x");
        for (f, d) in [
            ("x^3", "3*x^2"),
            ("sin(x)^2", "2*cos(x)*sin(x)"),
            ("exp(2*x)", "2*exp(2*x)"),
            ("log(x)", "1/x"),
            ("atan(x)", "1/(1 + x^2)"),
            ("x^1.8", "1.8*x^0.8"),
            ("a^x", "a^x*log(a)"),
        ] {
            let e = p.parse(f).unwrap();
            let de = p.diff(e, x);
            let want = p.parse(d).unwrap();
            assert_eq!(de, want, "d/dx {f} = {} (want {d})", p.display(de));
        }
    }

    #[test]
    fn expansion_cancels() {
        let mut p = Pool::new();
        let e = p.parse("(x + 1)^2 - x^2 - 2*x - 1").unwrap();
        assert!(!p.is_zero(e));
        let ex = p.expand(e).unwrap();
        assert!(p.is_zero(ex), "{}", p.display(ex));
    }

    #[test]
    fn substitution_is_simultaneous() {
        let mut p = Pool::new();
        let e = p.parse("x + 2*y").unwrap();
        let (x, y) = (p.symbol("x"), p.symbol("y"));
        let (sx, sy) = (p.var(x), p.var(y));
        let map = HashMap::from([(x, sy), (y, sx)]);
        let r = p.substitute(e, &map);
        assert_eq!(r, p.parse("y + 2*x").unwrap());
    }
}
