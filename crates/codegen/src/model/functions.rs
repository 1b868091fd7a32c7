//! The per-point functions: every function of the catalog lowered (parameter-only work into one invariant
//! arena shared by all of them), `Precomputed::new` computing the invariant values the per-point code reads,
//! one method of `Precomputed` per function and a free wrapper taking `&Params`.

use super::atoms::Atoms;
use super::context::{arg_syms, invert_result, Arg, FnKind, Gen, Straight};
use super::docs::doc_attrs;
use crate::emit;
use crate::error::CodegenError;
use invsim_expr::lower::{self, Arena, Invariants, Lowered, Op, Strategy, Val};
use invsim_expr::{Id, Pool, Symbol};
use proc_macro2::{Ident, TokenStream};
use quote::{format_ident, quote, ToTokens};
use std::collections::{BTreeSet, HashMap, HashSet};

/// Every function lowered, with the invariant values their per-point code reads (`exported`, the fields
/// `k0, k1, …` of `Precomputed`).
pub(super) struct Lowering<'p> {
    pub(super) inv: Invariants<'p>,
    pub(super) fns: Vec<Straight>,
    pub(super) exported: BTreeSet<usize>,
    pub(super) k_names: HashMap<usize, Ident>,
}

/// Lower `fns`; parameter-only work lands in one shared arena.
pub(super) fn lower_all<'p>(
    g: &Gen<'p>,
    mut fns: Vec<Straight>,
) -> Result<Lowering<'p>, CodegenError> {
    let m = &g.d.model;
    let param_syms: Vec<Symbol> = m.parameters.iter().map(|p| p.symbol).collect();
    let mut inv = Invariants::new(g.pool, &param_syms, Strategy::GENERATED);
    for f in fns.iter_mut() {
        let inputs = arg_syms(&f.args);
        let mut l =
            lower::lower(&mut inv, &f.roots, &inputs).map_err(|e| CodegenError::Unbound {
                model: m.name.clone(),
                function: f.kind.name(),
                symbol: e.0,
            })?;
        if f.kind == FnKind::Invert {
            if let Some(&beta) = l.roots.last() {
                if inv.is_invariant(beta) && !matches!(beta, Val::Num(_)) {
                    let rb = inv.recip(beta);
                    l.roots.push(rb);
                    f.beta_recip = true;
                }
            }
        }
        f.lowered = Some(l);
    }
    // Invariant values the per-point code reads become fields of `Precomputed`.
    let mut exported: BTreeSet<usize> = BTreeSet::new();
    for l in fns.iter().filter_map(|f| f.lowered.as_ref()) {
        let ops = l.arena.ops().iter().flat_map(|op| op.operands());
        for v in ops.chain(l.roots.iter().copied()) {
            if let Val::Inv(i) = v {
                exported.insert(i);
            }
        }
    }
    let k_names = exported
        .iter()
        .enumerate()
        .map(|(j, &i)| (i, format_ident!("k{}", j)))
        .collect();
    Ok(Lowering {
        inv,
        fns,
        exported,
        k_names,
    })
}

/// `Precomputed`'s invariant fields and the body of `Precomputed::new`.
pub(super) struct Precomputed {
    /// `#[doc] kN: f64,` each.
    pub(super) fields: Vec<TokenStream>,
    /// The `let` statements computing them.
    pub(super) lets: Vec<TokenStream>,
    pub(super) idents: Vec<Ident>,
    pub(super) uses_sign: bool,
}

