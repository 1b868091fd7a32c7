//! The lowering plan: expression DAGs as straight-line code, one SSA value per operation, shared by the
//! interpreter's tape ([`crate::Tape`] encodes it as instructions) and the code generator (which prints it).
//!
//! Sums become chains of `+`/`−` (negative coefficients as subtraction; leading negative terms subtracted from
//! the first positive one, an all-negative sum as −(t1 + t2 + …)), products coefficient · numerator /
//! denominator (negative exponents as division), integer powers `powi`, ½-powers `sqrt` and ¼- and ¾-powers
//! `sqrt(sqrt(b))` (`· sqrt(b)`) (times an integer power), and powers of one base whose exponents differ by an integer share one `powf` taken at the
//! *smallest* exponent (`v^1.8 = v^0.8 · v`, so nothing divides by a power that may be 0). Operations are
//! value-numbered: an operation on the same operands is one value. Together with the memo per DAG node this
//! is the common-subexpression elimination.
//!
//! The generated code makes three further choices, named in a [`Strategy`] so that nothing differs by
//! convention; the tape keeps them off ([`Strategy::TAPE`]) so that the interpreter's results are those it
//! always had, and the generated code turns them on ([`Strategy::GENERATED`]):
//!
//! * `hoist`: every operation whose operands depend only on parameters and constants goes to a separate
//!   *invariant* arena shared by all functions of a model, computed once per parameter set; to give it whole
//!   groups, the factors of a product and the terms of a sum are ordered parameter-only first (canonical
//!   order within each group): `V_d·i_t·s_i·ξ1·(…)/(4π·V_i·r_w)` becomes `k · ξ1 · (…)` with
//!   `k = V_d·i_t·s_i/(4π·V_i·r_w)`. Reordering changes rounding only at the level of single roundings of
//!   the terms involved.
//! * `shared_roots`: powers whose exponents are small multiples of a common g share one `powf(b, g)`
//!   (`b^0.1`, `b^0.9` → `r = b^0.1`, `r^9`).
//! * `fold_signs`: a sum whose terms all come out negative gives its sign to the product or sum around it
//!   (`k·(−a − b)` becomes `−k·(a + b)`).

use crate::calculus::UnboundSymbol;
use crate::func::{Func, Func2};
use crate::fxhash::{FxHashMap, FxHashSet};
use crate::map::MapId;
use crate::number::Number;
use crate::pool::{Id, Node, Pool, Symbol};
use std::cmp::Ordering;

/// An operand: a symbol, a constant, or the result of an operation in one of the two arenas.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Val {
    Sym(Symbol),
    Num(Number),
    Pi,
    /// Value `i` of the invariant (parameter-only) arena.
    Inv(usize),
    /// Value `i` of the current function's arena.
    Loc(usize),
}

/// One operation. `Powf` keeps the exact exponent.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum Op {
    Add(Val, Val),
    Sub(Val, Val),
    Mul(Val, Val),
    Div(Val, Val),
    Neg(Val),
    Recip(Val),
    Powi(Val, i32),
    Sqrt(Val),
    Powf(Val, Number),
    PowVar(Val, Val),
    Call(Func, Val),
    Call2(Func2, Val, Val),
    /// `M_dK(a)`: a 1-D map's K-th derivative (0: the map).
    Map1(MapId, u8, Val),
    /// `M_dIJ(a, b)`: a 2-D map's partial derivative of orders `[I, J]`.
    Map2(MapId, [u8; 2], Val, Val),
}

/// The operands of one operation (at most three), without allocation.
#[derive(Clone, Copy, Debug)]
pub struct Operands {
    vals: [Val; 3],
    len: usize,
}

impl Operands {
    fn of(vals: &[Val]) -> Operands {
        let mut o = Operands {
            vals: [Val::Pi; 3],
            len: vals.len(),
        };
        o.vals[..vals.len()].copy_from_slice(vals);
        o
    }
}

impl IntoIterator for Operands {
    type Item = Val;
    type IntoIter = std::iter::Take<std::array::IntoIter<Val, 3>>;
    fn into_iter(self) -> Self::IntoIter {
        self.vals.into_iter().take(self.len)
    }
}

