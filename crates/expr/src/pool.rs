//! The hash-consed expression DAG and its canonicalising constructors.
//!
//! Every expression lives in a [`Pool`] as an interned [`Node`]; an [`Id`] names it. Structurally equal
//! expressions get the same `Id` (O(1) equality), and shared subterms are stored once. Construction goes
//! through canonicalising constructors (`add`, `mul`, `pow`, `call`) in the style of Cohen's *automatic
//! simplification* (Cohen, *Computer Algebra and Symbolic Computation: Mathematical Methods*, 2003, ch. 3):
//!
//! * sums and products are flattened and sorted, with at most one numeric term / coefficient (exact rationals);
//! * like terms are merged (`2x + 3x → 5x`) and like powers combined (`x·x → x^2`, `x^a·x^b → x^(a+b)`);
//! * identities: `x + 0`, `1·x`, `0·x`, `x^0`, `x^1`, `1^x`, `(x^a)^n → x^(a·n)` for integer n,
//!   `(x·y)^n → x^n·y^n` for integer n, numeric coefficients distributed over sums (`2(x+y) → 2x + 2y`);
//! * the function identities in [`crate::rules::FUNCTION_RULES`] (kept as data, applied by [`Pool::call`]).
//!
//! No identity removes an undefined part (see [`crate::undefined`]): a node free of symbols whose value is
//! not finite (`1/0`, `log(0)`, `sqrt(-1)`, an overflow), or any node above one, is *undefined*, and the
//! constructors leave it in place: `0·(1/0)` stays a product, `(v − v)/(v − v)` becomes `0·(1/0)` (0/0),
//! never 0. Every identity above holds only where both sides are defined.
//!
//! Nothing here expands products of sums, so expressions never blow up; see [`Pool::expand`] for that.

use crate::func::{Func, Func2};
use crate::fxhash::{FxHashMap, FxHashSet};
use crate::map::{MapDecl, MapId, MapOrders};
use crate::number::{pow_f64, Number};
use crate::rules::{FunctionRule, Rewrite, FUNCTION_RULES};
use std::cmp::Ordering;
use std::collections::HashMap;

fn gcd_i128(mut a: i128, mut b: i128) -> i128 {
    a = a.abs();
    b = b.abs();
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    a
}

/// Handle of an interned expression in a [`Pool`].
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, PartialOrd, Ord)]
pub struct Id(pub(crate) u32);

impl Id {
    /// Position of the node in the pool (creation order).
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// Handle of an interned symbol name.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug, PartialOrd, Ord)]
pub struct Symbol(pub(crate) u32);

/// One node of the DAG. Children are [`Id`]s into the same pool.
#[derive(Clone, PartialEq, Eq, Hash, Debug)]
pub enum Node {
    Num(Number),
    /// The constant π.
    Pi,
    Sym(Symbol),
    /// n-ary sum, n ≥ 2, canonical order, numeric term (if any) first.
    Add(Box<[Id]>),
    /// n-ary product, n ≥ 2, canonical order, numeric coefficient (if any) first.
    Mul(Box<[Id]>),
    Pow(Id, Id),
    Call(Func, Id),
    Call2(Func2, Id, Id),
    /// A 1-D map call `M_dK(a)` (orders `[K, 0]`; see [`crate::map`]).
    Map(MapId, MapOrders, Id),
    /// A 2-D map call `M_dIJ(a, b)` (orders `[I, J]`).
    Map2(MapId, MapOrders, Id, Id),
}

/// An arena of interned expressions and symbols.
#[derive(Clone, Default)]
pub struct Pool {
    nodes: Vec<Node>,
    /// Sorted, deduplicated free symbols of each node.
    free: Vec<Box<[Symbol]>>,
    /// Depth of each node (see [`crate::limits`]).
    depth: Vec<u32>,
    /// Written size of each node, saturating (see [`crate::limits`]).
    written: Vec<u64>,
    /// The value of each node free of symbols and maps (`None` for the others).
    value: Vec<Option<f64>>,
    /// Is the node undefined: its value not finite, or a child undefined (see [`crate::undefined`])?
    undefined: Vec<bool>,
    index: FxHashMap<Node, Id>,
    symbols: Vec<String>,
    symbol_index: HashMap<String, Symbol>,
    /// Declared lookup maps, in declaration order.
    maps: Vec<MapDecl>,
    map_index: HashMap<String, MapId>,
}

impl std::fmt::Debug for Pool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Pool({} nodes, {} symbols)",
            self.nodes.len(),
            self.symbols.len()
        )
    }
}

impl Pool {
    pub fn new() -> Pool {
        Pool::default()
    }

    /// Number of distinct nodes ever interned.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The node behind an id.
    pub fn node(&self, id: Id) -> &Node {
        &self.nodes[id.index()]
    }

    /// The free symbols of an expression, sorted by symbol id.
    pub fn free_symbols(&self, id: Id) -> &[Symbol] {
        &self.free[id.index()]
    }