pub(super) fn precomputed(g: &Gen<'_>, lw: &Lowering<'_>) -> Precomputed {
    let roots: Vec<Val> = lw.exported.iter().map(|&i| Val::Inv(i)).collect();
    let index = |v: Val| match v {
        Val::Inv(i) => Some(i),
        _ => None,
    };
    let atoms = Atoms::new(g, &lw.k_names);
    let atom = |v: Val| atoms.ex(v);
    let block = emit::render(lw.inv.arena(), &roots, &index, &atom, &lw.k_names, "t");
    let mut pool = g.pool.clone();
    let mut memo: HashMap<usize, Id> = HashMap::new();
    let fields = lw
        .exported
        .iter()
        .map(|&i| {
            let e = describe(&mut pool, lw.inv.arena(), Val::Inv(i), &mut memo);
            let text = format!(" `{}`", pool.display(e));
            let k = &lw.k_names[&i];
            quote!(#[doc = #text] #k: f64,)
        })
        .collect();
    Precomputed {
        fields,
        lets: block.lets,
        idents: lw.exported.iter().map(|i| lw.k_names[i].clone()).collect(),
        uses_sign: block.uses_sign,
    }
}

/// The methods of `Precomputed` for the straight-line functions, their free wrappers, and whether any
/// calls `sign`.
pub(super) fn methods(
    g: &Gen<'_>,
    lw: &Lowering<'_>,
) -> (Vec<TokenStream>, Vec<TokenStream>, bool) {
    let (mut methods, mut free, mut uses_sign) = (Vec::new(), Vec::new(), false);
    for f in &lw.fns {
        let Some(l) = &f.lowered else { continue };
        let (m, w, sign) = method(g, f, l, &lw.k_names);
        methods.push(m);
        free.push(w);
        uses_sign |= sign;
    }
    (methods, free, uses_sign)
}

/// One function's method and free wrapper, and whether it calls `sign`.
fn method(
    g: &Gen<'_>,
    f: &Straight,
    l: &Lowered,
    k_names: &HashMap<usize, Ident>,
) -> (TokenStream, TokenStream, bool) {
    let loc_index = |v: Val| match v {
        Val::Loc(i) => Some(i),
        _ => None,
    };
    let atoms = Atoms::new(g, k_names);
    let atom = |v: Val| atoms.ex(v);
    // Newton's iteration (`invert_batch`) evaluates ψ, ∂ψ/∂x, α, β at a new x on every call: its map calls
    // would miss the memo every time.
    let render = if f.kind == FnKind::PsiJacobianAlphaBeta {
        emit::render_fresh
    } else {
        emit::render
    };
    let block = render(&l.arena, &l.roots, &loc_index, &atom, &HashMap::new(), "t");
    let is_invert = f.kind == FnKind::Invert;
    let (params_sig, destructure, call_args) = signature(g, &f.args, &atoms.used(), is_invert);
    let p_let = if atoms.uses_p() {
        quote!(let p = &self.params;)
    } else {
        quote!()
    };
    let lets = &block.lets;
    let name = f.kind.ident();
    let doc = doc_attrs(&f.doc);
    let allow_clamp = if block.clamp_like {
        quote!(#[allow(clippy::manual_clamp)])
    } else {
        quote!()
    };
    let (ret_ty, result) = if is_invert {
        let (extra, xs, u) = invert_result(block.roots.clone(), f.beta_recip);
        let xs = xs.iter().map(|e| e.tokens(0));
        let u = u.tokens(0);
        (quote!(([f64; N], f64)), quote!(#extra ([#(#xs),*], #u)))
    } else {
        let items: Vec<TokenStream> = block.roots.iter().map(|e| e.tokens(0)).collect();
        (f.shape.ty(), f.shape.build(&mut items.into_iter()))
    };
    let method = quote! {
        #doc
        #allow_clamp
        pub fn #name(&self, #(#params_sig),*) -> #ret_ty {
            #p_let
            #(#destructure)*
            #(#lets)*
            #result
        }
    };
    let free_doc = format!(
        " {} at the parameters `p`; the equation and the code are in [`Precomputed::{}`].",
        f.kind.title(),
        f.kind.name()
    );
    let free_sig = free_signature(g, &f.args, is_invert);
    let free = quote! {
        #[doc = #free_doc]
        #[inline]
        pub fn #name(p: &Params, #(#free_sig),*) -> #ret_ty {
            Precomputed::new(p).#name(#(#call_args),*)
        }
    };
    (method, free, block.uses_sign)
}

/// The method's parameter list, the `let` destructuring of its arrays, and the argument list a free wrapper
/// passes on.
fn signature(
    g: &Gen<'_>,
    args: &[Arg],
    used: &HashSet<Symbol>,
    is_invert: bool,
) -> (Vec<TokenStream>, Vec<TokenStream>, Vec<TokenStream>) {
    let mut sig = Vec::new();
    let mut destructure = Vec::new();
    let mut call = Vec::new();
    for a in args {
        match a {
            Arg::Array { name, len, syms } => {
                let len = format_ident!("{}", len);
                let any = syms.iter().any(|s| used.contains(s));
                let arg = if any {
                    format_ident!("{}", name)
                } else {
                    format_ident!("_{}", name)
                };
                sig.push(quote!(#arg: &[f64; #len]));
                call.push(format_ident!("{}", name).to_token_stream());
                if any {
                    let pats = syms.iter().map(|s| {
                        if used.contains(s) {
                            g.locals[s].to_token_stream()
                        } else {
                            quote!(_)
                        }
                    });
                    destructure.push(quote!(let [#(#pats),*] = *#arg;));
                }
            }
            Arg::Scalar(s) => {
                let local = &g.locals[s];
                let id = if used.contains(s) {
                    local.clone()
                } else {
                    format_ident!("_{}", local)
                };
                sig.push(quote!(#id: f64));
                call.push(local.to_token_stream());
            }
        }
    }
    if is_invert {
        sig.push(quote!(yr: f64));
        call.push(quote!(yr));
    }
    (sig, destructure, call)
}

/// The free wrapper's parameter list (every argument named, all passed on).
fn free_signature(g: &Gen<'_>, args: &[Arg], is_invert: bool) -> Vec<TokenStream> {
    let mut sig = Vec::new();
    for a in args {
        match a {
            Arg::Array { name, len, .. } => {
                let (name, len) = (format_ident!("{}", name), format_ident!("{}", len));
                sig.push(quote!(#name: &[f64; #len]));
            }
            Arg::Scalar(s) => {
                let local = &g.locals[s];
                sig.push(quote!(#local: f64));
            }
        }
    }
    if is_invert {
        sig.push(quote!(yr: f64));
    }
    sig
}

/// The module's `sign` function (the model language's sign, used by the code when it calls `sign`).
pub(super) fn sign_helper() -> TokenStream {
    quote! {
        /// sign(x) of the model language: −1, 0 or 1 (NaN for NaN). Unlike `f64::signum`, 0 at ±0.
        fn sign(x: f64) -> f64 {
            if x > 0.0 {
                1.0
            } else if x < 0.0 {
                -1.0
            } else if x == 0.0 {
                0.0
            } else {
                f64::NAN
            }
        }
    }
}

/// The expression an invariant value stands for, in the model language (for the field docs).
fn describe(pool: &mut Pool, arena: &Arena, v: Val, memo: &mut HashMap<usize, Id>) -> Id {
    let i = match v {
        Val::Sym(s) => return pool.var(s),
        Val::Num(n) => return pool.num(n),
        Val::Pi => return pool.pi(),
        Val::Loc(_) => return pool.zero(),
        Val::Inv(i) => i,
    };
    if let Some(&e) = memo.get(&i) {
        return e;
    }
    let mut sub = |pool: &mut Pool, v: Val| describe(pool, arena, v, memo);
    let e = match arena.ops()[i] {
        // Never hoisted (see `invsim_expr::lower`), so never an invariant to describe.
        Op::Map1(..) | Op::Map2(..) => pool.zero(),
        Op::Add(a, b) => {
            let (a, b) = (sub(pool, a), sub(pool, b));
            pool.add2(a, b)
        }
        Op::Sub(a, b) => {
            let (a, b) = (sub(pool, a), sub(pool, b));
            pool.sub(a, b)
        }
        Op::Mul(a, b) => {
            let (a, b) = (sub(pool, a), sub(pool, b));
            pool.mul2(a, b)
        }
        Op::Div(a, b) => {
            let (a, b) = (sub(pool, a), sub(pool, b));
            pool.div(a, b)
        }
        Op::Neg(a) => {
            let a = sub(pool, a);
            pool.neg(a)
        }
        Op::Recip(a) => {
            let a = sub(pool, a);
            pool.recip(a)
        }
        Op::Powi(a, k) => {
            let a = sub(pool, a);
            pool.powi(a, k as i128)
        }
        Op::Sqrt(a) => {
            let a = sub(pool, a);
            pool.sqrt(a)
        }
        Op::Powf(a, q) => {
            let a = sub(pool, a);
            let q = pool.num(q);
            pool.pow(a, q)
        }
        Op::PowVar(a, b) => {
            let (a, b) = (sub(pool, a), sub(pool, b));
            pool.pow(a, b)
        }
        Op::Call(f, a) => {
            let a = sub(pool, a);
            pool.call(f, a)
        }
        Op::Call2(f, a, b) => {
            let (a, b) = (sub(pool, a), sub(pool, b));
            pool.call2(f, a, b)
        }
    };
    memo.insert(i, e);
    e
}