impl Op {
    /// Operands, with multiplicity as straight-line code uses them (`Powi(v, 2)` is the product `v * v`,
    /// which uses `v` twice; `Powi(v, 3)` three times).
    pub fn operands(&self) -> Operands {
        match *self {
            Op::Add(a, b)
            | Op::Sub(a, b)
            | Op::Mul(a, b)
            | Op::Div(a, b)
            | Op::PowVar(a, b)
            | Op::Map2(_, _, a, b)
            | Op::Call2(_, a, b) => Operands::of(&[a, b]),
            Op::Powi(a, 2) => Operands::of(&[a, a]),
            Op::Powi(a, 3) => Operands::of(&[a, a, a]),
            Op::Neg(a)
            | Op::Recip(a)
            | Op::Powi(a, _)
            | Op::Sqrt(a)
            | Op::Powf(a, _)
            | Op::Map1(_, _, a)
            | Op::Call(_, a) => Operands::of(&[a]),
        }
    }
}

/// A value-numbered list of operations.
#[derive(Default, Debug, Clone)]
pub struct Arena {
    ops: Vec<Op>,
    index: FxHashMap<Op, usize>,
}

impl Arena {
    /// The operations in order; each refers only to earlier ones (of this arena or the invariant one).
    pub fn ops(&self) -> &[Op] {
        &self.ops
    }

    fn push(&mut self, op: Op) -> usize {
        let next = self.ops.len();
        let i = *self.index.entry(op).or_insert(next);
        if i == next {
            self.ops.push(op);
        }
        i
    }
}

/// A symbol the lowering may meet: a parameter (invariant) or a per-point input.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum SymKind {
    Param,
    Varying,
}

/// The choices in which the lowering for generated code differs from the tape's (see the module docs).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct Strategy {
    /// Parameter-only operations go to the invariant arena; parameter-only terms and factors come first.
    pub hoist: bool,
    /// Powers of one base with exponents that are small multiples of a common g share one `powf(b, g)`.
    pub shared_roots: bool,
    /// An all-negative sum gives its sign to the product or sum around it.
    pub fold_signs: bool,
}

impl Strategy {
    /// The interpreter's tape: none of the three.
    pub const TAPE: Strategy = Strategy {
        hoist: false,
        shared_roots: false,
        fold_signs: false,
    };
    /// Generated Rust code: all three.
    pub const GENERATED: Strategy = Strategy {
        hoist: true,
        shared_roots: true,
        fold_signs: true,
    };
}

/// The invariant arena and the classification of symbols, shared by all functions of a model.
pub struct Invariants<'p> {
    pool: &'p Pool,
    params: FxHashMap<Symbol, usize>,
    arena: Arena,
    strategy: Strategy,
}

