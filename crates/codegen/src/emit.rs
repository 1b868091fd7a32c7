//! Printing lowered code as Rust tokens: common subexpressions as `let` bindings, expressions with only the
//! parentheses evaluation order needs, typed `f64` literals.
//!
//! A value of an arena becomes `let tN = …;` when it is used two or more times (counted over everything the
//! block computes, with `v * v` for `powi(v, 2)` counting twice) or when the caller names it; any other value
//! is written inline where it is used. Bindings come in arena order, which is topological.
//!
//! Parentheses follow Rust's precedence with floating-point evaluation order preserved: `a - (b - c)` keeps
//! its parentheses (floating-point `−` is not associative), `a - b - c` needs none.

use invsim_expr::lower::{Arena, Op, Val};
use invsim_expr::{Func, Func2};
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{quote, ToTokens};
use std::collections::HashMap;

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
}

impl BinOp {
    fn prec(self) -> u8 {
        match self {
            BinOp::Add | BinOp::Sub => 1,
            BinOp::Mul | BinOp::Div => 2,
        }
    }
}

/// A Rust expression of type `f64`.
#[derive(Clone, Debug)]
pub(crate) enum Ex {
    /// An identifier, field access or path.
    Atom(TokenStream),
    Lit(f64),
    Int(i32),
    Bin(BinOp, Box<Ex>, Box<Ex>),
    Neg(Box<Ex>),
    /// `receiver.method(args)`.
    Method(Box<Ex>, &'static str, Vec<Ex>),
    /// `function(args)`.
    Call(&'static str, Vec<Ex>),
}

const P_NEG: u8 = 3;
const P_ATOM: u8 = 4;

impl Ex {
    pub fn atom(tokens: TokenStream) -> Ex {
        Ex::Atom(tokens)
    }
    pub fn bin(op: BinOp, a: Ex, b: Ex) -> Ex {
        Ex::Bin(op, Box::new(a), Box::new(b))
    }

    fn prec(&self) -> u8 {
        match self {
            Ex::Lit(x) if x.is_sign_negative() && !x.is_nan() => P_NEG,
            Ex::Neg(_) => P_NEG,
            Ex::Bin(op, ..) => op.prec(),
            Ex::Atom(_) | Ex::Lit(_) | Ex::Int(_) | Ex::Method(..) | Ex::Call(..) => P_ATOM,
        }
    }

    fn starts_with_minus(&self) -> bool {
        match self {
            Ex::Lit(x) => x.is_sign_negative() && !x.is_nan(),
            Ex::Neg(_) => true,
            Ex::Bin(_, a, _) => a.starts_with_minus(),
            _ => false,
        }
    }

    /// A method call whose receiver chain starts at a numeric literal (`2.0_f64.sqrt()`): `-` in front of
    /// it reads ambiguously (clippy's `precedence`), so it gets parentheses.
    fn is_literal_method(&self) -> bool {
        match self {
            Ex::Method(r, ..) => matches!(**r, Ex::Lit(_)) || r.is_literal_method(),
            _ => false,
        }
    }

    /// Tokens, parenthesised if this expression binds looser than `min_prec`.
    pub fn tokens(&self, min_prec: u8) -> TokenStream {
        let inner = self.bare(false);
        if self.prec() < min_prec {
            quote!((#inner))
        } else {
            inner
        }
    }

    fn bare(&self, receiver: bool) -> TokenStream {
        match self {
            Ex::Atom(t) => t.clone(),
            Ex::Lit(x) => float_tokens(*x, receiver),
            Ex::Int(i) => Literal::i32_unsuffixed(*i).into_token_stream(),
            Ex::Bin(op, a, b) => {
                let p = op.prec();
                let (a, b) = (a.tokens(p), b.tokens(p + 1));
                match op {
                    BinOp::Add => quote!(#a + #b),
                    BinOp::Sub => quote!(#a - #b),
                    BinOp::Mul => quote!(#a * #b),
                    BinOp::Div => quote!(#a / #b),
                }
            }
            Ex::Neg(a) => {
                let inner = if a.starts_with_minus() || a.is_literal_method() || a.prec() < P_NEG {
                    let t = a.bare(false);
                    quote!((#t))
                } else {
                    a.bare(false)
                };
                quote!(-#inner)
            }
            Ex::Method(r, name, args) => {
                let recv = if r.prec() < P_ATOM {
                    let t = r.bare(true);
                    quote!((#t))
                } else {
                    r.bare(true)
                };
                let m = Ident::new(name, Span::call_site());
                let args = args.iter().map(|a| a.tokens(0));
                quote!(#recv.#m(#(#args),*))
            }
            Ex::Call(name, args) => {
                let f = Ident::new(name, Span::call_site());
                let args = args.iter().map(|a| a.tokens(0));
                quote!(#f(#(#args),*))
            }
        }
    }
}

/// Named constants of `std::f64::consts` that a literal must be spelled as (clippy's `approx_constant`
/// rejects their digits).
const STD_CONSTS: &[(&str, f64)] = &[
    ("PI", std::f64::consts::PI),
    ("TAU", std::f64::consts::TAU),
    ("E", std::f64::consts::E),
    ("FRAC_1_PI", std::f64::consts::FRAC_1_PI),
    ("FRAC_1_SQRT_2", std::f64::consts::FRAC_1_SQRT_2),
    ("FRAC_2_PI", std::f64::consts::FRAC_2_PI),
    ("FRAC_2_SQRT_PI", std::f64::consts::FRAC_2_SQRT_PI),
    ("FRAC_PI_2", std::f64::consts::FRAC_PI_2),
    ("FRAC_PI_3", std::f64::consts::FRAC_PI_3),
    ("FRAC_PI_4", std::f64::consts::FRAC_PI_4),
    ("FRAC_PI_6", std::f64::consts::FRAC_PI_6),
    ("FRAC_PI_8", std::f64::consts::FRAC_PI_8),
    ("LN_2", std::f64::consts::LN_2),
    ("LN_10", std::f64::consts::LN_10),
    ("LOG2_10", std::f64::consts::LOG2_10),
    ("LOG2_E", std::f64::consts::LOG2_E),
    ("LOG10_2", std::f64::consts::LOG10_2),
    ("LOG10_E", std::f64::consts::LOG10_E),
    ("SQRT_2", std::f64::consts::SQRT_2),
];

/// The digits of a finite, non-negative f64 as a Rust float literal that parses back to the same value:
/// the shortest round-trip form, always with a `.` or an exponent (`1300.0`, `0.075`, `4.4e7`).
pub(crate) fn float_text(x: f64) -> String {
    let s = format!("{x:?}");
    if s.contains(['.', 'e', 'E']) {
        s
    } else {
        format!("{s}.0")
    }
}

/// Tokens for an f64 constant; `receiver`: it is the receiver of a method call, so it needs a type suffix.
pub(crate) fn float_tokens(x: f64, receiver: bool) -> TokenStream {
    if x.is_nan() {
        return quote!(f64::NAN);
    }
    if x.is_infinite() {
        return if x > 0.0 {
            quote!(f64::INFINITY)
        } else {
            quote!(f64::NEG_INFINITY)
        };
    }
    let neg = x.is_sign_negative() && x != 0.0;
    let mag = x.abs();
    let body = if mag == std::f64::consts::PI {
        // The module imports `std::f64::consts::PI`.
        quote!(PI)
    } else if let Some((name, _)) = STD_CONSTS.iter().find(|(_, v)| *v == mag) {
        let id = Ident::new(name, Span::call_site());
        quote!(std::f64::consts::#id)
    } else {
        let text = float_text(mag);
        let text = if receiver {
            format!("{text}_f64")
        } else {
            text
        };
        text.parse::<Literal>()
            .map(|l| l.into_token_stream())
            .unwrap_or_else(|_| quote!(f64::NAN))
    };
    if neg {
        quote!(-#body)
    } else {
        body
    }
}

/// Would clippy's `approx_constant` take this literal text (digits without suffix) for an approximation of
/// a `std::f64::consts` value? (The same test clippy applies.)
pub(crate) fn looks_like_std_constant(text: &str) -> bool {
    let min_digits = |name: &str| {
        if matches!(name, "PI" | "TAU") {
            3
        } else if matches!(name, "E" | "FRAC_1_PI") {
            4
        } else {
            5
        }
    };
    STD_CONSTS.iter().any(|(name, c)| {
        if text.len() <= min_digits(name) {
            false
        } else if c.to_string().starts_with(text) {
            true
        } else {
            format!("{c:.*}", text.len().saturating_sub(2)) == text
        }
    })
}

/// The method name of a one-argument function of the model language.
pub(crate) fn method(f: Func) -> &'static str {
    match f {
        Func::Exp => "exp",
        Func::Log => "ln",
        Func::Sin => "sin",
        Func::Cos => "cos",
        Func::Tan => "tan",
        Func::Sinh => "sinh",
        Func::Cosh => "cosh",
        Func::Tanh => "tanh",
        Func::Atan => "atan",
        Func::Abs => "abs",
        Func::Sign => "sign",
    }
}

/// A block of straight-line code: `let` statements and the expressions of its results.
pub(crate) struct Block {
    pub lets: Vec<TokenStream>,
    pub roots: Vec<Ex>,
    /// Does the code call the module's `sign` helper?
    pub uses_sign: bool,
    /// Does it contain `x.max(a).min(b)` or `x.min(b).max(a)` (which clippy would have written `clamp`)?
    pub clamp_like: bool,
}

const USES_SIGN: u8 = 1;
const CLAMP_LIKE: u8 = 2;

/// Print `roots` (values of `arena` or atoms) with common subexpressions bound.
///
/// * `index`: the arena position of a value, if it is one of this arena's;
/// * `atom`: how to print any other value (symbols, constants, the other arena);
/// * `fixed`: names the caller assigns to arena values (always bound);
/// * `temp`: prefix of the temporaries' names.
pub(crate) fn render(
    arena: &Arena,
    roots: &[Val],
    index: &dyn Fn(Val) -> Option<usize>,
    atom: &dyn Fn(Val) -> Ex,
    fixed: &HashMap<usize, Ident>,
    temp: &str,
) -> Block {
    render_full(arena, roots, index, atom, &|_| None, fixed, temp, true)
}

/// [`render`] for a function whose map calls are at new points on every call (Newton's iterates): they call
/// `Map::partials2_fresh` (no per-thread memo; the same numbers as `partials2`).
pub(crate) fn render_fresh(
    arena: &Arena,
    roots: &[Val],
    index: &dyn Fn(Val) -> Option<usize>,
    atom: &dyn Fn(Val) -> Ex,
    fixed: &HashMap<usize, Ident>,
    temp: &str,
) -> Block {
    render_full(arena, roots, index, atom, &|_| None, fixed, temp, false)
}

/// [`render`], with some arena values computed elsewhere: `given(i)` is the expression that stands for value
/// `i` (bound or inlined like any other value; its operands are not computed here).
pub(crate) fn render_with(
    arena: &Arena,
    roots: &[Val],
    index: &dyn Fn(Val) -> Option<usize>,
    atom: &dyn Fn(Val) -> Ex,
    given: &dyn Fn(usize) -> Option<Ex>,
    fixed: &HashMap<usize, Ident>,
    temp: &str,
) -> Block {
    render_full(arena, roots, index, atom, given, fixed, temp, true)
}

/// [`render_with`]; the map calls through the per-thread memo (`partials2`) if `memo`, else
/// `partials2_fresh`.
#[allow(clippy::too_many_arguments)]
fn render_full(
    arena: &Arena,
    roots: &[Val],
    index: &dyn Fn(Val) -> Option<usize>,
    atom: &dyn Fn(Val) -> Ex,
    given: &dyn Fn(usize) -> Option<Ex>,
    fixed: &HashMap<usize, Ident>,
    temp: &str,
    memo: bool,
) -> Block {
    let map_fn = if memo {
        quote!(partials2)
    } else {
        quote!(partials2_fresh)
    };
    let n = arena.ops().len();
    let mut reachable = vec![false; n];
    let mut stack: Vec<usize> = roots.iter().filter_map(|&v| index(v)).collect();
    while let Some(i) = stack.pop() {
        if !reachable[i] {
            reachable[i] = true;
            if given(i).is_none() {
                stack.extend(arena.ops()[i].operands().into_iter().filter_map(index));
            }
        }
    }
    let mut uses = vec![0usize; n];
    for (i, op) in arena.ops().iter().enumerate() {
        if reachable[i] && given(i).is_none() {
            for v in op.operands() {
                if let Some(j) = index(v) {
                    uses[j] += 1;
                }
            }
        }
    }
    for &r in roots {
        if let Some(j) = index(r) {
            uses[j] += 1;
        }
    }
    let bundles = map_bundles(arena, &reachable, given, temp);
    let given = &|i: usize| given(i).or_else(|| bundles.member(i));
    let mut names: Vec<Option<Ident>> = vec![None; n];
    let mut lets = Vec::new();
    let mut flags = 0u8;
    let mut counter = 0;
    for i in 0..n {
        if let Some((name, m, args)) = bundles.starts_at(i) {
            let args: Vec<TokenStream> = args
                .iter()
                .map(|&a| val_ex(a, arena, &names, index, atom, given, &mut flags).tokens(0))
                .collect();
            let m = Literal::usize_unsuffixed(m);
            lets.push(quote!(let #name = self.maps[#m].#map_fn(&[#(#args),*]);));
        }
        if !reachable[i] || (uses[i] < 2 && !fixed.contains_key(&i)) {
            continue;
        }
        let name = fixed.get(&i).cloned().unwrap_or_else(|| {
            let id = Ident::new(&format!("{temp}{counter}"), Span::call_site());
            counter += 1;
            id
        });
        let ex = match given(i) {
            Some(e) => e,
            None => op_ex(
                arena.ops()[i],
                arena,
                &names,
                index,
                atom,
                given,
                &mut flags,
            ),
        };
        let t = ex.tokens(0);
        lets.push(quote!(let #name = #t;));
        names[i] = Some(name);
    }
    let roots = roots
        .iter()
        .map(|&v| val_ex(v, arena, &names, index, atom, given, &mut flags))
        .collect();
    Block {
        lets,
        roots,
        uses_sign: flags & USES_SIGN != 0,
        clamp_like: flags & CLAMP_LIKE != 0,
    }
}

fn val_ex(
    v: Val,
    arena: &Arena,
    names: &[Option<Ident>],
    index: &dyn Fn(Val) -> Option<usize>,
    atom: &dyn Fn(Val) -> Ex,
    given: &dyn Fn(usize) -> Option<Ex>,
    flags: &mut u8,
) -> Ex {
    match index(v) {
        Some(i) => match &names[i] {
            Some(name) => Ex::Atom(name.to_token_stream()),
            None => match given(i) {
                Some(e) => e,
                None => op_ex(arena.ops()[i], arena, names, index, atom, given, flags),
            },
        },
        None => atom(v),
    }
}

fn op_ex(
    op: Op,
    arena: &Arena,
    names: &[Option<Ident>],
    index: &dyn Fn(Val) -> Option<usize>,
    atom: &dyn Fn(Val) -> Ex,
    given: &dyn Fn(usize) -> Option<Ex>,
    flags: &mut u8,
) -> Ex {
    let mut e = |v: Val| val_ex(v, arena, names, index, atom, given, flags);
    match op {
        Op::Add(a, b) => Ex::bin(BinOp::Add, e(a), e(b)),
        Op::Sub(a, b) => Ex::bin(BinOp::Sub, e(a), e(b)),
        Op::Mul(a, b) => Ex::bin(BinOp::Mul, e(a), e(b)),
        Op::Div(a, b) => Ex::bin(BinOp::Div, e(a), e(b)),
        Op::Neg(a) => Ex::Neg(Box::new(e(a))),
        Op::Recip(a) => Ex::bin(BinOp::Div, Ex::Lit(1.0), e(a)),
        Op::Powi(a, 0) => {
            let _ = a;
            Ex::Lit(1.0)
        }
        Op::Powi(a, 1) => e(a),
        Op::Powi(a, 2) => {
            let x = e(a);
            Ex::bin(BinOp::Mul, x.clone(), x)
        }
        Op::Powi(a, 3) => {
            let x = e(a);
            Ex::bin(BinOp::Mul, Ex::bin(BinOp::Mul, x.clone(), x.clone()), x)
        }
        Op::Powi(a, k) => Ex::Method(Box::new(e(a)), "powi", vec![Ex::Int(k)]),
        Op::Sqrt(a) => Ex::Method(Box::new(e(a)), "sqrt", vec![]),
        Op::Powf(a, q) => Ex::Method(Box::new(e(a)), "powf", vec![Ex::Lit(q.to_f64())]),
        Op::PowVar(a, b) => {
            let (a, b) = (e(a), e(b));
            Ex::Method(Box::new(a), "powf", vec![b])
        }
        Op::Call(Func::Sign, a) => {
            let a = e(a);
            *flags |= USES_SIGN;
            Ex::Call("sign", vec![a])
        }
        Op::Call(f, a) => Ex::Method(Box::new(e(a)), method(f), vec![]),
        Op::Map1(m, k, a) => map_call(m.index(), [k, 0], &[e(a)]),
        Op::Map2(m, o, a, b) => {
            let (a, b) = (e(a), e(b));
            map_call(m.index(), o, &[a, b])
        }
        Op::Call2(f, a, b) => {
            // min and max are symmetric: a constant goes in the argument (`v.max(0.0)`, not `0.0_f64.max(v)`).
            let (a, b) = if matches!(a, Val::Num(_) | Val::Pi) {
                (b, a)
            } else {
                (a, b)
            };
            let (a, b) = (e(a), e(b));
            let (m, other) = match f {
                Func2::Min => ("min", "max"),
                Func2::Max => ("max", "min"),
            };
            if matches!(&a, Ex::Method(_, inner, _) if *inner == other) {
                *flags |= CLAMP_LIKE;
            }
            Ex::Method(Box::new(a), m, vec![b])
        }
    }
}

/// The map calls of a block that share their map and arguments (two or more, every order ≤ 2 per
/// argument): each group is read from one `let mbK = self.maps[m].partials2(&[a, b]);` (value and partials
/// in one pass), bound just before the group's first call; its calls become `mbK[p * 3 + q]`.
struct Bundles {
    /// Per arena value: its bundle's name and the index into the bundle.
    member: HashMap<usize, (Ident, usize)>,
    /// Per first call: the bundle's name, the map and the arguments.
    start: HashMap<usize, (Ident, usize, Vec<Val>)>,
}

impl Bundles {
    fn member(&self, i: usize) -> Option<Ex> {
        self.member.get(&i).map(|(name, k)| {
            let k = Literal::usize_unsuffixed(*k);
            Ex::Atom(quote!(#name[#k]))
        })
    }

    fn starts_at(&self, i: usize) -> Option<(Ident, usize, Vec<Val>)> {
        self.start.get(&i).cloned()
    }
}

fn map_bundles(
    arena: &Arena,
    reachable: &[bool],
    given: &dyn Fn(usize) -> Option<Ex>,
    temp: &str,
) -> Bundles {
    // (map, arguments) → the calls, in arena order, with their index into the bundle.
    type Key = (usize, Vec<Val>);
    let mut groups: Vec<(Key, Vec<(usize, usize)>)> = Vec::new();
    for (i, op) in arena.ops().iter().enumerate() {
        if !reachable[i] || given(i).is_some() {
            continue;
        }
        let (key, k) = match *op {
            Op::Map1(m, o, a) if o <= 2 => ((m.index(), vec![a]), o as usize),
            Op::Map2(m, [p, q], a, b) if p <= 2 && q <= 2 => {
                ((m.index(), vec![a, b]), 3 * p as usize + q as usize)
            }
            _ => continue,
        };
        match groups.iter_mut().find(|(g, _)| *g == key) {
            Some((_, calls)) => calls.push((i, k)),
            None => groups.push((key, vec![(i, k)])),
        }
    }
    let mut b = Bundles {
        member: HashMap::new(),
        start: HashMap::new(),
    };
    let shared = groups.into_iter().filter(|(_, calls)| calls.len() >= 2);
    for (count, ((m, args), calls)) in shared.enumerate() {
        let name = Ident::new(&format!("{temp}mb{count}"), Span::call_site());
        b.start.insert(calls[0].0, (name.clone(), m, args));
        for (i, k) in calls {
            b.member.insert(i, (name.clone(), k));
        }
    }
    b
}

/// `self.maps[m].partial(&[a, b], [I, J])`: one partial derivative of map `m` (contract §6) from the model's
/// map data (`Precomputed::maps`).
fn map_call(m: usize, o: [u8; 2], args: &[Ex]) -> Ex {
    let m = Literal::usize_unsuffixed(m);
    let (i, j) = (
        Literal::usize_unsuffixed(o[0] as usize),
        Literal::usize_unsuffixed(o[1] as usize),
    );
    let args = args.iter().map(|a| a.tokens(0));
    Ex::Atom(quote!(self.maps[#m].partial(&[#(#args),*], [#i, #j])))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(s: &str) -> Ex {
        Ex::Atom(Ident::new(s, Span::call_site()).into_token_stream())
    }

    fn show(e: &Ex) -> String {
        e.tokens(0).to_string()
    }

    #[test]
    fn parentheses_only_where_needed() {
        let (a, b, c) = (id("a"), id("b"), id("c"));
        let sub = |x: Ex, y: Ex| Ex::bin(BinOp::Sub, x, y);
        assert_eq!(
            show(&sub(sub(a.clone(), b.clone()), c.clone())),
            "a - b - c"
        );
        assert_eq!(
            show(&sub(a.clone(), sub(b.clone(), c.clone()))),
            "a - (b - c)"
        );
        let mul = Ex::bin(
            BinOp::Mul,
            Ex::bin(BinOp::Add, a.clone(), b.clone()),
            c.clone(),
        );
        assert_eq!(show(&mul), "(a + b) * c");
        assert_eq!(
            show(&Ex::Neg(Box::new(Ex::bin(
                BinOp::Mul,
                a.clone(),
                b.clone()
            )))),
            "- (a * b)"
        );
        assert_eq!(show(&Ex::Neg(Box::new(a.clone()))), "- a");
        let m = Ex::Method(Box::new(Ex::bin(BinOp::Mul, a.clone(), b)), "sqrt", vec![]);
        assert_eq!(show(&m), "(a * b) . sqrt ()");
        let lit = Ex::Method(Box::new(Ex::Lit(0.075)), "sqrt", vec![]);
        assert_eq!(show(&lit), "0.075_f64 . sqrt ()");
        assert_eq!(show(&Ex::Neg(Box::new(lit))), "- (0.075_f64 . sqrt ())");
        let neg_recv = Ex::Method(Box::new(Ex::Lit(-2.0)), "powi", vec![Ex::Int(3)]);
        assert_eq!(show(&neg_recv), "(- 2.0_f64) . powi (3)");
        assert_eq!(show(&Ex::bin(BinOp::Div, Ex::Lit(1.0), a)), "1.0 / a");
    }

    #[test]
    fn literals() {
        assert_eq!(float_text(1300.0), "1300.0");
        assert_eq!(float_text(0.075), "0.075");
        assert_eq!(float_text(1e30), "1e30");
        assert_eq!(float_tokens(std::f64::consts::PI, false).to_string(), "PI");
        assert_eq!(
            float_tokens(std::f64::consts::E, true).to_string(),
            "std :: f64 :: consts :: E"
        );
        assert_eq!(float_tokens(-0.5, false).to_string(), "- 0.5");
        assert!(looks_like_std_constant("3.14") && looks_like_std_constant("0.7071"));
        assert!(
            !looks_like_std_constant("3.1")
                && !looks_like_std_constant("0.32")
                && !looks_like_std_constant("9.81")
        );
    }
}