    /// Nesting depth of `id`: 1 for a leaf (see [`crate::limits`]).
    pub fn depth(&self, id: Id) -> u32 {
        self.depth[id.index()]
    }

    /// Number of nodes of `id` written out as a tree, saturating (see [`crate::limits`]).
    pub fn written_size(&self, id: Id) -> u64 {
        self.written[id.index()]
    }

    /// The nodes below `e` in post-order when `e` is deeper than [`crate::limits::ITERATIVE_DEPTH`]: a
    /// memoised walk that first visits these bottom-up never recurses more than a few levels.
    pub(crate) fn deep_order(&self, e: Id) -> Vec<Id> {
        if self.depth(e) > crate::limits::ITERATIVE_DEPTH {
            self.topological(&[e])
        } else {
            Vec::new()
        }
    }

    /// Does `id` depend on symbol `s`?
    pub fn depends_on(&self, id: Id, s: Symbol) -> bool {
        self.free[id.index()].binary_search(&s).is_ok()
    }

    /// Does `id` depend on any of `syms`?
    pub fn depends_on_any(&self, id: Id, syms: &[Symbol]) -> bool {
        syms.iter().any(|&s| self.depends_on(id, s))
    }

    pub(crate) fn intern(&mut self, node: Node) -> Id {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let free = self.collect_free(&node);
        let (mut depth, mut written) = (0u32, 1u64);
        Self::for_each_child_of(&node, |c| {
            depth = depth.max(self.depth[c.index()]);
            written = written.saturating_add(self.written[c.index()]);
        });
        self.depth.push(depth.saturating_add(1));
        self.written.push(written);
        let value = self.constant_value(&node);
        let mut undefined = value.is_some_and(|v| !v.is_finite());
        Self::for_each_child_of(&node, |c| undefined |= self.undefined[c.index()]);
        self.value.push(value);
        self.undefined.push(undefined);
        let id = Id(u32::try_from(self.nodes.len()).expect("expression pool exceeded 2^32 nodes"));
        self.nodes.push(node.clone());
        self.free.push(free);
        self.index.insert(node, id);
        id
    }

    /// The value of a node free of symbols and maps, from its children's values, computed as every
    /// evaluator in invsim computes it (`pow_f64`, [`Func::eval`]).
    fn constant_value(&self, node: &Node) -> Option<f64> {
        let v = |c: &Id| self.value[c.index()];
        Some(match node {
            Node::Num(n) => n.to_f64(),
            Node::Pi => std::f64::consts::PI,
            Node::Sym(_) | Node::Map(..) | Node::Map2(..) => return None,
            Node::Add(ts) => ts.iter().map(v).sum::<Option<f64>>()?,
            Node::Mul(fs) => fs.iter().map(v).product::<Option<f64>>()?,
            Node::Pow(b, e) => pow_f64(v(b)?, self.as_number(*e), v(e)?),
            Node::Call(f, a) => f.eval(v(a)?),
            Node::Call2(f, a, b) => f.eval(v(a)?, v(b)?),
        })
    }

    /// Is `id` undefined: free of symbols with a value that is not finite (`1/0`, `log(0)`, `sqrt(-1)`),
    /// or built on such a part (`u/0`, `0·log(0)`)? See [`crate::undefined`].
    pub fn is_undefined(&self, id: Id) -> bool {
        self.undefined[id.index()]
    }

    /// The value of `id` if it is free of symbols and maps (numbers, π and functions of them).
    pub fn constant(&self, id: Id) -> Option<f64> {
        self.value[id.index()]
    }

    fn collect_free(&self, node: &Node) -> Box<[Symbol]> {
        let mut v: Vec<Symbol> = match node {
            Node::Num(_) | Node::Pi => Vec::new(),
            Node::Sym(s) => vec![*s],
            Node::Add(c) | Node::Mul(c) => c
                .iter()
                .flat_map(|&c| self.free[c.index()].iter().copied())
                .collect(),
            Node::Pow(a, b) | Node::Call2(_, a, b) | Node::Map2(_, _, a, b) => self.free[a.index()]
                .iter()
                .chain(self.free[b.index()].iter())
                .copied()
                .collect(),
            Node::Call(_, a) | Node::Map(_, _, a) => self.free[a.index()].to_vec(),
        };
        v.sort_unstable();
        v.dedup();
        v.into_boxed_slice()
    }

    // ----- leaves -------------------------------------------------------------------------------------

    pub fn num(&mut self, n: Number) -> Id {
        let n = match n {
            Number::Float(x) => Number::from_f64(x),
            r => r,
        };
        self.intern(Node::Num(n))
    }
    pub fn int(&mut self, i: i128) -> Id {
        self.num(Number::int(i))
    }
    pub fn rational(&mut self, n: i128, d: i128) -> Id {
        self.num(Number::ratio(n, d))
    }
    pub fn float(&mut self, x: f64) -> Id {
        self.num(Number::from_f64(x))
    }
    pub fn zero(&mut self) -> Id {
        self.int(0)
    }
    pub fn one(&mut self) -> Id {
        self.int(1)
    }
    pub fn pi(&mut self) -> Id {
        self.intern(Node::Pi)
    }