impl<'p> Invariants<'p> {
    /// An empty invariant arena for the functions of one model over `pool`, with parameters `params`.
    pub fn new(pool: &'p Pool, params: &[Symbol], strategy: Strategy) -> Invariants<'p> {
        Invariants {
            pool,
            params: params.iter().enumerate().map(|(i, &s)| (s, i)).collect(),
            arena: Arena::default(),
            strategy,
        }
    }

    /// The parameter-only operations of every function lowered so far.
    pub fn arena(&self) -> &Arena {
        &self.arena
    }

    /// Is `s` one of the parameters?
    pub fn is_param(&self, s: Symbol) -> bool {
        self.params.contains_key(&s)
    }

    /// Is `v` computable from parameters and constants alone?
    pub fn is_invariant(&self, v: Val) -> bool {
        match v {
            Val::Sym(s) => self.params.contains_key(&s),
            Val::Num(_) | Val::Pi | Val::Inv(_) => true,
            Val::Loc(_) => false,
        }
    }

    /// 1/v for an invariant `v`, as an invariant value.
    pub fn recip(&mut self, v: Val) -> Val {
        Val::Inv(self.arena.push(Op::Recip(v)))
    }
}

/// One function's lowering: its arena and the values of its roots (operations of either arena, symbols or
/// constants).
#[derive(Debug, Clone)]
pub struct Lowered {
    pub arena: Arena,
    pub roots: Vec<Val>,
}

struct FnLowering<'a, 'p> {
    inv: &'a mut Invariants<'p>,
    inputs: &'a FxHashSet<Symbol>,
    arena: Arena,
    memo: FxHashMap<Id, Val>,
    /// Sums as (negative?, magnitude), see `lower_sum`.
    signed_memo: FxHashMap<Id, (bool, Val)>,
    /// (base, fractional part of the exponent) → smallest exponent with that fractional part.
    min_power: FxHashMap<(Id, Number), Number>,
    /// (base, group root q) → (g, m) with q = m·g, when one `powf(b, g)` serves several groups: see
    /// [`shared_roots`].
    shared_root: FxHashMap<(Id, Number), (Number, i32)>,
}

/// Largest power of a shared root taken by multiplication (`r.powi(m)`).
const MAX_ROOT_MULTIPLE: i128 = 16;

fn gcd(a: i128, b: i128) -> i128 {
    let (mut a, mut b) = (a.abs(), b.abs());
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// The greatest common divisor of two positive exact rationals, if it is computable without overflow.
fn rational_gcd(a: Number, b: Number) -> Option<Number> {
    let (Number::Rational(n1, d1), Number::Rational(n2, d2)) = (a, b) else {
        return None;
    };
    let num = gcd(n1.checked_mul(d2)?, n2.checked_mul(d1)?);
    Some(Number::ratio(num, d1.checked_mul(d2)?))
}

/// Powers of one base whose exponents are small multiples of a common g share one `powf(b, g)`:
/// `b^0.1` and `b^0.9` become `r = b^0.1` and `r^9`, one `powf` instead of two. (Groups whose exponents differ by
/// an integer already share one; this joins groups with different fractional parts.) `r^m` is exact at b = 0
/// and costs a few multiplications; its relative error is about m ulp.
fn shared_roots(
    min_power: &FxHashMap<(Id, Number), Number>,
) -> FxHashMap<(Id, Number), (Number, i32)> {
    let mut by_base: FxHashMap<Id, Vec<Number>> = FxHashMap::default();
    for (&(b, frac), &q) in min_power {
        if root_quarters(frac).is_none() {
            by_base.entry(b).or_default().push(q);
        }
    }
    let mut out = FxHashMap::default();
    for (b, mut qs) in by_base {
        if qs.len() < 2 {
            continue;
        }
        qs.sort_by(|x, y| x.cmp_value(y));
        let Some(g) = qs[1..].iter().try_fold(qs[0], |g, &q| rational_gcd(g, q)) else {
            continue;
        };
        let multiples: Option<Vec<i32>> = qs
            .iter()
            .map(|&q| {
                let m = q.mul(g.recip()?).as_integer()?;
                (1..=MAX_ROOT_MULTIPLE).contains(&m).then_some(m as i32)
            })
            .collect();
        if let Some(ms) = multiples {
            for (q, m) in qs.into_iter().zip(ms) {
                out.insert((b, q), (g, m));
            }
        }
    }
    out
}

/// The fractional parts taken by square roots instead of `powf`, as quarters: ½ = `sqrt(b)` (2), ¼ =
/// `sqrt(sqrt(b))` (1), ¾ = `sqrt(b)·sqrt(sqrt(b))` (3). Each `sqrt` is correctly rounded, so the result is
/// within about 1 ulp of `b^k` as `powf` gives it (at b = −0 it is −0 where `powf` gives +0) at a few
/// cycles instead of a library call.
fn root_quarters(frac: Number) -> Option<u8> {
    [1, 2, 3]
        .into_iter()
        .find(|&q| frac == Number::ratio(i128::from(q), 4))
}

/// (base, fractional part of the exponent) → the smallest |exponent| with that fractional part, over the
/// non-integer numeric powers below `roots` (a plain depth-first visit: the result does not depend on order).
fn min_powers(pool: &Pool, roots: &[Id]) -> FxHashMap<(Id, Number), Number> {
    let mut out: FxHashMap<(Id, Number), Number> = FxHashMap::default();
    let mut seen: FxHashSet<Id> = FxHashSet::default();
    let mut stack: Vec<Id> = roots.to_vec();
    while let Some(id) = stack.pop() {
        if !seen.insert(id) {
            continue;
        }
        pool.for_each_child(id, |c| stack.push(c));
        let Node::Pow(base, p) = pool.node(id) else {
            continue;
        };
        let Some(k) = pool.as_number(*p) else {
            continue;
        };
        let k = if k.is_negative() { k.neg() } else { k };
        if k.as_integer().is_some() {
            continue;
        }
        let frac = k.add(Number::from_f64(-k.to_f64().floor()));
        let e = out.entry((*base, frac)).or_insert(k);
        if k.cmp_value(e) == Ordering::Less {
            *e = k;
        }
    }
    out
}

/// Lower `roots`, whose free symbols must be parameters of `inv` or `inputs`; parameter-only operations go
/// to `inv`'s arena when its strategy hoists them.
pub fn lower(
    inv: &mut Invariants<'_>,
    roots: &[Id],
    inputs: &[Symbol],
) -> Result<Lowered, UnboundSymbol> {
    let input_set: FxHashSet<Symbol> = inputs.iter().copied().collect();
    let pool = inv.pool;
    let mut l = FnLowering {
        inv,
        inputs: &input_set,
        arena: Arena::default(),
        memo: FxHashMap::default(),
        signed_memo: FxHashMap::default(),
        min_power: FxHashMap::default(),
        shared_root: FxHashMap::default(),
    };
    l.min_power = min_powers(pool, roots);
    if l.inv.strategy.shared_roots {
        l.shared_root = shared_roots(&l.min_power);
    }
    if roots
        .iter()
        .any(|&r| pool.depth(r) > crate::limits::ITERATIVE_DEPTH)
    {
        l.lower_bottom_up(roots)?;
    }
    let mut out = Vec::with_capacity(roots.len());
    for &r in roots {
        out.push(l.lower(r)?);
    }
    Ok(Lowered {
        arena: l.arena,
        roots: out,
    })
}

impl<'p> FnLowering<'_, 'p> {
    fn pool(&self) -> &'p Pool {
        self.inv.pool
    }

