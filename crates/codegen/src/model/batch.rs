//! Batch kernels: `invert_batch`, `outputs_batch` and `sensitivity_batch`, a model function evaluated over
//! columns of points, block by block, with the fractional powers of a block taken at once by `invsim_model_api::math::pow_pos_slice`
//! and the lookup-map calls by `Map::partials2_batch` (`Map::values_batch` where only the value is read).
//!
//! The per-point function's lowered code is split at its fractional powers b^q (q a constant or a
//! parameter-only value, b varying) and its map calls of orders ≤ 2 (one `partials2_batch` per map and
//! arguments, into a buffer `mapv[j]` with entry e of point k at `e · len + k`; a map's arguments play the
//! part of a power's base). A power's *level* is one more than the highest level of the powers (and maps) its
//! base depends on. Over a block of points, loop l computes the bases of the level-(l + 1) powers into block
//! buffers and `pow_pos_slice` raises them, for l = 0, 1, …; the last loop computes the function's results
//! from the inputs and the powers. Every loop is straight-line `f64` code per point that LLVM vectorises (the
//! results go to block buffers on the stack, copied to the columns afterwards, so no loop writes memory that
//! could alias its inputs). `sensitivity_batch`, whose results are many and of which a caller wants a few,
//! keeps the temporaries its results share in a block buffer instead and computes each result wanted in a
//! loop of its own, straight into its column. A later loop recomputes the cheap values it shares with an earlier one and reads
//! calls of transcendental functions (and powers with varying exponents) from a block buffer instead.

use super::atoms::Atoms;
use super::context::{invert_result, Arg, FnKind, Gen, Straight};
use super::docs::doc_attrs;
use crate::emit::{self, Ex};
use invsim_expr::lower::{Arena, Lowered, Op, Val};
use invsim_expr::{Func, Symbol};
use proc_macro2::{Ident, TokenStream};
use quote::{format_ident, quote, ToTokens};
use std::cell::{Cell, RefCell};
use std::collections::{HashMap, HashSet};

/// A fractional power, or a call of a transcendental function, taken a block at a time.
pub(super) struct SlicePow {
    /// Its arena index.
    op: usize,
    /// 1 + the highest level among the powers its base depends on.
    level: usize,
    base: Val,
    what: Sliced,
}

/// What a [`SlicePow`] computes from its base.
#[derive(Clone, Copy, Debug)]
enum Sliced {
    /// `pow_pos_slice` with this exponent (a number or a parameter-only value).
    Pow(Val),
    /// The function (not `abs` or `sign`), point by point in a loop of its own: the library call then
    /// stays out of the loops around it, which vectorise.
    Call(Func),
}

/// The calls of one map at the same arguments (every order ≤ 2 per argument), evaluated a block at a time by
/// `Map::partials2_batch`: the value and partials of `partials2` bit for bit, which every single call's
/// `partial` equals (contract §6).
pub(super) struct SliceMap {
    /// Its calls: (arena index, entry of `partials2`: `3p + q` in 2-D, the order in 1-D).
    calls: Vec<(usize, usize)>,
    /// 1 + the highest level among the powers and maps its arguments depend on.
    level: usize,
    /// The map's index in `Precomputed::maps`.
    map: usize,
    /// `a` (and `b` of a 2-D map), each with whether it is an input column as it is.
    args: Vec<(Val, bool)>,
}

/// How one function's lowered code splits into loops over a block.
pub(super) struct Split {
    pows: Vec<SlicePow>,
    maps: Vec<SliceMap>,
    /// Values computed in loop `l` and kept in a block buffer for later loops: (arena index, l).
    kept: Vec<(usize, usize)>,
    /// The number of loops: the highest level + 1.
    loops: usize,
}

/// `b^q` with a varying base and a constant or parameter-only exponent, as (b, q); `f(b)` of a
/// transcendental function with a varying argument, as (b, f).
fn slice_pow(op: Op, is_param: &dyn Fn(Val) -> bool) -> Option<(Val, Sliced)> {
    match op {
        Op::Powf(b, q) if !is_param(b) => Some((b, Sliced::Pow(Val::Num(q)))),
        Op::PowVar(b, e) if !is_param(b) && is_param(e) => Some((b, Sliced::Pow(e))),
        Op::Call(f, b) if !is_param(b) && !matches!(f, Func::Abs | Func::Sign) => {
            Some((b, Sliced::Call(f)))
        }
        _ => None,
    }
}

/// A map call taken a block at a time, as ((map, arguments), entry of `partials2`).
fn slice_map(op: Op) -> Option<((usize, Vec<Val>), usize)> {
    match op {
        Op::Map1(m, o, a) if o <= 2 => Some(((m.index(), vec![a]), o as usize)),
        Op::Map2(m, [p, q], a, b) if p <= 2 && q <= 2 => {
            Some(((m.index(), vec![a, b]), 3 * p as usize + q as usize))
        }
        _ => None,
    }
}

/// Worth a block buffer rather than computing twice: library calls.
fn expensive(op: Op) -> bool {
    match op {
        Op::Call(f, _) => !matches!(f, Func::Abs | Func::Sign),
        Op::PowVar(..) => true,
        _ => false,
    }
}

/// The arena values computed for `roots` (not descending below the values `given` marks), as flags.
fn reach(arena: &Arena, roots: &[Val], given: &dyn Fn(usize) -> bool) -> Vec<bool> {
    let mut seen = vec![false; arena.ops().len()];
    let mut stack: Vec<usize> = roots.iter().filter_map(|v| loc(*v)).collect();
    while let Some(i) = stack.pop() {
        if seen[i] || given(i) {
            continue;
        }
        seen[i] = true;
        stack.extend(arena.ops()[i].operands().into_iter().filter_map(loc));
    }
    seen
}

fn loc(v: Val) -> Option<usize> {
    match v {
        Val::Loc(i) => Some(i),
        _ => None,
    }
}

