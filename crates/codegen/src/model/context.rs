//! What every generator of a model's module shares: the derivation with the Rust names of its symbols
//! ([`Gen`]), the per-point functions ([`FnKind`], [`Straight`]) with their arguments and result shapes.

use crate::emit::{BinOp, Ex};
use crate::names::{self, FieldName, Locals};
use invsim_expr::lower::Lowered;
use invsim_expr::{Id, Pool, Symbol};
use invsim_inversion::Derivation;
use proc_macro2::{Ident, Span, TokenStream};
use quote::{format_ident, quote, ToTokens};
use std::collections::{HashMap, HashSet};

/// The per-point functions the generated module can define (which ones a model gets depends on whether
/// ψ⁻¹ is in closed form, whether there are internal states and extra outputs).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum FnKind {
    H,
    Psi,
    PsiInv,
    Alpha,
    Beta,
    Invert,
    ZeroDynamics,
    PsiJacobian,
    PsiJacobianAlphaBeta,
    AlphaX,
    BetaX,
    ZeroDynamicsX,
    Phi,
    InputSolution,
    PhiX,
    InputSolutionX,
    Rhs,
    Outputs,
    Sensitivity,
    ZeroDynamicsJacobian,
    ZeroDynamicsAffine,
    OutputsJacobian,
}

impl FnKind {
    /// The method's (and free function's) name.
    pub(super) fn name(self) -> &'static str {
        match self {
            FnKind::H => "h",
            FnKind::Psi => "psi",
            FnKind::PsiInv => "psi_inv",
            FnKind::Alpha => "alpha",
            FnKind::Beta => "beta",
            FnKind::Invert => "invert",
            FnKind::ZeroDynamics => "zero_dynamics",
            FnKind::PsiJacobian => "psi_jacobian",
            FnKind::PsiJacobianAlphaBeta => "psi_jacobian_alpha_beta",
            FnKind::AlphaX => "alpha_x",
            FnKind::BetaX => "beta_x",
            FnKind::ZeroDynamicsX => "zero_dynamics_x",
            FnKind::Phi => "phi",
            FnKind::InputSolution => "input_solution",
            FnKind::PhiX => "phi_x",
            FnKind::InputSolutionX => "input_solution_x",
            FnKind::Rhs => "rhs",
            FnKind::Outputs => "outputs",
            FnKind::Sensitivity => "sensitivity",
            FnKind::ZeroDynamicsJacobian => "zero_dynamics_jacobian",
            FnKind::ZeroDynamicsAffine => "zero_dynamics_affine",
            FnKind::OutputsJacobian => "outputs_jacobian",
        }
    }

    /// The first words of the function's description, for the free wrappers' docs.
    pub(super) fn title(self) -> &'static str {
        match self {
            FnKind::H => "The tracked output y = h(x)",
            FnKind::Psi => "(ξ, η) = ψ(x)",
            FnKind::PsiInv => "x = ψ⁻¹(ξ, η)",
            FnKind::Alpha => "α(ξ, η)",
            FnKind::Beta => "β(ξ, η)",
            FnKind::Invert => "The inverse (x, u) at one point",
            FnKind::ZeroDynamics => "The zero dynamics dη/dt",
            FnKind::PsiJacobian => "ψ(x) and ∂ψ/∂x",
            FnKind::PsiJacobianAlphaBeta => "ψ(x), ∂ψ/∂x, α and β in the states",
            FnKind::AlphaX => "α = L_f^r h in the states",
            FnKind::BetaX => "β = L_g L_f^(r−1) h in the states",
            FnKind::ZeroDynamicsX => "The zero dynamics in the states",
            FnKind::Phi => "y^(r) = φ(ξ, η, u) and ∂φ/∂u",
            FnKind::InputSolution => "The input u solving φ(ξ, η, u) = y^(r) in closed form",
            FnKind::PhiX => "y^(r) = φ(x, u) and ∂φ/∂u in the states",
            FnKind::InputSolutionX => {
                "The input u solving φ(x, u) = y^(r) in closed form, in the states"
            }
            FnKind::Rhs => "dx/dt = f(x) + g(x)·u",
            FnKind::Outputs => "The extra outputs",
            FnKind::Sensitivity => {
                "The partial derivatives the parameter sensitivities are built from"
            }
            FnKind::ZeroDynamicsJacobian => {
                "The zero dynamics' partial derivatives by η, ξ, y^(r) and the parameters"
            }
            FnKind::ZeroDynamicsAffine => {
                "The coefficients A, b of affine zero dynamics dη/dt = A η + b"
            }
            FnKind::OutputsJacobian => {
                "The extra outputs' partial derivatives by η, ξ, y^(r) and the parameters"
            }
        }
    }

    pub(super) fn ident(self) -> Ident {
        format_ident!("{}", self.name())
    }
}