    fn kind(&self, s: Symbol) -> Option<SymKind> {
        if self.inputs.contains(&s) {
            Some(SymKind::Varying)
        } else if self.inv.params.contains_key(&s) {
            Some(SymKind::Param)
        } else {
            None
        }
    }

    /// For deep expressions: lower every node that the recursion lowers as a whole (calls, and sums when
    /// signs are not folded) bottom-up first, so that the recursion below finds them memoised and stays
    /// shallow. Only the order of the operations differs from the recursive lowering (which shallow
    /// expressions keep, so that the generated code and the tape stay as they were).
    fn lower_bottom_up(&mut self, roots: &[Id]) -> Result<(), UnboundSymbol> {
        let pool = self.pool();
        for id in pool.topological(roots) {
            let whole = match pool.node(id) {
                Node::Call(..) | Node::Call2(..) | Node::Map(..) | Node::Map2(..) => true,
                Node::Add(_) => !self.inv.strategy.fold_signs,
                _ => false,
            };
            if whole {
                self.lower(id)?;
            }
        }
        Ok(())
    }

    /// Emit `op` into the invariant arena when all its operands are invariant, else into this function's.
    fn emit(&mut self, op: Op) -> Val {
        // A map call is never hoisted: its data may be replaced at run time, apart from the parameters.
        let is_map = matches!(op, Op::Map1(..) | Op::Map2(..));
        if !is_map && op.operands().into_iter().all(|v| self.hoisted(v)) {
            Val::Inv(self.inv.arena.push(op))
        } else {
            Val::Loc(self.arena.push(op))
        }
    }

    /// Does `v` belong to the parameter-only group (always false without hoisting)?
    fn hoisted(&self, v: Val) -> bool {
        self.inv.strategy.hoist && self.is_param(v)
    }

    fn is_param(&self, v: Val) -> bool {
        match v {
            Val::Sym(s) => self.kind(s) == Some(SymKind::Param),
            Val::Num(_) | Val::Pi | Val::Inv(_) => true,
            Val::Loc(_) => false,
        }
    }