impl Split {
    pub(super) fn new(arena: &Arena, roots: &[Val], is_param: &dyn Fn(Val) -> bool) -> Split {
        let live = reach(arena, roots, &|_| false);
        let mut level = vec![0usize; arena.ops().len()];
        let mut pows = Vec::new();
        let mut maps: Vec<SliceMap> = Vec::new();
        for (i, &op) in arena.ops().iter().enumerate() {
            let of = |v: Val| loc(v).map_or(0, |j| level[j]);
            if let Some(((map, args), k)) = slice_map(op) {
                let l = args.iter().map(|&a| of(a)).max().unwrap_or(0) + 1;
                level[i] = l;
                if live[i] {
                    add_call(&mut maps, map, &args, (i, k), l, is_param);
                }
                continue;
            }
            level[i] = match slice_pow(op, is_param) {
                Some((base, what)) => {
                    let l = of(base) + 1;
                    if live[i] {
                        pows.push(SlicePow {
                            op: i,
                            level: l,
                            base,
                            what,
                        });
                    }
                    l
                }
                None => op.operands().into_iter().map(of).max().unwrap_or(0),
            };
        }
        // Numbered in the order they are taken.
        pows.sort_by_key(|p| p.level);
        maps.sort_by_key(|m| m.level);
        let top = pows.iter().map(|p| p.level);
        let loops = top.chain(maps.iter().map(|m| m.level)).max().unwrap_or(0) + 1;
        let mut plan = Split {
            pows,
            maps,
            kept: Vec::new(),
            loops,
        };
        for l in 0..loops - 1 {
            let here = reach(arena, &plan.roots(l, roots), &|i| plan.given(i, l));
            let mut later = vec![false; arena.ops().len()];
            for m in l + 1..loops {
                let r = reach(arena, &plan.roots(m, roots), &|i| {
                    plan.given(i, l) || plan.taken(i, m)
                });
                later.iter_mut().zip(r).for_each(|(a, b)| *a |= b);
            }
            for i in 0..arena.ops().len() {
                if here[i]
                    && later[i]
                    && expensive(arena.ops()[i])
                    && slice_pow(arena.ops()[i], is_param).is_none()
                    && slice_map(arena.ops()[i]).is_none()
                {
                    plan.kept.push((i, l));
                }
            }
        }
        plan
    }

    /// Is value `i` a power or a map call taken a block at a time at a level ≤ `l`?
    fn taken(&self, i: usize, l: usize) -> bool {
        self.pows.iter().any(|p| p.op == i && p.level <= l)
            || self
                .maps
                .iter()
                .any(|m| m.level <= l && m.calls.iter().any(|&(c, _)| c == i))
    }

    /// Is value `i` available from a block buffer in loop `l` (a power or map below level l + 1, or kept
    /// earlier)?
    fn given(&self, i: usize, l: usize) -> bool {
        self.taken(i, l) || self.kept.iter().any(|&(k, m)| k == i && m < l)
    }

    /// What loop `l` computes: the function's roots in the last loop, else the bases of the next level's
    /// powers (those not already in a column or buffer) and the values kept from it.
    fn roots(&self, l: usize, roots: &[Val]) -> Vec<Val> {
        if l + 1 == self.loops {
            return roots.to_vec();
        }
        let mut out: Vec<Val> = Vec::new();
        for p in &self.pows {
            if p.level == l + 1
                && loc(p.base).is_some_and(|b| !self.given(b, l))
                && !out.contains(&p.base)
            {
                out.push(p.base);
            }
        }
        for m in self.maps.iter().filter(|m| m.level == l + 1) {
            for &(a, column) in &m.args {
                let given = loc(a).is_some_and(|b| self.given(b, l));
                if !column && !given && !out.contains(&a) {
                    out.push(a);
                }
            }
        }
        for &(i, m) in &self.kept {
            if m == l && !out.contains(&Val::Loc(i)) {
                out.push(Val::Loc(i));
            }
        }
        out
    }

    /// Does this function have powers to take a block at a time (by `pow_pos_slice`)?
    pub(super) fn has_powers(&self) -> bool {
        self.pows.iter().any(|p| matches!(p.what, Sliced::Pow(_)))
    }

    /// Does it have calls of transcendental functions in loops of their own?
    fn has_calls(&self) -> bool {
        self.pows.iter().any(|p| matches!(p.what, Sliced::Call(_)))
    }

    /// Does this function have map calls to take a block at a time?
    pub(super) fn has_maps(&self) -> bool {
        !self.maps.is_empty()
    }
}

/// Call `call` of `map` at `args` into its group (a new one at `level` if none has these arguments yet).
fn add_call(
    maps: &mut Vec<SliceMap>,
    map: usize,
    args: &[Val],
    call: (usize, usize),
    level: usize,
    is_param: &dyn Fn(Val) -> bool,
) {
    let same =
        |m: &&mut SliceMap| m.map == map && m.args.iter().map(|a| a.0).eq(args.iter().copied());
    match maps.iter_mut().find(same) {
        Some(m) => m.calls.push(call),
        None => maps.push(SliceMap {
            calls: vec![call],
            level,
            map,
            args: args
                .iter()
                .map(|&a| (a, matches!(a, Val::Sym(_)) && !is_param(a)))
                .collect(),
        }),
    }
}

/// The three batch methods.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    /// `invert_batch` from the fused inverse `invert`.
    Invert,
    /// `outputs_batch` from `outputs`.
    Outputs,
    /// `sensitivity_batch` from `sensitivity` (the gradient's pass over the grid of a run without internal
    /// states).
    Sensitivity,
}

impl Kind {
    /// The batch method made from function `f`, if any (`invert_batch` needs ψ⁻¹ in closed form;
    /// `sensitivity_batch` is made where `sensitivity` asks for it).
    fn of(f: FnKind, closed: bool, sensitivity: bool) -> Option<Kind> {
        match f {
            FnKind::Invert if closed => Some(Kind::Invert),
            FnKind::Outputs => Some(Kind::Outputs),
            FnKind::Sensitivity if sensitivity => Some(Kind::Sensitivity),
            _ => None,
        }
    }