    /// Intern a symbol name.
    pub fn symbol(&mut self, name: &str) -> Symbol {
        if let Some(&s) = self.symbol_index.get(name) {
            return s;
        }
        let s = Symbol(self.symbols.len() as u32);
        self.symbols.push(name.to_string());
        self.symbol_index.insert(name.to_string(), s);
        s
    }
    /// Look up a symbol without creating it.
    pub fn find_symbol(&self, name: &str) -> Option<Symbol> {
        self.symbol_index.get(name).copied()
    }
    pub fn symbol_name(&self, s: Symbol) -> &str {
        &self.symbols[s.0 as usize]
    }
    /// The expression consisting of symbol `s`.
    pub fn var(&mut self, s: Symbol) -> Id {
        self.intern(Node::Sym(s))
    }
    /// Shorthand: intern `name` and return it as an expression.
    pub fn sym(&mut self, name: &str) -> Id {
        let s = self.symbol(name);
        self.var(s)
    }

    /// The numeric value of a number node.
    pub fn as_number(&self, id: Id) -> Option<Number> {
        match self.node(id) {
            Node::Num(n) => Some(*n),
            _ => None,
        }
    }
    pub fn is_zero(&self, id: Id) -> bool {
        matches!(self.node(id), Node::Num(n) if n.is_zero())
    }
    pub fn is_one(&self, id: Id) -> bool {
        matches!(self.node(id), Node::Num(n) if n.is_one())
    }
    pub fn as_symbol(&self, id: Id) -> Option<Symbol> {
        match self.node(id) {
            Node::Sym(s) => Some(*s),
            _ => None,
        }
    }

    // ----- canonical order ----------------------------------------------------------------------------

    fn rank(node: &Node) -> u8 {
        match node {
            Node::Num(_) => 0,
            Node::Pi => 1,
            Node::Sym(_) => 2,
            Node::Pow(..) => 3,
            Node::Mul(_) => 4,
            Node::Add(_) => 5,
            Node::Call(..) => 6,
            Node::Call2(..) => 7,
            Node::Map(..) => 8,
            Node::Map2(..) => 9,
        }
    }

    /// The canonical total order on expressions: structural, independent of creation order, so printed and
    /// generated output is deterministic. Numbers first, then π, symbols by name, powers (by base, then
    /// exponent), products, sums and function calls.
    ///
    /// Lexicographic over the two trees, with an explicit stack of pairs still to compare (no recursion, so
    /// the depth of the expressions does not matter). Two distinct nodes never compare equal (creation
    /// order breaks ties between equal numbers of different kinds), so a compound node is decided by the
    /// first pair of distinct children, and only sums and products of different lengths need more.
    pub fn cmp_expr(&self, a: Id, b: Id) -> Ordering {
        /// A pair still to compare, or an ordering that decides once every pair above it is equal.
        enum Item {
            Pair(Id, Id),
            Then(Ordering),
        }
        let mut stack: Vec<Item> = Vec::new();
        let mut next = Some((a, b));
        loop {
            let (a, b) = match next.take() {
                Some(p) => p,
                None => match stack.pop() {
                    None => return Ordering::Equal,
                    Some(Item::Then(Ordering::Equal)) => continue,
                    Some(Item::Then(o)) => return o,
                    Some(Item::Pair(a, b)) => (a, b),
                },
            };
            if a == b {
                continue;
            }
            let (na, nb) = (self.node(a), self.node(b));
            // A power sorts next to its base: x < x^2 < y.
            let base = |n: &Node, id: Id| match n {
                Node::Pow(b, _) => *b,
                _ => id,
            };
            let (ba, bb) = (base(na, a), base(nb, b));
            if ba != bb && (matches!(na, Node::Pow(..)) || matches!(nb, Node::Pow(..))) {
                next = Some((ba, bb));
                continue;
            }
            let o = Self::rank(na).cmp(&Self::rank(nb));
            if o != Ordering::Equal {
                return o;
            }
            match (na, nb) {
                (Node::Pow(b1, e1), Node::Pow(b2, e2)) => {
                    stack.push(Item::Pair(*e1, *e2));
                    next = Some((*b1, *b2));
                }
                (Node::Add(x), Node::Add(y)) | (Node::Mul(x), Node::Mul(y)) => {
                    // From the most significant (last) term, like polynomial degree order; then the
                    // shorter first.
                    stack.push(Item::Then(x.len().cmp(&y.len())));
                    let k = x.len().min(y.len());
                    let pairs = x[x.len() - k..].iter().zip(&y[y.len() - k..]);
                    stack.extend(pairs.map(|(p, q)| Item::Pair(*p, *q)));
                }
                (Node::Call(f, x), Node::Call(g, y)) if f == g => next = Some((*x, *y)),
                (Node::Call2(f, x1, x2), Node::Call2(g, y1, y2)) if f == g => {
                    stack.push(Item::Pair(*x2, *y2));
                    next = Some((*x1, *y1));
                }
                (Node::Map(m, o, x), Node::Map(n, p, y)) if m == n => {
                    if o != p {
                        return o.cmp(p);
                    }
                    next = Some((*x, *y));
                }
                (Node::Map2(m, o, x1, x2), Node::Map2(n, p, y1, y2)) if m == n => {
                    if o != p {
                        return o.cmp(p);
                    }
                    stack.push(Item::Pair(*x2, *y2));
                    next = Some((*x1, *y1));
                }
                (Node::Map(m, ..), Node::Map(n, ..)) | (Node::Map2(m, ..), Node::Map2(n, ..)) => {
                    return self.map_decl(*m).name.cmp(&self.map_decl(*n).name)
                }
                (Node::Call(f, _), Node::Call(g, _)) => return f.cmp(g),
                (Node::Call2(f, ..), Node::Call2(g, ..)) => return f.cmp(g),
                (Node::Num(x), Node::Num(y)) => return x.cmp_value(y).then(a.cmp(&b)),
                (Node::Sym(x), Node::Sym(y)) => {
                    return self
                        .symbol_name(*x)
                        .cmp(self.symbol_name(*y))
                        .then(a.cmp(&b))
                }
                _ => return a.cmp(&b),
            }
        }
    }