    fn lower(&mut self, e: Id) -> Result<Val, UnboundSymbol> {
        if let Some(&v) = self.memo.get(&e) {
            return Ok(v);
        }
        let v = match *self.pool().node(e) {
            Node::Num(n) => Val::Num(n),
            Node::Pi => Val::Pi,
            Node::Sym(s) => {
                if self.kind(s).is_none() {
                    return Err(UnboundSymbol(self.pool().symbol_name(s).to_string()));
                }
                Val::Sym(s)
            }
            Node::Add(_) => {
                let (neg, v) = self.lower_sum(e)?;
                if neg {
                    self.emit(Op::Neg(v))
                } else {
                    v
                }
            }
            Node::Mul(_) | Node::Pow(..) => {
                let (neg, v) = self.lower_product(e, false)?;
                if neg {
                    self.emit(Op::Neg(v))
                } else {
                    v
                }
            }
            Node::Call(f, a) => {
                let a = self.lower(a)?;
                self.emit(Op::Call(f, a))
            }
            Node::Call2(f, a, b) => {
                let (a, b) = (self.lower(a)?, self.lower(b)?);
                self.emit(Op::Call2(f, a, b))
            }
            Node::Map(m, o, a) => {
                let a = self.lower(a)?;
                self.emit(Op::Map1(m, o[0], a))
            }
            Node::Map2(m, o, a, b) => {
                let (a, b) = (self.lower(a)?, self.lower(b)?);
                self.emit(Op::Map2(m, o, a, b))
            }
        };
        self.memo.insert(e, v);
        Ok(v)
    }

    /// A sum as (negative?, magnitude): when every term comes out negative, −(|t1| + |t2| + …) is returned as
    /// the sum of the magnitudes with the sign separate, so that a product or a sum around it can absorb
    /// the sign (`k·(−a − b)` becomes `−k·(a + b)`).
    fn lower_sum(&mut self, e: Id) -> Result<(bool, Val), UnboundSymbol> {
        if let Some(&r) = self.signed_memo.get(&e) {
            return Ok(r);
        }
        let one = [e];
        let ts: &[Id] = match self.pool().node(e) {
            Node::Add(ts) => ts,
            _ => &one,
        };
        let mut terms = Vec::with_capacity(ts.len());
        for &t in ts {
            terms.push(self.lower_signed(t)?);
        }
        let all_negative = terms.iter().all(|&(neg, _)| neg);
        if all_negative {
            for t in terms.iter_mut() {
                t.0 = false;
            }
        }
        // Parameter-only terms first, so that their partial sum is hoisted.
        if self.inv.strategy.hoist {
            // A stable sort: the order within each group is kept.
            terms.sort_by_key(|&(_, v)| !self.hoisted(v));
        }
        let r = (all_negative, self.sum(&terms));
        self.signed_memo.insert(e, r);
        Ok(r)
    }

    /// Σ ±t as a chain of additions and subtractions, left to right; leading negative terms are subtracted
    /// from the first positive one, and an all-negative sum is −(t1 + t2 + …).
    fn sum(&mut self, terms: &[(bool, Val)]) -> Val {
        let mut acc: Option<Val> = None;
        let mut negs: Vec<Val> = Vec::new();
        for &(neg, v) in terms {
            if neg {
                match acc {
                    Some(a) => acc = Some(self.emit(Op::Sub(a, v))),
                    None => negs.push(v),
                }
            } else {
                let mut a = match acc {
                    Some(a) => self.emit(Op::Add(a, v)),
                    None => v,
                };
                for n in std::mem::take(&mut negs) {
                    a = self.emit(Op::Sub(a, n));
                }
                acc = Some(a);
            }
        }
        match acc {
            Some(a) => a,
            None => {
                let mut s = negs[0];
                for &n in &negs[1..] {
                    s = self.emit(Op::Add(s, n));
                }
                self.emit(Op::Neg(s))
            }
        }
    }

