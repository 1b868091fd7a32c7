//! The one resolver of operands: how generated code reads a value of the lowering plan that is not an
//! operation of the arena being printed — a parameter `p.<field>`, a per-point input by its local name, an
//! invariant value `self.k<j>`, a number as a literal, π as `PI`.

use super::context::Gen;
use crate::emit::Ex;
use invsim_expr::lower::Val;
use invsim_expr::Symbol;
use proc_macro2::{Ident, TokenStream};
use quote::{quote, ToTokens};
use std::cell::{Cell, RefCell};
use std::collections::{HashMap, HashSet};

/// Resolves atoms for one block of code and records what it read (the inputs, and whether `p` is needed).
pub(super) struct Atoms<'a> {
    g: &'a Gen<'a>,
    /// The `Precomputed` field of every exported invariant value.
    k_names: &'a HashMap<usize, Ident>,
    used: RefCell<HashSet<Symbol>>,
    uses_p: Cell<bool>,
}

impl<'a> Atoms<'a> {
    pub(super) fn new(g: &'a Gen<'a>, k_names: &'a HashMap<usize, Ident>) -> Atoms<'a> {
        Atoms {
            g,
            k_names,
            used: RefCell::new(HashSet::new()),
            uses_p: Cell::new(false),
        }
    }

    /// Is `v` computable from parameters and constants alone?
    pub(super) fn is_param(&self, v: Val) -> bool {
        match v {
            Val::Sym(s) => self.g.fields.contains_key(&s),
            Val::Num(_) | Val::Pi | Val::Inv(_) => true,
            Val::Loc(_) => false,
        }
    }

    /// The expression for `v` (an arena's own values, `Val::Loc`, are printed by `emit`, never here).
    pub(super) fn ex(&self, v: Val) -> Ex {
        match v {
            Val::Sym(s) => match self.g.fields.get(&s) {
                Some(f) => {
                    self.uses_p.set(true);
                    let f = &f.ident;
                    Ex::atom(quote!(p.#f))
                }
                None => {
                    self.used.borrow_mut().insert(s);
                    match self.g.locals.get(&s) {
                        Some(id) => Ex::atom(id.to_token_stream()),
                        None => Ex::Lit(f64::NAN),
                    }
                }
            },
            Val::Num(x) => Ex::Lit(x.to_f64()),
            Val::Pi => Ex::Lit(std::f64::consts::PI),
            Val::Inv(i) => match self.k_names.get(&i) {
                Some(k) => Ex::atom(quote!(self.#k)),
                None => Ex::Lit(f64::NAN),
            },
            Val::Loc(_) => Ex::Lit(f64::NAN),
        }
    }

    /// The tokens for `v`.
    pub(super) fn tokens(&self, v: Val) -> TokenStream {
        self.ex(v).tokens(0)
    }

    /// The per-point inputs read so far.
    pub(super) fn used(&self) -> HashSet<Symbol> {
        self.used.borrow().clone()
    }

    /// Was a parameter read (so the code needs `let p = &self.params;`)?
    pub(super) fn uses_p(&self) -> bool {
        self.uses_p.get()
    }
}