    // ----- sums ---------------------------------------------------------------------------------------

    /// Split a term into numeric coefficient and the rest: `3*x*y → (3, x*y)`, `x → (1, x)`.
    pub fn split_coefficient(&mut self, t: Id) -> (Number, Id) {
        match self.node(t) {
            Node::Num(n) => {
                let n = *n;
                (n, self.one())
            }
            Node::Mul(fs) => {
                if let Node::Num(c) = self.node(fs[0]) {
                    let c = *c;
                    let rest: Vec<Id> = fs[1..].to_vec();
                    let rest = if rest.len() == 1 {
                        rest[0]
                    } else {
                        self.intern(Node::Mul(rest.into()))
                    };
                    (c, rest)
                } else {
                    (Number::ONE, t)
                }
            }
            _ => (Number::ONE, t),
        }
    }

    /// The numeric content of a sum: `6a − 4b → (2, 3a − 2b)`, `−a − b → (−1, a + b)`; the primitive part
    /// has coprime integer-or-rational coefficients and a positive first non-numeric term. `None` when the
    /// content is 1, the expression is not a sum, or a coefficient is inexact.
    pub fn content(&mut self, e: Id) -> Option<(Number, Id)> {
        if self.is_undefined(e) {
            return None;
        }
        let Node::Add(ts) = self.node(e) else {
            return None;
        };
        let ts = ts.to_vec();
        let mut g: i128 = 0;
        let mut l: i128 = 1;
        let mut sign_negative = None;
        for &t in &ts {
            let c = match self.node(t) {
                Node::Num(n) => *n,
                _ => {
                    let c = self.split_coefficient(t).0;
                    if sign_negative.is_none() {
                        sign_negative = Some(c.is_negative());
                    }
                    c
                }
            };
            let Number::Rational(p, q) = c else {
                return None;
            };
            g = gcd_i128(g, p);
            l = l.checked_div(gcd_i128(l, q))?.checked_mul(q)?;
        }
        if g == 0 {
            return None;
        }
        let content = Number::ratio(if sign_negative == Some(true) { -g } else { g }, l);
        if content.is_one() {
            return None;
        }
        let inv = self.num(content.recip()?);
        let scaled: Vec<Id> = ts.iter().map(|&t| self.mul(&[inv, t])).collect();
        Some((content, self.add(&scaled)))
    }

    /// Canonical n-ary sum.
    pub fn add(&mut self, terms: &[Id]) -> Id {
        let sum = self.add_canonical(terms);
        if self.is_undefined(sum) || !terms.iter().any(|&t| self.is_undefined(t)) {
            return sum;
        }
        // An undefined term was cancelled (1/0 − 1/0): keep it (`crate::undefined`).
        self.add_keeping_undefined(terms)
    }

    fn add_canonical(&mut self, terms: &[Id]) -> Id {
        let mut constant = Number::ZERO;
        let mut order: Vec<Id> = Vec::new();
        let mut coeff: FxHashMap<Id, Number> = FxHashMap::default();
        let mut stack: Vec<Id> = terms.iter().rev().copied().collect();
        while let Some(t) = stack.pop() {
            match self.node(t) {
                Node::Add(ts) => stack.extend(ts.iter().rev().copied()),
                Node::Num(n) => constant = constant.add(*n),
                _ => {
                    let (c, rest) = self.split_coefficient(t);
                    match coeff.get_mut(&rest) {
                        Some(acc) => *acc = acc.add(c),
                        None => {
                            coeff.insert(rest, c);
                            order.push(rest);
                        }
                    }
                }
            }
        }
        let mut out: Vec<Id> = Vec::with_capacity(order.len() + 1);
        order.sort_by(|a, b| self.cmp_expr(*a, *b));
        for rest in order {
            let c = coeff[&rest];
            if c.is_zero() {
                continue;
            }
            out.push(self.scale(c, rest));
        }
        // Scaling can produce numbers only if rest was 1, which split_coefficient never yields for non-numbers.
        if !constant.is_zero() {
            let k = self.num(constant);
            out.insert(0, k);
        }
        match out.len() {
            0 => self.zero(),
            1 => out[0],
            _ => self.intern(Node::Add(out.into())),
        }
    }