    /// A sum's term as (negative?, magnitude).
    fn lower_signed(&mut self, t: Id) -> Result<(bool, Val), UnboundSymbol> {
        match self.pool().node(t) {
            Node::Num(n) if n.is_negative() => Ok((true, Val::Num(n.neg()))),
            Node::Mul(_) => self.lower_product(t, true),
            Node::Add(_) if self.inv.strategy.fold_signs => self.lower_sum(t),
            _ => Ok((false, self.lower(t)?)),
        }
    }

    /// A product (or a lone power) as coefficient · numerator / denominator, parameter-only factors first:
    /// `(c · n_inv / d_inv) · n_var / d_var`. With `split_sign`, a negative coefficient is returned as a flag.
    fn lower_product(&mut self, e: Id, split_sign: bool) -> Result<(bool, Val), UnboundSymbol> {
        if !split_sign {
            if let Some(&v) = self.memo.get(&e) {
                return Ok((false, v));
            }
        }
        let one = [e];
        let factors: &[Id] = match self.pool().node(e) {
            Node::Mul(fs) => fs,
            _ => &one,
        };
        let mut coeff = Number::ONE;
        let mut num: Vec<Val> = Vec::new();
        let mut den: Vec<Val> = Vec::new();
        for &f in factors {
            match *self.pool().node(f) {
                Node::Num(n) => coeff = coeff.mul(n),
                Node::Pow(b, p) => match self.pool().as_number(p) {
                    Some(k) if k.is_negative() => {
                        let v = self.lower_power(b, k.neg())?;
                        den.push(v)
                    }
                    Some(k) => {
                        let v = self.lower_power(b, k)?;
                        num.push(v)
                    }
                    None => {
                        let (vb, vp) = (self.lower(b)?, self.lower(p)?);
                        let v = self.emit(Op::PowVar(vb, vp));
                        num.push(v)
                    }
                },
                Node::Add(_) if self.inv.strategy.fold_signs => {
                    // A sum that came out negative gives its sign to the coefficient.
                    let (neg, v) = self.lower_sum(f)?;
                    if neg {
                        coeff = coeff.neg();
                    }
                    num.push(v)
                }
                _ => {
                    let v = self.lower(f)?;
                    num.push(v)
                }
            }
        }
        let (num_inv, num_var): (Vec<Val>, Vec<Val>) = num.iter().partition(|&&v| self.hoisted(v));
        let (den_inv, den_var): (Vec<Val>, Vec<Val>) = den.iter().partition(|&&v| self.hoisted(v));
        let negative = coeff.is_negative();
        let mag = if negative { coeff.neg() } else { coeff };
        let sign_applied = negative && !split_sign;
        let mut acc: Option<Val> = None;
        if !mag.is_one() || (num.is_empty() && !sign_applied) {
            acc = Some(Val::Num(if sign_applied { mag.neg() } else { mag }));
        } else if sign_applied && num.is_empty() {
            acc = Some(Val::Num(Number::MINUS_ONE));
        }
        let applied = !mag.is_one() || num.is_empty();
        for group in [(num_inv, den_inv), (num_var, den_var)] {
            for v in group.0 {
                acc = Some(match acc {
                    Some(a) => self.emit(Op::Mul(a, v)),
                    None => v,
                });
            }
            if let Some((&first, others)) = group.1.split_first() {
                let mut d = first;
                for &v in others {
                    d = self.emit(Op::Mul(d, v));
                }
                acc = Some(match acc {
                    Some(a) => self.emit(Op::Div(a, d)),
                    None => self.emit(Op::Recip(d)),
                });
            }
        }
        let mut v = acc.unwrap_or(Val::Num(Number::ONE));
        if sign_applied && !applied {
            v = self.emit(Op::Neg(v));
        }
        if !split_sign {
            self.memo.insert(e, v);
        }
        Ok((negative && split_sign, v))
    }

    /// s · b^j for an exact j ≥ 0.
    fn times_integer_power(&mut self, s: Val, vb: Val, j: Number) -> Val {
        match j.as_integer() {
            Some(0) => s,
            Some(1) => self.emit(Op::Mul(s, vb)),
            Some(i) if i > 0 && i <= i32::MAX as i128 => {
                let p = self.emit(Op::Powi(vb, i as i32));
                self.emit(Op::Mul(s, p))
            }
            _ => {
                let p = self.emit(Op::Powf(vb, j));
                self.emit(Op::Mul(s, p))
            }
        }
    }