    /// The points per block: [`BLOCK`], or for `sensitivity_batch`, whose results are many (every partial
    /// derivative), as many as keep its block buffer of results within [`SENS_BUFFER`] bytes (a multiple of
    /// 4, at least 4), so that the buffer stays on the stack.
    fn block(self, results: usize) -> Option<usize> {
        (self == Kind::Sensitivity).then(|| {
            let points = SENS_BUFFER / (8 * results.max(1));
            (points / 4 * 4).clamp(4, 256)
        })
    }
}

/// The bytes of `sensitivity_batch`'s block buffer of results, at most.
const SENS_BUFFER: usize = 64 * 1024;

/// The batch methods of a model.
#[derive(Default)]
pub(super) struct Batch {
    pub(super) methods: Vec<TokenStream>,
    pub(super) uses_sign: bool,
    /// Some method calls `pow_pos_slice`.
    pub(super) uses_pow_slice: bool,
    pub(super) invert: bool,
    pub(super) outputs: bool,
    pub(super) sensitivity: bool,
}

impl Batch {
    /// Does the model have any batch method?
    pub(super) fn any(&self) -> bool {
        self.invert || self.outputs || self.sensitivity
    }
}

/// The batch methods over columns of points for the lowered functions `fns` that have one (`sensitivity`:
/// `sensitivity_batch` too).
pub(super) fn methods(
    g: &Gen<'_>,
    fns: &[Straight],
    k_names: &HashMap<usize, Ident>,
    sensitivity: bool,
) -> Batch {
    let mut out = Batch::default();
    for f in fns {
        let kind = Kind::of(f.kind, g.closed, sensitivity);
        let (Some(l), Some(kind)) = (&f.lowered, kind) else {
            continue;
        };
        let atoms = Atoms::new(g, k_names);
        let is_param = |v: Val| atoms.is_param(v);
        let plan = Split::new(&l.arena, &l.roots, &is_param);
        out.uses_pow_slice |= plan.has_powers();
        let (tokens, sign) = method(g, f, l, &plan, kind, k_names);
        out.uses_sign |= sign;
        out.methods.push(tokens);
        match kind {
            Kind::Invert => out.invert = true,
            Kind::Outputs => out.outputs = true,
            Kind::Sensitivity => out.sensitivity = true,
        }
    }
    out
}