    /// c · rest for a coefficient-free `rest` (no distribution needed).
    fn scale(&mut self, c: Number, rest: Id) -> Id {
        if c.is_one() {
            return rest;
        }
        if self.is_one(rest) {
            return self.num(c);
        }
        let k = self.num(c);
        let mut fs = vec![k];
        match self.node(rest) {
            Node::Mul(rs) => fs.extend(rs.iter().copied()),
            _ => fs.push(rest),
        }
        self.intern(Node::Mul(fs.into()))
    }

    pub fn add2(&mut self, a: Id, b: Id) -> Id {
        self.add(&[a, b])
    }
    pub fn sub(&mut self, a: Id, b: Id) -> Id {
        let nb = self.neg(b);
        self.add(&[a, nb])
    }
    pub fn neg(&mut self, a: Id) -> Id {
        let m = self.int(-1);
        self.mul(&[m, a])
    }

    // ----- products -----------------------------------------------------------------------------------

    /// Canonical n-ary product.
    pub fn mul(&mut self, factors: &[Id]) -> Id {
        let product = self.mul_canonical(factors);
        if self.is_undefined(product) || !factors.iter().any(|&f| self.is_undefined(f)) {
            return product;
        }
        // An undefined factor was multiplied away (0·(1/0)): keep it (`crate::undefined`).
        self.mul_keeping_undefined(factors)
    }

    fn mul_canonical(&mut self, factors: &[Id]) -> Id {
        let mut coeff = Number::ONE;
        let mut order: Vec<Id> = Vec::new();
        let mut exps: FxHashMap<Id, Vec<Id>> = FxHashMap::default();
        let mut stack: Vec<Id> = factors.iter().rev().copied().collect();
        while let Some(f) = stack.pop() {
            match self.node(f) {
                Node::Mul(fs) => stack.extend(fs.iter().rev().copied()),
                Node::Num(n) => coeff = coeff.mul(*n),
                Node::Pow(b, e) => {
                    let (b, e) = (*b, *e);
                    exps.entry(b).or_insert_with(|| {
                        order.push(b);
                        Vec::new()
                    });
                    if let Some(v) = exps.get_mut(&b) {
                        v.push(e);
                    }
                }
                _ => {
                    // A sum factor contributes its numeric content to the coefficient, so that
                    // 3(a + b)c and (a + b)c·3 meet the same canonical form.
                    let f = match self.content(f) {
                        Some((c, primitive)) => {
                            coeff = coeff.mul(c);
                            primitive
                        }
                        None => f,
                    };
                    let one = self.one();
                    exps.entry(f).or_insert_with(|| {
                        order.push(f);
                        Vec::new()
                    });
                    if let Some(v) = exps.get_mut(&f) {
                        v.push(one);
                    }
                }
            }
        }
        if coeff.is_zero() {
            return self.zero();
        }
        let mut out: Vec<Id> = Vec::with_capacity(order.len() + 1);
        let mut refold = false;
        for b in order {
            let es = exps.remove(&b).unwrap_or_default();
            let e = if es.len() == 1 { es[0] } else { self.add(&es) };
            let p = self.pow(b, e);
            match self.node(p) {
                Node::Num(n) => coeff = coeff.mul(*n),
                Node::Mul(_) => {
                    refold = true;
                    out.push(p)
                }
                node => {
                    // The power rules can change the base ((x^2)^(−1) → x^(−2), exp(a)^2 → exp(2a)); the new
                    // base may meet another factor with that base, so combine again.
                    let new_base = match node {
                        Node::Pow(pb, _) => *pb,
                        _ => p,
                    };
                    refold |= new_base != b;
                    out.push(p)
                }
            }
        }
        if refold {
            let k = self.num(coeff);
            out.push(k);
            return self.mul(&out);
        }
        if coeff.is_zero() {
            return self.zero();
        }
        out.sort_by(|a, b| self.cmp_expr(*a, *b));
        // Distribute a numeric coefficient over a single sum: 2(x + y) → 2x + 2y.
        if out.len() == 1 && !coeff.is_one() {
            if let Node::Add(ts) = self.node(out[0]) {
                let ts = ts.to_vec();
                let k = self.num(coeff);
                let scaled: Vec<Id> = ts.iter().map(|&t| self.mul(&[k, t])).collect();
                return self.add(&scaled);
            }
        }
        if !coeff.is_one() {
            let k = self.num(coeff);
            out.insert(0, k);
        }
        match out.len() {
            0 => self.one(),
            1 => out[0],
            _ => self.intern(Node::Mul(out.into())),
        }
    }