    /// b^k for k > 0: `powi`, square roots for the quarters ([`root_quarters`], times an integer power), or
    /// one shared `powf` per base and fractional part of the exponent, taken at the smallest such exponent.
    fn lower_power(&mut self, b: Id, k: Number) -> Result<Val, UnboundSymbol> {
        let vb = self.lower(b)?;
        if let Some(i) = k.as_integer().filter(|i| *i <= i32::MAX as i128) {
            return Ok(if i == 1 {
                vb
            } else {
                self.emit(Op::Powi(vb, i as i32))
            });
        }
        let m = k.to_f64().floor();
        let frac = k.add(Number::from_f64(-m));
        if let Some(quarters) = root_quarters(frac) {
            let half = self.emit(Op::Sqrt(vb));
            let root = match quarters {
                2 => half,
                1 => self.emit(Op::Sqrt(half)),
                _ => {
                    let quarter = self.emit(Op::Sqrt(half));
                    self.emit(Op::Mul(half, quarter))
                }
            };
            return Ok(match m as i32 {
                0 => root,
                1 => self.emit(Op::Mul(root, vb)),
                mi => {
                    let p = self.emit(Op::Powi(vb, mi));
                    self.emit(Op::Mul(root, p))
                }
            });
        }
        let q = self.min_power.get(&(b, frac)).copied().unwrap_or(k);
        let s = match self.shared_root.get(&(b, q)).copied() {
            Some((g, m)) => {
                let r = self.emit(Op::Powf(vb, g));
                if m == 1 {
                    r
                } else {
                    self.emit(Op::Powi(r, m))
                }
            }
            None => self.emit(Op::Powf(vb, q)),
        };
        Ok(self.times_integer_power(s, vb, k.add(q.neg())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lower_src(src: &[&str], params: &[&str], inputs: &[&str]) -> (usize, usize) {
        let mut pool = Pool::new();
        let roots: Vec<Id> = src.iter().map(|s| pool.parse(s).unwrap()).collect();
        let ps: Vec<Symbol> = params.iter().map(|n| pool.symbol(n)).collect();
        let is: Vec<Symbol> = inputs.iter().map(|n| pool.symbol(n)).collect();
        let mut inv = Invariants::new(&pool, &ps, Strategy::GENERATED);
        let l = lower(&mut inv, &roots, &is).unwrap();
        (inv.arena().ops().len(), l.arena.ops().len())
    }

    #[test]
    fn parameter_groups_are_hoisted() {
        // a*b*x/(c*d): a*b/(c*d) is invariant (3 ops), then one multiplication per point.
        let (inv, loc) = lower_src(&["a*b*x/(c*d)"], &["a", "b", "c", "d"], &["x"]);
        assert_eq!((inv, loc), (3, 1));
        // a + b - x + c: (a + b + c) - x.
        let (inv, loc) = lower_src(&["a + b - x + c"], &["a", "b", "c"], &["x"]);
        assert_eq!((inv, loc), (2, 1));
    }

    #[test]
    fn the_tape_strategy_hoists_nothing_and_keeps_canonical_order() {
        let mut pool = Pool::new();
        let e = pool.parse("a*b*x/(c*d)").unwrap();
        let w = pool.parse("v^0.1 + v^0.9").unwrap();
        let ps: Vec<Symbol> = ["a", "b", "c", "d"]
            .iter()
            .map(|n| pool.symbol(n))
            .collect();
        let (x, v) = (pool.symbol("x"), pool.symbol("v"));
        let mut inv = Invariants::new(&pool, &ps, Strategy::TAPE);
        let l = lower(&mut inv, &[e, w], &[x, v]).unwrap();
        assert!(inv.arena().ops().is_empty());
        // a·b·x first (canonical order), then the division by c·d.
        let ops = l.arena.ops();
        let (a, b) = (Val::Sym(ps[0]), Val::Sym(ps[1]));
        assert_eq!(ops[0], Op::Mul(a, b));
        assert_eq!(ops[1], Op::Mul(Val::Loc(0), Val::Sym(x)));
        // Two powf: no shared root without the strategy.
        let powf = ops.iter().filter(|o| matches!(o, Op::Powf(..))).count();
        assert_eq!(powf, 2);
    }

    #[test]
    fn powers_share_one_powf() {
        let mut pool = Pool::new();
        let e = pool.parse("v^1.8 + v^0.8 + sqrt(v)*v").unwrap();
        let v = pool.symbol("v");
        let mut inv = Invariants::new(&pool, &[], Strategy::GENERATED);
        let l = lower(&mut inv, &[e], &[v]).unwrap();
        let powf: Vec<&Op> = l
            .arena
            .ops()
            .iter()
            .filter(|o| matches!(o, Op::Powf(..)))
            .collect();
        assert_eq!(powf, vec![&Op::Powf(Val::Sym(v), Number::ratio(4, 5))]);
    }

    #[test]
    fn exponents_with_a_common_divisor_share_one_powf() {
        let mut pool = Pool::new();
        let e = pool.parse("v^0.9 + 1/v^0.1 + v^1.9").unwrap();
        let v = pool.symbol("v");
        let mut inv = Invariants::new(&pool, &[], Strategy::GENERATED);
        let l = lower(&mut inv, &[e], &[v]).unwrap();
        let powf: Vec<&Op> = l
            .arena
            .ops()
            .iter()
            .filter(|o| matches!(o, Op::Powf(..)))
            .collect();
        assert_eq!(powf, vec![&Op::Powf(Val::Sym(v), Number::ratio(1, 10))]);
        assert!(l.arena.ops().iter().any(|o| matches!(o, Op::Powi(_, 9))));
        // 0.3 and 0.7: gcd 0.1, multiples 3 and 7.
        assert_eq!(
            rational_gcd(Number::ratio(3, 10), Number::ratio(7, 10)),
            Some(Number::ratio(1, 10))
        );
    }

    /// Quarter powers (and their integer multiples, and negative ones as division) take square roots, no
    /// `powf`, and agree with `powf` within 2 ulp over decades of the base.
    #[test]
    fn quarter_powers_take_square_roots() {
        let mut pool = Pool::new();
        let src = [
            "v^0.25",
            "v^0.75",
            "v^1.75",
            "(1 + v^4)^0.25",
            "1/v^2.25",
            "v^0.5",
        ];
        let roots: Vec<Id> = src.iter().map(|s| pool.parse(s).unwrap()).collect();
        let v = pool.symbol("v");
        let mut inv = Invariants::new(&pool, &[], Strategy::GENERATED);
        let l = lower(&mut inv, &roots, &[v]).unwrap();
        assert!(!l.arena.ops().iter().any(|o| matches!(o, Op::Powf(..))));
        let tape = crate::Tape::compile(&pool, &roots, &[v]).unwrap();
        let exact = |x: f64| {
            [
                x.powf(0.25),
                x.powf(0.75),
                x.powf(1.75),
                (1.0 + x.powi(4)).powf(0.25),
                1.0 / x.powf(2.25),
                x.sqrt(),
            ]
        };
        let mut out = vec![0.0; src.len()];
        for x in [1e-100, 3e-7, 0.37, 1.0, 2.0, 7.5, 813.0, 4.1e12] {
            tape.eval(&[x], &mut out);
            for ((got, want), s) in out.iter().zip(exact(x)).zip(src) {
                let ulp = (want.next_up() - want).abs();
                assert!(
                    (got - want).abs() <= 2.0 * ulp,
                    "{s} at {x}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn unbound_symbols_are_reported() {
        let mut pool = Pool::new();
        let e = pool.parse("x + y").unwrap();
        let x = pool.symbol("x");
        let mut inv = Invariants::new(&pool, &[], Strategy::GENERATED);
        assert_eq!(
            lower(&mut inv, &[e], &[x]).err(),
            Some(UnboundSymbol("y".into()))
        );
    }
}