/// The shape of a function's result.
#[derive(Clone)]
pub(super) enum Shape {
    Scalar,
    /// `[inner; len]`, `len` given as a constant's name.
    Array(&'static str, usize, Box<Shape>),
    Tuple(Vec<Shape>),
}

impl Shape {
    pub(super) fn array(len: &'static str, n: usize) -> Shape {
        Shape::Array(len, n, Box::new(Shape::Scalar))
    }

    pub(super) fn ty(&self) -> TokenStream {
        match self {
            Shape::Scalar => quote!(f64),
            Shape::Array(len, _, inner) => {
                let (len, inner) = (format_ident!("{}", len), inner.ty());
                quote!([#inner; #len])
            }
            Shape::Tuple(parts) => {
                let parts = parts.iter().map(Shape::ty);
                quote!((#(#parts),*))
            }
        }
    }

    /// The result expression, consuming `items` in order.
    pub(super) fn build(&self, items: &mut std::vec::IntoIter<TokenStream>) -> TokenStream {
        match self {
            Shape::Scalar => items.next().unwrap_or_else(|| quote!(f64::NAN)),
            Shape::Array(_, n, inner) => {
                let parts: Vec<TokenStream> = (0..*n).map(|_| inner.build(items)).collect();
                quote!([#(#parts),*])
            }
            Shape::Tuple(parts) => {
                let parts: Vec<TokenStream> = parts.iter().map(|p| p.build(items)).collect();
                quote!((#(#parts),*))
            }
        }
    }
}

/// An argument of a per-point function.
#[derive(Clone)]
pub(super) enum Arg {
    /// `name: &[f64; LEN]`, destructured into the symbols' locals.
    Array {
        name: &'static str,
        len: &'static str,
        syms: Vec<Symbol>,
    },
    /// `local: f64` for a single symbol (the input u, or y^(r)).
    Scalar(Symbol),
}

/// The symbols of `args`, in order.
pub(super) fn arg_syms(args: &[Arg]) -> Vec<Symbol> {
    args.iter()
        .flat_map(|a| match a {
            Arg::Array { syms, .. } => syms.clone(),
            Arg::Scalar(s) => vec![*s],
        })
        .collect()
}

/// A per-point function computed by straight-line code.
pub(super) struct Straight {
    pub(super) kind: FnKind,
    pub(super) args: Vec<Arg>,
    pub(super) roots: Vec<Id>,
    pub(super) shape: Shape,
    pub(super) doc: Vec<String>,
    pub(super) lowered: Option<Lowered>,
    /// For `invert`: β is parameter-only, and the last root is 1/β (u = (y^(r) − α)·(1/β)).
    pub(super) beta_recip: bool,
}

impl Straight {
    pub(super) fn new(
        kind: FnKind,
        args: Vec<Arg>,
        roots: Vec<Id>,
        shape: Shape,
        doc: Vec<String>,
    ) -> Straight {
        Straight {
            kind,
            args,
            roots,
            shape,
            doc,
            lowered: None,
            beta_recip: false,
        }
    }
}

/// Everything needed to write one model's module.
pub(super) struct Gen<'d> {
    pub(super) d: &'d Derivation,
    pub(super) pool: &'d Pool,
    pub(super) closed: bool,
    /// y^(r) affine in the input (else u solves y^(r) = φ(ξ, η, w, u), or φ(x, w, u) where ψ⁻¹ is numeric,
    /// `solve_input.rs`).
    pub(super) affine: bool,
    pub(super) fields: HashMap<Symbol, FieldName>,
    pub(super) locals: HashMap<Symbol, Ident>,
    /// Model names written in a non-snake-case spelling (fields or locals).
    pub(super) non_snake: bool,
}

impl<'d> Gen<'d> {
    pub(super) fn new(d: &'d Derivation) -> Gen<'d> {
        let m = &d.model;
        let pool = d.pool();
        let mut all: Vec<&str> = Vec::new();
        all.extend(m.parameters.iter().map(|p| p.name.as_str()));
        all.extend(m.definitions.iter().map(|p| p.name.as_str()));
        all.extend(m.states.iter().map(|p| p.name.as_str()));
        all.push(m.input.name.as_str());
        let w_names: Vec<String> =
            d.w.iter()
                .map(|&s| pool.symbol_name(s).to_string())
                .collect();
        all.extend(w_names.iter().map(String::as_str));
        let mut locals = Locals::new(&all);
        let mut taken: HashSet<String> = m.parameters.iter().map(|p| p.name.clone()).collect();
        let mut non_snake = false;
        let mut fields = HashMap::new();
        for p in &m.parameters {
            let f = names::field_name(&p.name, &taken);
            taken.insert(f.ident.to_string());
            non_snake |= !names::is_snake_case(&f.ident.to_string());
            fields.insert(p.symbol, f);
        }
        let mut local_map = HashMap::new();
        let mut add = |s: Symbol, name: String, non_snake: &mut bool| {
            *non_snake |= !names::is_snake_case(&name);
            local_map.insert(s, Ident::new(&name, Span::call_site()));
        };
        for st in &m.states {
            add(st.symbol, locals.local(&st.name), &mut non_snake);
        }
        add(m.input.symbol, locals.local(&m.input.name), &mut non_snake);
        for (&s, name) in d.w.iter().zip(&w_names) {
            add(s, locals.local(name), &mut non_snake);
        }
        for &s in d.xi.iter().chain(&d.eta) {
            add(s, pool.symbol_name(s).to_string(), &mut non_snake);
        }
        add(d.yr, "yr".to_string(), &mut non_snake);
        Gen {
            d,
            pool,
            closed: d.psi_inv_closed(),
            affine: d.yr_affine,
            fields,
            locals: local_map,
            non_snake,
        }
    }

    pub(super) fn name(&self, s: Symbol) -> &str {
        self.pool.symbol_name(s)
    }

    pub(super) fn state_syms(&self) -> Vec<Symbol> {
        self.d.model.state_symbols()
    }

    pub(super) fn x_arg(&self) -> Arg {
        Arg::Array {
            name: "x",
            len: "N",
            syms: self.state_syms(),
        }
    }

    pub(super) fn xi_arg(&self) -> Arg {
        Arg::Array {
            name: "xi",
            len: "R",
            syms: self.d.xi.clone(),
        }
    }

    pub(super) fn eta_arg(&self) -> Arg {
        Arg::Array {
            name: "eta",
            len: "N_ETA",
            syms: self.d.eta.clone(),
        }
    }

    /// Does the model have signals (so that every function takes their values `w`)?
    pub(super) fn has_w(&self) -> bool {
        !self.d.w.is_empty()
    }

    /// `args` followed by the signal values `w: &[f64; NW]` when the model has signals.
    pub(super) fn with_w(&self, mut args: Vec<Arg>) -> Vec<Arg> {
        if self.has_w() {
            args.push(Arg::Array {
                name: "w",
                len: "NW",
                syms: self.d.w.clone(),
            });
        }
        args
    }
}

/// The fused inverse's results from the roots of its lowered code (x…, α, β and, with `beta_recip`, 1/β):
/// `let` statements naming α and β where they are not single tokens, the states, and
/// u = (y^(r) − α)/β (or (y^(r) − α)·(1/β) when β depends on parameters only).
pub(super) fn invert_result(mut items: Vec<Ex>, beta_recip: bool) -> (TokenStream, Vec<Ex>, Ex) {
    let beta_recip = if beta_recip { items.pop() } else { None };
    let beta = items.pop().unwrap_or(Ex::Lit(f64::NAN));
    let alpha = items.pop().unwrap_or(Ex::Lit(f64::NAN));
    let mut extra = TokenStream::new();
    let mut bind = |name: &str, e: Ex| -> Ex {
        if matches!(e, Ex::Atom(_)) {
            e
        } else {
            let id = format_ident!("{}", name);
            let t = e.tokens(0);
            extra.extend(quote!(let #id = #t;));
            Ex::atom(id.to_token_stream())
        }
    };
    let alpha = bind("alpha", alpha);
    let yr = Ex::atom(quote!(yr));
    let u = match beta_recip {
        // β depends on parameters only: multiply by the precomputed 1/β.
        Some(rb) => {
            let _ = beta;
            Ex::bin(BinOp::Mul, Ex::bin(BinOp::Sub, yr, alpha), rb)
        }
        None => {
            let beta = bind("beta", beta);
            Ex::bin(BinOp::Div, Ex::bin(BinOp::Sub, yr, alpha), beta)
        }
    };
    (extra, items, u)
}