    pub fn mul2(&mut self, a: Id, b: Id) -> Id {
        self.mul(&[a, b])
    }
    pub fn div(&mut self, a: Id, b: Id) -> Id {
        let r = self.recip(b);
        self.mul(&[a, r])
    }
    pub fn recip(&mut self, a: Id) -> Id {
        let m = self.int(-1);
        self.pow(a, m)
    }

    // ----- powers -------------------------------------------------------------------------------------

    /// Canonical power b^e.
    pub fn pow(&mut self, b: Id, e: Id) -> Id {
        let p = self.pow_canonical(b, e);
        if self.is_undefined(p) || !(self.is_undefined(b) || self.is_undefined(e)) {
            return p;
        }
        // An identity removed an undefined operand ((1/0)^0 = 1, (1/0)^(−1) = 0): not applied.
        self.intern(Node::Pow(b, e))
    }

    fn pow_canonical(&mut self, b: Id, e: Id) -> Id {
        let en = self.as_number(e);
        if let Some(en) = en {
            if en.is_zero() {
                return self.one();
            }
            if en.is_one() {
                return b;
            }
        }
        if self.is_one(b) {
            return b;
        }
        match (self.node(b).clone(), en) {
            (Node::Num(bn), Some(en)) => {
                if bn.is_zero() && !en.is_negative() {
                    return self.zero();
                }
                if bn.is_zero() && !en.is_minus_one() {
                    // 0^(−p) is a division by zero whatever p > 0 is; one form, 1/0, so that it prints and
                    // parses back to itself (`1/0^2` would parse as 1/(0^2) = 1/0).
                    let m = self.int(-1);
                    return self.intern(Node::Pow(b, m));
                }
                if let Some(k) = en.as_integer() {
                    // Exact integer powers of numbers, kept small so that coefficients stay readable.
                    if k.abs() <= 64 {
                        if let Some(r) = bn.powi(k) {
                            if r.is_exact() || !bn.is_exact() {
                                return self.num(r);
                            }
                        }
                    }
                }
                if let (Number::Float(x), Number::Float(_) | Number::Rational(..)) = (bn, en) {
                    if x > 0.0 {
                        return self.float(x.powf(en.to_f64()));
                    }
                }
            }
            (Node::Pow(bb, be), Some(en)) if en.as_integer().is_some() => {
                // (x^a)^n = x^(a n) for integer n.
                let ne = self.mul(&[be, e]);
                return self.pow(bb, ne);
            }
            (Node::Pow(bb, be), Some(_)) => {
                // (x^a)^c = x^(a c) when a is not an integer: x^a is then real only for x ≥ 0, where the
                // identity holds; likewise for a = −1 ((1/x)^c and x^(−c) are both real exactly for x > 0
                // when c is not an integer). ((x^2)^(1/2) = |x| is deliberately left alone.)
                if matches!(self.as_number(be), Some(an) if an.as_integer().is_none() || an.is_minus_one())
                {
                    let ne = self.mul(&[be, e]);
                    return self.pow(bb, ne);
                }
            }
            (Node::Mul(fs), Some(en)) if en.as_integer().is_some() => {
                // (x y)^n = x^n y^n for integer n.
                let fs = fs.to_vec();
                let ps: Vec<Id> = fs.iter().map(|&f| self.pow(f, e)).collect();
                return self.mul(&ps);
            }
            (Node::Mul(fs), Some(_)) => {
                // (c·rest)^p = c^p · rest^p for a positive numeric coefficient c (both sides real on the same
                // domain, rest ≥ 0).
                if let Node::Num(c) = self.node(fs[0]) {
                    if !c.is_negative() {
                        let fs = fs.to_vec();
                        let rest = if fs.len() == 2 {
                            fs[1]
                        } else {
                            self.intern(Node::Mul(fs[1..].into()))
                        };
                        let c = fs[0];
                        let cp = self.pow(c, e);
                        let rp = self.pow(rest, e);
                        return self.mul(&[cp, rp]);
                    }
                }
            }
            (Node::Add(_), Some(en)) => {
                // (c·P)^e = c^e·P^e for the content c of a sum, when e is an integer or c > 0.
                if let Some((c, primitive)) = self.content(b) {
                    if en.as_integer().is_some() || !c.is_negative() {
                        let cn = self.num(c);
                        let ce = self.pow(cn, e);
                        let pe = self.pow(primitive, e);
                        return self.mul(&[ce, pe]);
                    }
                }
            }
            (Node::Call(Func::Exp, a), _) => {
                // exp(a)^e = exp(a e).
                let ae = self.mul(&[a, e]);
                return self.call(Func::Exp, ae);
            }
            _ => {}
        }
        self.intern(Node::Pow(b, e))
    }

    pub fn powi(&mut self, b: Id, k: i128) -> Id {
        let e = self.int(k);
        self.pow(b, e)
    }
    pub fn sqrt(&mut self, a: Id) -> Id {
        let h = self.rational(1, 2);
        self.pow(a, h)
    }

    // ----- functions ----------------------------------------------------------------------------------