/// The batch method for `f` (`invert` or `outputs`) and whether it calls `sign`.
fn method(
    g: &Gen<'_>,
    f: &Straight,
    l: &Lowered,
    plan: &Split,
    kind: Kind,
    k_names: &HashMap<usize, Ident>,
) -> (TokenStream, bool) {
    let k = Kernel::new(g, f, l, plan, kind, k_names);
    let loops = k.loops();
    let (params, slices) = k.columns();
    let parts = k.parts();
    let doc = k.doc(parts.doc);
    let scratch = k.scratch(parts.buffers);
    let p_let = if k.uses_p.get() {
        quote!(let p = &self.params;)
    } else {
        quote!()
    };
    let allow_clamp = if k.clamp_like.get() {
        quote!(#[allow(clippy::manual_clamp)])
    } else {
        quote!()
    };
    let (name, length, outputs_params, copies, tail) = (
        parts.name,
        parts.length,
        parts.outputs_params,
        parts.copies,
        parts.tail,
    );
    // A kernel with its own block size shadows the module's `BLOCK` in its body.
    let block = match kind.block(k.buffered()) {
        Some(b) => {
            let b = lit(b);
            quote!(const BLOCK: usize = #b;)
        }
        None => quote!(),
    };
    let tokens = quote! {
        #doc
        #allow_clamp
        pub fn #name(&self, #(#params,)* #outputs_params) {
            #block
            #p_let
            #scratch
            for start in (0..#length).step_by(BLOCK) {
                let len = BLOCK.min(#length - start);
                let end = start + len;
                #slices
                #loops
                #copies
            }
            #tail
        }
    };
    (tokens, k.uses_sign.get())
}

/// The name bound by a `let NAME = …;` statement.
fn let_name(stmt: &TokenStream) -> Option<Ident> {
    match stmt.clone().into_iter().nth(1)? {
        proc_macro2::TokenTree::Ident(id) => Some(id),
        _ => None,
    }
}

/// Every identifier in `ts`, at any depth.
fn idents_in(ts: &TokenStream) -> HashSet<String> {
    let mut out = HashSet::new();
    let mut stack = vec![ts.clone()];
    while let Some(ts) = stack.pop() {
        for tt in ts {
            match tt {
                proc_macro2::TokenTree::Ident(id) => {
                    out.insert(id.to_string());
                }
                proc_macro2::TokenTree::Group(g) => stack.push(g.stream()),
                _ => {}
            }
        }
    }
    out
}

fn lit(i: usize) -> proc_macro2::Literal {
    proc_macro2::Literal::usize_unsuffixed(i)
}

/// One batch method being written: the function, its loop split, its block buffers (bases computed here,
/// powers, kept values, each by number) and what its code turned out to use.
struct Kernel<'a> {
    g: &'a Gen<'a>,
    f: &'a Straight,
    l: &'a Lowered,
    plan: &'a Split,
    kind: Kind,
    k_names: &'a HashMap<usize, Ident>,
    /// Bases computed here (a base that is an input column or a buffer already is used as it is).
    base_of: HashMap<Val, usize>,
    power_of: HashMap<usize, usize>,
    kept_of: HashMap<usize, usize>,
    /// Per map call taken a block at a time: (its group, its entry).
    map_of: HashMap<usize, (usize, usize)>,
    used_any: RefCell<HashSet<Symbol>>,
    uses_p: Cell<bool>,
    uses_sign: Cell<bool>,
    clamp_like: Cell<bool>,
    /// The results computed per point: every one, except for `sensitivity_batch`, whose invariant results
    /// (parameter-only partial derivatives, most of them 0) are filled once per call.
    varying: Vec<usize>,
    /// `sensitivity_batch`'s temporaries kept per block ([`Kernel::entry_loops`]), once its last loop is written.
    temps: Cell<usize>,
}

/// What differs between `invert_batch` and `outputs_batch`.
struct Parts {
    length: TokenStream,
    outputs_params: TokenStream,
    buffers: TokenStream,
    copies: TokenStream,
    name: Ident,
    doc: Vec<String>,
    /// After the blocks: `sensitivity_batch`'s invariant results.
    tail: TokenStream,
}

impl<'a> Kernel<'a> {
    fn new(
        g: &'a Gen<'a>,
        f: &'a Straight,
        l: &'a Lowered,
        plan: &'a Split,
        kind: Kind,
        k_names: &'a HashMap<usize, Ident>,
    ) -> Kernel<'a> {
        let mut base_of: HashMap<Val, usize> = HashMap::new();
        for l_ in 0..plan.loops.saturating_sub(1) {
            for v in plan.roots(l_, &[]) {
                if plan.kept.iter().all(|&(i, _)| Val::Loc(i) != v) {
                    let n = base_of.len();
                    base_of.entry(v).or_insert(n);
                }
            }
        }
        let power_of = plan
            .pows
            .iter()
            .enumerate()
            .map(|(j, p)| (p.op, j))
            .collect();
        let kept_of = plan
            .kept
            .iter()
            .enumerate()
            .map(|(j, &(i, _))| (i, j))
            .collect();
        let mut map_of = HashMap::new();
        for (j, m) in plan.maps.iter().enumerate() {
            map_of.extend(m.calls.iter().map(|&(i, k)| (i, (j, k))));
        }
        let atoms = Atoms::new(g, k_names);
        let varying = (0..l.roots.len())
            .filter(|&i| kind != Kind::Sensitivity || !atoms.is_param(l.roots[i]))
            .collect();
        Kernel {
            g,
            f,
            l,
            plan,
            kind,
            k_names,
            base_of,
            power_of,
            kept_of,
            map_of,
            used_any: RefCell::new(HashSet::new()),
            uses_p: Cell::new(false),
            uses_sign: Cell::new(false),
            clamp_like: Cell::new(false),
            varying,
            temps: Cell::new(0),
        }
    }

    /// Value `i` read from a block buffer in loop `lv`, if it is available there.
    fn given(&self, i: usize, lv: usize) -> Option<Ex> {
        if !self.plan.given(i, lv) {
            return None;
        }
        if let Some(&(j, e)) = self.map_of.get(&i) {
            // Entry e of point k: `out[e · len + k]` (`Map::partials2_batch`).
            let j = lit(j);
            return Some(Ex::atom(match e {
                0 => quote!(mapv[#j][k]),
                1 => quote!(mapv[#j][len + k]),
                e => {
                    let e = lit(e);
                    quote!(mapv[#j][#e * len + k])
                }
            }));
        }
        Some(match (self.power_of.get(&i), self.kept_of.get(&i)) {
            (Some(&j), _) => {
                let j = lit(j);
                Ex::atom(quote!(power[#j][k]))
            }
            (None, Some(&j)) => {
                let j = lit(j);
                Ex::atom(quote!(kept[#j][k]))
            }
            (None, None) => Ex::Lit(f64::NAN),
        })
    }

    /// The loops with the powers and the map calls between them.
    fn loops(&self) -> TokenStream {
        let mut loops = TokenStream::new();
        for lv in 0..self.plan.loops {
            loops.extend(self.loop_body(lv));
            for (j, p) in self.plan.pows.iter().enumerate() {
                if p.level == lv + 1 {
                    loops.extend(self.power(j, p, lv));
                }
            }
            for (j, m) in self.plan.maps.iter().enumerate() {
                if m.level == lv + 1 {
                    loops.extend(self.map_batch(j, m, lv));
                }
            }
        }
        loops
    }

    /// `partials2_batch` for map group `j` after loop `lv`: entry e of point k into `mapv[j][e · len + k]`;
    /// `values_batch` (entry 0 alone, the same number) when the group reads only the value.
    fn map_batch(&self, j: usize, m: &SliceMap, lv: usize) -> TokenStream {
        let a = self.source(m.args[0].0, lv);
        let (b, width) = match m.args.get(1) {
            Some(&(b, _)) => (self.source(b, lv), lit(9)),
            None => (quote!(&[]), lit(3)),
        };
        let (j, map) = (lit(j), lit(m.map));
        if m.calls.iter().all(|&(_, e)| e == 0) {
            return quote!(self.maps[#map].values_batch(#a, #b, &mut mapv[#j][..len]););
        }
        quote!(self.maps[#map].partials2_batch(#a, #b, &mut mapv[#j][..#width * len]);)
    }

    /// The block's values of `v` in loop `lv` as a `&[f64]` of `len` points: an input column, a power or map
    /// entry taken before, a value kept, or a base computed by a loop.
    fn source(&self, v: Val, lv: usize) -> TokenStream {
        match v {
            Val::Sym(s) if column_of(self.g, self.f, s).is_some() => {
                column_of(self.g, self.f, s).unwrap_or_default()
            }
            Val::Loc(i) if self.power_of.contains_key(&i) && self.plan.given(i, lv) => {
                let m = lit(self.power_of[&i]);
                quote!(&power[#m][..len])
            }
            Val::Loc(i) if self.map_of.contains_key(&i) && self.plan.given(i, lv) => {
                let (m, e) = self.map_of[&i];
                let (m, e) = (lit(m), lit(e));
                quote!(&mapv[#m][#e * len..][..len])
            }
            Val::Loc(i) if self.kept_of.contains_key(&i) => {
                let m = lit(self.kept_of[&i]);
                quote!(&kept[#m][..len])
            }
            v => match self.base_of.get(&v) {
                Some(&b) => {
                    let b = lit(b);
                    quote!(&base[#b][..len])
                }
                None => quote!(&[]),
            },
        }
    }

    /// One loop over the block: per point, the inputs it reads, its `let`s and its stores.
    fn loop_body(&self, lv: usize) -> TokenStream {
        let atoms = Atoms::new(self.g, self.k_names);
        let atom = |v: Val| atoms.ex(v);
        let given = |i: usize| self.given(i, lv);
        let last = lv + 1 == self.plan.loops;
        let roots: Vec<Val> = if last {
            self.varying.iter().map(|&i| self.l.roots[i]).collect()
        } else {
            self.plan.roots(lv, &[])
        };
        let mut block = emit::render_with(
            &self.l.arena,
            &roots,
            &loc,
            &atom,
            &given,
            &HashMap::new(),
            "t",
        );
        self.uses_sign.set(self.uses_sign.get() || block.uses_sign);
        self.clamp_like
            .set(self.clamp_like.get() || block.clamp_like);
        let lets = &block.lets;
        let stores = match (last, self.kind) {
            // Written by `entry_loops` below, result by result.
            (true, Kind::Sensitivity) => TokenStream::new(),
            (true, _) => self.results(std::mem::take(&mut block.roots)),
            (false, _) => self.stores(&roots, &block.roots),
        };
        self.uses_p.set(self.uses_p.get() || atoms.uses_p());
        let mut used = atoms.used();
        if last && self.kind == Kind::Invert {
            used.insert(self.g.d.yr);
        }
        let reads = self.reads(&used);
        self.used_any.borrow_mut().extend(used.iter().copied());
        if last && self.kind == Kind::Sensitivity {
            return self.entry_loops((lets, &block.roots), &used);
        }
        // A loop with nothing to compute (every base is a column or a buffer already) is left out.
        if stores.is_empty() {
            return quote!();
        }
        quote! {
            for k in 0..len {
                #reads
                #(#lets)*
                #stores
            }
        }
    }

    /// The results per point held in a block buffer: `sensitivity_batch`'s temporaries, or the results.
    fn buffered(&self) -> usize {
        match self.kind {
            Kind::Sensitivity => self.temps.get(),
            _ => self.varying.len(),
        }
    }

    /// `sensitivity_batch`'s last loop: the temporaries the results share (`let`s) computed per point and kept
    /// in the block buffer `temps`, then one loop per varying result e that reads the ones it uses and writes
    /// `out[e]` directly — only where `out[e]` is not empty: an entry the caller does not want is neither
    /// computed nor written (the chain rule reads a few rows and columns of the layout).
    fn entry_loops(
        &self,
        (lets, roots): (&[TokenStream], &[Ex]),
        used: &HashSet<Symbol>,
    ) -> TokenStream {
        // The inputs a piece of code reads, of those the loop reads.
        let reads_of = |idents: &HashSet<String>| {
            let own: HashSet<Symbol> = used
                .iter()
                .copied()
                .filter(|s| idents.contains(&self.g.locals[s].to_string()))
                .collect();
            self.reads(&own)
        };
        let names: Vec<Ident> = lets.iter().filter_map(let_name).collect();
        let reads = reads_of(&lets.iter().flat_map(idents_in).collect());
        self.temps.set(names.len());
        let keeps = names.iter().enumerate().map(|(j, n)| {
            let j = lit(j);
            quote!(temps[#j][k] = #n;)
        });
        let shared = if names.is_empty() {
            quote!()
        } else {
            quote! {
                for k in 0..len {
                    #reads
                    #(#lets)*
                    #(#keeps)*
                }
            }
        };
        let entries = self.varying.iter().zip(roots).map(|(&e, root)| {
            let expr = root.tokens(0);
            let idents = idents_in(&expr);
            let loads = names
                .iter()
                .enumerate()
                .filter(|(_, n)| idents.contains(&n.to_string()))
                .map(|(j, n)| {
                    let j = lit(j);
                    quote!(let #n = temps[#j][k];)
                });
            let reads = reads_of(&idents);
            let e = lit(e);
            quote! {
                if !out[#e].is_empty() {
                    for (k, slot) in out[#e][start..end].iter_mut().enumerate() {
                        #reads
                        #(#loads)*
                        *slot = #expr;
                    }
                }
            }
        });
        quote!(#shared #(#entries)*)
    }

    /// The last loop's stores: the states and the input, or the outputs.
    fn results(&self, items: Vec<Ex>) -> TokenStream {
        match self.kind {
            Kind::Invert => {
                let (extra, xs, u) = invert_result(items, self.f.beta_recip);
                let xs = xs.iter().enumerate().map(|(s, e)| {
                    let (s, e) = (lit(s), e.tokens(0));
                    quote!(states[#s][k] = #e;)
                });
                let u = u.tokens(0);
                quote!(#extra #(#xs)* input[k] = #u;)
            }
            Kind::Outputs | Kind::Sensitivity => {
                let outs = items.iter().enumerate().map(|(o, e)| {
                    let (o, e) = (lit(o), e.tokens(0));
                    quote!(values[#o][k] = #e;)
                });
                quote!(#(#outs)*)
            }
        }
    }

    /// An earlier loop's stores: the next level's bases and the values kept for later loops.
    fn stores(&self, roots: &[Val], items: &[Ex]) -> TokenStream {
        roots
            .iter()
            .zip(items)
            .map(|(v, e)| {
                let e = e.tokens(0);
                match loc(*v).and_then(|i| self.kept_of.get(&i)) {
                    Some(&j) => {
                        let j = lit(j);
                        quote!(kept[#j][k] = #e;)
                    }
                    None => {
                        let j = lit(self.base_of.get(v).copied().unwrap_or(0));
                        quote!(base[#j][k] = #e;)
                    }
                }
            })
            .collect()
    }

    /// Per point: the inputs it reads, from the block's columns.
    fn reads(&self, used: &HashSet<Symbol>) -> TokenStream {
        let g = self.g;
        let mut reads = TokenStream::new();
        let yr = (self.kind == Kind::Invert).then_some(Arg::Scalar(g.d.yr));
        for a in self.f.args.iter().cloned().chain(yr) {
            match a {
                Arg::Array { name, syms, .. } => {
                    if syms.iter().any(|s| used.contains(s)) {
                        let pats = syms.iter().map(|s| {
                            if used.contains(s) {
                                g.locals[s].to_token_stream()
                            } else {
                                quote!(_)
                            }
                        });
                        let name = format_ident!("{}", name);
                        reads.extend(quote!(let [#(#pats),*] = #name.map(|c| c[k]);));
                    }
                }
                Arg::Scalar(s) => {
                    if used.contains(&s) {
                        let id = &g.locals[&s];
                        reads.extend(quote!(let #id = #id[k];));
                    }
                }
            }
        }
        reads
    }

    /// `pow_pos_slice` for power `j` after loop `lv`, or the loop of its function call (the same call as
    /// the per-point code's, so the same number).
    fn power(&self, j: usize, p: &SlicePow, lv: usize) -> TokenStream {
        // A base that is itself taken a block at a time is an earlier entry of the same buffer (numbered
        // by level): the buffer is split there, so that one part is read while the other is written.
        let earlier = match p.base {
            Val::Loc(i) if self.power_of.contains_key(&i) && self.plan.given(i, lv) => {
                Some(self.power_of[&i])
            }
            _ => None,
        };
        if let Some(m) = earlier {
            let (m, at) = (lit(m), lit(j));
            let inner = self.power_with(p, quote!(&done[#m][..len]), quote!(rest[0]));
            return quote! {
                {
                    let (done, rest) = power.split_at_mut(#at);
                    #inner
                }
            };
        }
        let source = self.source(p.base, lv);
        let j = lit(j);
        self.power_with(p, source, quote!(power[#j]))
    }

    /// [`Kernel::power`] from `source` into the buffer `target`.
    fn power_with(&self, p: &SlicePow, source: TokenStream, target: TokenStream) -> TokenStream {
        match p.what {
            Sliced::Pow(exponent) => {
                let atoms = Atoms::new(self.g, self.k_names);
                let exponent = atoms.tokens(exponent);
                self.uses_p.set(self.uses_p.get() || atoms.uses_p());
                quote!(pow_pos_slice(#source, #exponent, &mut #target[..len]);)
            }
            Sliced::Call(f) => {
                let f = format_ident!("{}", emit::method(f));
                quote! {
                    for (v, b) in #target[..len].iter_mut().zip(#source) {
                        *v = b.#f();
                    }
                }
            }
        }
    }

    /// The column arguments and the block's slices of them (after the loops, which record what is read).
    fn columns(&self) -> (Vec<TokenStream>, TokenStream) {
        let used_any = self.used_any.borrow();
        // The inputs read as whole columns: powers' bases and maps' arguments.
        let mut sliced: Vec<Val> = self.plan.pows.iter().map(|p| p.base).collect();
        for m in &self.plan.maps {
            sliced.extend(m.args.iter().map(|a| a.0));
        }
        let mut params = Vec::new();
        let mut slices = TokenStream::new();
        for a in &self.f.args {
            match a {
                Arg::Array { name, len, syms } => {
                    let len_id = format_ident!("{}", len);
                    let any = syms.iter().any(|s| used_any.contains(s))
                        || sliced
                            .iter()
                            .any(|v| matches!(v, Val::Sym(s) if syms.contains(s)));
                    let id = format_ident!("{}", name);
                    if any {
                        params.push(quote!(#id: [&[f64]; #len_id]));
                        slices.extend(quote!(let #id = #id.map(|c| &c[start..end]);));
                    } else {
                        let unused = format_ident!("_{}", name);
                        params.push(quote!(#unused: [&[f64]; #len_id]));
                    }
                }
                Arg::Scalar(s) => {
                    // Named even when no point reads it: its length is the number of points.
                    let id = &self.g.locals[s];
                    params.push(quote!(#id: &[f64]));
                    let base = sliced.contains(&Val::Sym(*s));
                    if used_any.contains(s) || base {
                        slices.extend(quote!(let #id = &#id[start..end];));
                    }
                }
            }
        }
        if self.kind == Kind::Invert {
            params.push(quote!(yr: &[f64]));
            slices.extend(quote!(let yr = &yr[start..end];));
        }
        (params, slices)
    }

    /// The input column whose length is the number of points.
    fn length_column(&self) -> String {
        match self.kind {
            Kind::Invert => "yr".to_string(),
            Kind::Outputs | Kind::Sensitivity => {
                self.g.locals[&self.g.d.model.input.symbol].to_string()
            }
        }
    }

    fn parts(&self) -> Parts {
        match self.kind {
            Kind::Invert => Parts {
                length: quote!(yr.len()),
                outputs_params: quote!(mut x: [&mut [f64]; N], u: &mut [f64]),
                buffers: quote!(let mut states = [[0.0; BLOCK]; N]; let mut input = [0.0; BLOCK];),
                copies: quote! {
                    for (column, buffer) in x.iter_mut().zip(&states) {
                        column[start..end].copy_from_slice(&buffer[..len]);
                    }
                    u[start..end].copy_from_slice(&input[..len]);
                },
                tail: quote!(),
                name: format_ident!("invert_batch"),
                doc: vec![
                    "[`Precomputed::invert`] at many points, stored column-wise: ξ_i at point k is `xi[i][k]`, η_j \
                     is `eta[j][k]`, y^(r) is `yr[k]`; x_s is written to `x[s][k]` and u to `u[k]`."
                        .to_string(),
                ],
            },
            Kind::Outputs => {
                let u = &self.g.locals[&self.g.d.model.input.symbol];
                Parts {
                    length: quote!(#u.len()),
                    outputs_params: quote!(mut out: [&mut [f64]; N_OUTPUTS]),
                    buffers: quote!(let mut values = [[0.0; BLOCK]; N_OUTPUTS];),
                    copies: quote! {
                        for (column, buffer) in out.iter_mut().zip(&values) {
                            column[start..end].copy_from_slice(&buffer[..len]);
                        }
                    },
                    tail: quote!(),
                    name: format_ident!("outputs_batch"),
                    doc: vec![format!(
                        "[`Precomputed::outputs`] at many points, stored column-wise: x_s at point k is `x[s][k]`, \
                         the input `{u}[k]`; output o is written to `out[o][k]`."
                    )],
                }
            }
            Kind::Sensitivity => {
                let u = &self.g.locals[&self.g.d.model.input.symbol];
                let temps = self.temps.get();
                let atoms = Atoms::new(self.g, self.k_names);
                let fills: Vec<TokenStream> = (0..self.l.roots.len())
                    .filter(|e| self.varying.binary_search(e).is_err())
                    .map(|e| {
                        let value = atoms.tokens(self.l.roots[e]);
                        let e = lit(e);
                        quote!(if !out[#e].is_empty() { out[#e][..points].fill(#value); })
                    })
                    .collect();
                self.uses_p.set(self.uses_p.get() || atoms.uses_p());
                Parts {
                    length: quote!(#u.len()),
                    outputs_params: quote!(out: [&mut [f64]; N_SENS], invariant: bool),
                    buffers: if temps == 0 {
                        quote!()
                    } else {
                        let temps = lit(temps);
                        quote!(let mut temps = [[0.0; BLOCK]; #temps];)
                    },
                    copies: quote!(),
                    tail: quote! {
                        if invariant {
                            let points = #u.len();
                            #(#fills)*
                        }
                    },
                    name: format_ident!("sensitivity_batch"),
                    doc: vec![format!(
                        "[`Precomputed::sensitivity`] at many points, stored column-wise: x_s at point k is \
                         `x[s][k]`, the input `{u}[k]`; entry e is written to `out[e][k]`, the entries that \
                         depend on no point (parameter-only) only where `invariant` is true; an empty `out[e]` \
                         is an entry not wanted, neither computed nor written."
                    )],
                }
            }
        }
    }

    /// The method's documentation, from its first paragraph.
    fn doc(&self, mut doc: Vec<String>) -> TokenStream {
        doc.push(String::new());
        let mut at_once = Vec::new();
        if self.plan.has_powers() {
            at_once.push("the fractional powers of a block at once, by [`pow_pos_slice`] (within 1 ulp of `powf`)");
        }
        if self.plan.has_calls() {
            at_once.push("the calls of transcendental functions in loops of their own");
        }
        if self.plan.has_maps() {
            at_once.push("the map calls of a block at once, by `Map::partials2_batch` or, where only the value is read, `Map::values_batch` (bit for bit `partials2`)");
        }
        let block = match self.kind.block(self.buffered()) {
            Some(b) => format!("{b} points, the body's own `BLOCK`"),
            None => "[`BLOCK`] points".to_string(),
        };
        doc.push(if at_once.is_empty() {
            format!("Block by block ({block}), point by point in loops that vectorise.")
        } else {
            format!(
                "Block by block ({block}): {}, everything else point by point in loops that vectorise.",
                at_once.join("; ")
            )
        });
        doc.push(String::new());
        doc.push("# Panics".to_string());
        doc.push(String::new());
        doc.push(format!(
            "If a column is shorter than `{}`.",
            self.length_column()
        ));
        doc_attrs(&doc)
    }

    /// The block buffers on the stack.
    fn scratch(&self, buffers: TokenStream) -> TokenStream {
        let mut scratch = TokenStream::new();
        if !self.base_of.is_empty() {
            let n = lit(self.base_of.len());
            scratch.extend(quote!(let mut base = [[0.0; BLOCK]; #n];));
        }
        if !self.plan.pows.is_empty() {
            let n = lit(self.plan.pows.len());
            scratch.extend(quote!(let mut power = [[0.0; BLOCK]; #n];));
        }
        if !self.plan.kept.is_empty() {
            let n = lit(self.plan.kept.len());
            scratch.extend(quote!(let mut kept = [[0.0; BLOCK]; #n];));
        }
        if self.plan.has_maps() {
            let n = lit(self.plan.maps.len());
            scratch.extend(quote!(let mut mapv = vec![[0.0; 9 * BLOCK]; #n];));
        }
        scratch.extend(buffers);
        scratch
    }
}

/// The block's column of input symbol `s` (a `&[f64]` expression), if `f` takes it.
fn column_of(g: &Gen<'_>, f: &Straight, s: Symbol) -> Option<TokenStream> {
    for a in &f.args {
        match a {
            Arg::Array { name, syms, .. } => {
                if let Some(i) = syms.iter().position(|&t| t == s) {
                    let name = format_ident!("{}", name);
                    let i = proc_macro2::Literal::usize_unsuffixed(i);
                    return Some(quote!(#name[#i]));
                }
            }
            Arg::Scalar(t) if *t == s => {
                let id = &g.locals[t];
                return Some(quote!(#id));
            }
            Arg::Scalar(_) => {}
        }
    }
    (s == g.d.yr).then(|| quote!(yr))
}

#[cfg(test)]
mod tests {
    use super::*;
    use invsim_expr::lower::{self, Invariants, Strategy};
    use invsim_expr::map::{Map, MapSettings};
    use invsim_expr::{MapDecl, Pool};
    use std::sync::Arc;

    /// The loop split of `src` with parameters `params` and the single input `v` (and `s`).
    fn plan_of(src: &str, params: &[&str]) -> (Split, Arena) {
        let mut pool = Pool::new();
        let m = Map::new_2d(
            vec![0.0, 1.0, 2.0],
            vec![0.0, 1.0],
            vec![1.0, 2.0, 0.5, 1.5, 3.0, 1.0],
            MapSettings::default(),
        )
        .unwrap();
        pool.declare_map(MapDecl::new("m", Arc::new(m)));
        let c = Map::new_1d(
            vec![0.0, 1.0, 3.0],
            vec![1.0, 2.0, 0.5],
            MapSettings::default(),
        );
        pool.declare_map(MapDecl::new("c", Arc::new(c.unwrap())));
        let e = pool.parse(src).unwrap();
        let ps: Vec<Symbol> = params.iter().map(|n| pool.symbol(n)).collect();
        let inputs = [pool.symbol("v"), pool.symbol("s")];
        let mut inv = Invariants::new(&pool, &ps, Strategy::GENERATED);
        let l = lower::lower(&mut inv, &[e], &inputs).unwrap();
        let is_param = |v: Val| match v {
            Val::Sym(s) => ps.contains(&s),
            Val::Num(_) | Val::Pi | Val::Inv(_) => true,
            Val::Loc(_) => false,
        };
        (Split::new(&l.arena, &l.roots, &is_param), l.arena)
    }

    fn levels(p: &Split) -> Vec<usize> {
        p.pows.iter().map(|q| q.level).collect()
    }

    #[test]
    fn one_power_two_loops() {
        let (p, _) = plan_of("v*(1 + v^2)^0.3", &[]);
        assert_eq!((levels(&p), p.loops, p.kept.len()), (vec![1], 2, 0));
        // Loop 0 computes the base 1 + v².
        assert_eq!(p.roots(0, &[]).len(), 1);
    }

    #[test]
    fn a_power_of_an_input_needs_no_base_loop() {
        let (p, _) = plan_of("v^0.8 + v", &[]);
        assert_eq!((levels(&p), p.loops), (vec![1], 2));
        assert!(p.roots(0, &[]).is_empty());
    }

    #[test]
    fn nested_powers_and_a_shared_call_take_a_level_each() {
        let (p, arena) = plan_of("(2 + (1 + exp(-v))^0.3)^0.7 + exp(-v)", &[]);
        assert_eq!((levels(&p), p.loops, p.kept.len()), (vec![1, 2, 3], 4, 0));
        // exp(−v) is taken in a loop of its own after loop 0 (which computes −v) and read from its buffer by
        // the inner base's loop and the last.
        let call = p.pows[0].op;
        assert!(matches!(arena.ops()[call], Op::Call(Func::Exp, _)));
        assert!(p.given(call, 1) && p.given(call, 3) && !p.given(call, 0));
        assert!(p.has_powers() && p.has_calls());
    }

    #[test]
    fn calls_take_a_loop_of_their_own() {
        let (p, arena) = plan_of("tanh(2*v) + v", &[]);
        assert_eq!((levels(&p), p.loops), (vec![1], 2));
        assert!(matches!(p.pows[0].what, Sliced::Call(Func::Tanh)));
        // Loop 0 computes the argument 2v; the last reads tanh from its buffer.
        assert_eq!(p.roots(0, &[]).len(), 1);
        assert!(p.given(p.pows[0].op, 1) && matches!(arena.ops()[p.pows[0].op], Op::Call(..)));
        assert!(!p.has_powers() && p.has_calls());
        // A call of an input needs no argument loop; abs and sign stay point by point.
        let (p, _) = plan_of("exp(v) + abs(s)", &[]);
        assert_eq!((levels(&p), p.loops), (vec![1], 2));
        assert!(p.roots(0, &[]).is_empty());
    }

    #[test]
    fn parameter_exponents_are_taken_a_block_at_a_time_varying_ones_are_not() {
        let (p, _) = plan_of("(1 + v^2)^(g - 1)", &["g"]);
        assert_eq!(levels(&p), vec![1]);
        assert!(matches!(p.pows[0].what, Sliced::Pow(Val::Inv(_))));
        let (p, _) = plan_of("(1 + v^2)^s", &[]);
        assert!(!p.has_powers());
        assert_eq!(p.loops, 1);
    }

    #[test]
    fn a_kept_value_can_be_a_base() {
        let (p, arena) = plan_of("(v^s)^0.3 + v^s", &[]);
        assert_eq!((levels(&p), p.kept.len()), (vec![1], 1));
        // v^s (a varying exponent: not taken a block at a time) is computed once, in loop 0, as a kept value
        // (and not also as a base).
        let roots = p.roots(0, &[]);
        assert_eq!(roots.len(), 1);
        assert!(matches!(arena.ops()[p.kept[0].0], Op::PowVar(..)));
    }

    #[test]
    fn powers_of_one_base_share_its_loop() {
        let (p, _) = plan_of("(1 + v^2)^a + (1 + v^2)^b", &["a", "b"]);
        assert_eq!(levels(&p), vec![1, 1]);
        assert_eq!(p.roots(0, &[]).len(), 1, "one base for both powers");
    }

    fn map_levels(p: &Split) -> Vec<(usize, usize)> {
        p.maps.iter().map(|m| (m.level, m.calls.len())).collect()
    }

    #[test]
    fn calls_of_one_map_at_the_same_arguments_share_one_batch() {
        let (p, _) = plan_of("m(2*v, s) + v*m_d10(2*v, s) + m_d02(2*v, s)", &[]);
        assert_eq!((map_levels(&p), p.loops), (vec![(1, 3)], 2));
        // Loop 0 computes the argument 2v; s is a column.
        assert_eq!(p.roots(0, &[]), vec![p.maps[0].args[0].0]);
        assert!(p.maps[0].args[1].1);
    }

    #[test]
    fn a_map_of_a_map_and_a_power_of_a_map_take_levels() {
        let (p, _) = plan_of("c(m(v, s)^0.3) + c(m(v, s))", &[]);
        // m at level 1 (its arguments are columns), the power at 2, c of the power at 3, c of m at 2.
        assert_eq!(map_levels(&p), vec![(1, 1), (2, 1), (3, 1)]);
        assert_eq!((levels(&p), p.loops), (vec![2], 4));
        assert!(p.roots(0, &[]).is_empty());
    }

    #[test]
    fn orders_above_two_stay_point_by_point() {
        let (p, _) = plan_of("c_d3(v) + m_d30(v, s)", &[]);
        assert!(!p.has_maps());
        assert_eq!(p.loops, 1);
    }
}