    /// Canonical one-argument function call, applying the first matching rule of [`FUNCTION_RULES`].
    pub fn call(&mut self, f: Func, a: Id) -> Id {
        let c = self.call_canonical(f, a);
        if self.is_undefined(c) || !self.is_undefined(a) {
            return c;
        }
        // A rule removed an undefined argument (exp(log(0)) = 0, sign(0/0) = 1): not applied.
        self.intern(Node::Call(f, a))
    }

    fn call_canonical(&mut self, f: Func, a: Id) -> Id {
        for rule in FUNCTION_RULES.iter().filter(|r| r.func == f) {
            if let Some(r) = self.apply_rule(rule, a) {
                return r;
            }
        }
        self.intern(Node::Call(f, a))
    }

    /// `rule` applied to `rule.func(arg)`; `None` when it does not match.
    fn apply_rule(&mut self, rule: &FunctionRule, arg: Id) -> Option<Id> {
        let f = rule.func;
        match rule.rewrite {
            Rewrite::Inverse(g) => match self.node(arg) {
                Node::Call(h, inner) if *h == g => Some(*inner),
                _ => None,
            },
            Rewrite::AtZero(v) => self.is_zero(arg).then(|| self.int(v)),
            Rewrite::AtOne(v) => self.is_one(arg).then(|| self.int(v)),
            Rewrite::Odd => {
                // f(−x) = −f(x).
                let m = self.negated(arg)?;
                let inner = self.call(f, m);
                Some(self.neg(inner))
            }
            Rewrite::Even => {
                // f(−x) = f(x).
                let m = self.negated(arg)?;
                Some(self.call(f, m))
            }
            Rewrite::Numeric => {
                let n = self.as_number(arg)?;
                let v = match f {
                    Func::Abs if n.is_negative() => n.neg(),
                    Func::Abs => n,
                    Func::Sign if n.is_zero() => Number::ZERO,
                    Func::Sign if n.is_negative() => Number::MINUS_ONE,
                    _ => Number::ONE,
                };
                Some(self.num(v))
            }
            Rewrite::OfAtan => {
                let x = match self.node(arg) {
                    Node::Call(Func::Atan, x) => *x,
                    _ => return None,
                };
                // 1 + x², and its −½ power: cos(atan x); sin(atan x) = x·cos(atan x); tan(atan x) = x.
                let (one, x2) = (self.int(1), self.powi(x, 2));
                let hyp = self.add(&[one, x2]);
                let minus_half = self.rational(-1, 2);
                let cos = self.pow(hyp, minus_half);
                match f {
                    Func::Cos => Some(cos),
                    Func::Sin => Some(self.mul(&[x, cos])),
                    Func::Tan => Some(x),
                    _ => None,
                }
            }
        }
    }

    /// −arg if `arg` is written with a negative numeric coefficient (for a sum: its first non-numeric term's).
    fn negated(&mut self, arg: Id) -> Option<Id> {
        let (c, _) = self.split_coefficient(arg);
        let leading_negative = match self.node(arg) {
            Node::Add(ts) => {
                let first = ts.iter().find(|&&t| self.as_number(t).is_none()).copied();
                first
                    .map(|t| self.split_coefficient(t).0.is_negative())
                    .unwrap_or(false)
            }
            _ => c.is_negative(),
        };
        leading_negative.then(|| self.neg(arg))
    }

    /// Canonical two-argument call (`min`, `max`).
    pub fn call2(&mut self, f: Func2, a: Id, b: Id) -> Id {
        if self.is_undefined(a) || self.is_undefined(b) {
            // min(1/0, 1) is not 1: no identity applies (`crate::undefined`).
            return self.intern(Node::Call2(f, a, b));
        }
        if a == b {
            return a;
        }
        if let (Some(x), Some(y)) = (self.as_number(a), self.as_number(b)) {
            let o = x.cmp_value(&y);
            return match (f, o) {
                (Func2::Min, Ordering::Greater) | (Func2::Max, Ordering::Less) => b,
                _ => a,
            };
        }
        let (a, b) = if self.cmp_expr(a, b) == Ordering::Greater {
            (b, a)
        } else {
            (a, b)
        };
        self.intern(Node::Call2(f, a, b))
    }

    // ----- maps ---------------------------------------------------------------------------------------

    /// Declares a lookup map (contract §6); a second declaration of the same name replaces its data.
    pub fn declare_map(&mut self, decl: MapDecl) -> MapId {
        if let Some(&id) = self.map_index.get(&decl.name) {
            self.maps[id.index()] = decl;
            return id;
        }
        let id = MapId(self.maps.len() as u32);
        self.map_index.insert(decl.name.clone(), id);
        self.maps.push(decl);
        id
    }

    /// The declared maps, in declaration order ([`MapId::index`]).
    pub fn maps(&self) -> &[MapDecl] {
        &self.maps
    }

    /// A declared map.
    pub fn map_decl(&self, id: MapId) -> &MapDecl {
        &self.maps[id.index()]
    }

    /// The map declared as `name`.
    pub fn find_map(&self, name: &str) -> Option<MapId> {
        self.map_index.get(name).copied()
    }

    /// The call `∂^(I+J) M / ∂a^I ∂b^J (args)` (`orders = [I, J]`; 1-D: `[K, 0]`). `args.len()` must be the
    /// map's arity. A map is never simplified away: it is an opaque smooth function of its arguments.
    pub fn map_call(&mut self, map: MapId, orders: MapOrders, args: &[Id]) -> Id {
        debug_assert_eq!(args.len(), self.map_decl(map).arity());
        match args {
            [a] => self.intern(Node::Map(map, [orders[0], 0], *a)),
            [a, b, ..] => self.intern(Node::Map2(map, orders, *a, *b)),
            [] => unreachable!("a map call has one or two arguments"),
        }
    }

    /// Rebuild a node from (possibly new) children through the canonical constructors.
    pub fn rebuild(&mut self, node: &Node, children: &[Id]) -> Id {
        match node {
            Node::Num(_) | Node::Pi | Node::Sym(_) => self.intern(node.clone()),
            Node::Add(_) => self.add(children),
            Node::Mul(_) => self.mul(children),
            Node::Pow(..) => self.pow(children[0], children[1]),
            Node::Call(f, _) => self.call(*f, children[0]),
            Node::Call2(f, ..) => self.call2(*f, children[0], children[1]),
            Node::Map(m, o, _) => self.map_call(*m, *o, &children[..1]),
            Node::Map2(m, o, ..) => self.map_call(*m, *o, &children[..2]),
        }
    }

    /// The children of a node, in order.
    pub fn children(&self, id: Id) -> Vec<Id> {
        match self.node(id) {
            Node::Num(_) | Node::Pi | Node::Sym(_) => Vec::new(),
            Node::Add(c) | Node::Mul(c) => c.to_vec(),
            Node::Pow(a, b) | Node::Call2(_, a, b) | Node::Map2(_, _, a, b) => vec![*a, *b],
            Node::Call(_, a) | Node::Map(_, _, a) => vec![*a],
        }
    }

    /// Calls `f` on each child of `id`, in order, without allocating.
    #[inline]
    pub fn for_each_child(&self, id: Id, f: impl FnMut(Id)) {
        Self::for_each_child_of(self.node(id), f)
    }

    #[inline]
    fn for_each_child_of(node: &Node, mut f: impl FnMut(Id)) {
        match node {
            Node::Num(_) | Node::Pi | Node::Sym(_) => {}
            Node::Add(c) | Node::Mul(c) => c.iter().for_each(|&c| f(c)),
            Node::Pow(a, b) | Node::Call2(_, a, b) | Node::Map2(_, _, a, b) => {
                f(*a);
                f(*b)
            }
            Node::Call(_, a) | Node::Map(_, _, a) => f(*a),
        }
    }

    /// The children of `id` as a slice-like pair (the two operands of a power or a two-argument call are
    /// `pair`, the terms or factors of a sum or product `list`).
    #[inline]
    fn child_slice(&self, id: Id) -> ChildSlice<'_> {
        match self.node(id) {
            Node::Num(_) | Node::Pi | Node::Sym(_) => ChildSlice::Pair([id, id], 0),
            Node::Add(c) | Node::Mul(c) => ChildSlice::List(c),
            Node::Pow(a, b) | Node::Call2(_, a, b) | Node::Map2(_, _, a, b) => {
                ChildSlice::Pair([*a, *b], 2)
            }
            Node::Call(_, a) | Node::Map(_, _, a) => ChildSlice::Pair([*a, *a], 1),
        }
    }

    /// Number of distinct nodes in the DAG below `roots` (shared subterms counted once).
    pub fn dag_size(&self, roots: &[Id]) -> usize {
        let mut seen: FxHashSet<Id> = FxHashSet::default();
        let mut stack: Vec<Id> = roots.to_vec();
        while let Some(id) = stack.pop() {
            if seen.insert(id) {
                self.for_each_child(id, |c| stack.push(c));
            }
        }
        seen.len()
    }

    /// Every node below `roots` in post-order (children before parents), each once.
    pub fn topological(&self, roots: &[Id]) -> Vec<Id> {
        let mut out = Vec::new();
        let mut seen: FxHashSet<Id> = FxHashSet::default();
        let mut stack: Vec<(Id, bool)> = Vec::new();
        for &r in roots {
            stack.push((r, false));
            while let Some((id, done)) = stack.pop() {
                if done {
                    out.push(id);
                    continue;
                }
                if !seen.insert(id) {
                    continue;
                }
                stack.push((id, true));
                for &c in self.child_slice(id).as_slice().iter().rev() {
                    if !seen.contains(&c) {
                        stack.push((c, false));
                    }
                }
            }
        }
        out
    }
}

/// The children of a node: up to two inline, or the terms of a sum or factors of a product.
enum ChildSlice<'a> {
    Pair([Id; 2], usize),
    List(&'a [Id]),
}

impl ChildSlice<'_> {
    fn as_slice(&self) -> &[Id] {
        match self {
            ChildSlice::Pair(p, n) => &p[..*n],
            ChildSlice::List(l) => l,
        }
    }
}
