//! The generated module for one model: constants, `Params`, `Precomputed` (parameter-only subexpressions, the
//! per-point functions and the batch methods of [`batch`]), free functions, `Model` and its `InverseModel` impl.
//!
//! Which functions exist, and what they compute, mirrors the interpreter (`invsim_inversion::Interpreter`):
//!
//! * ψ⁻¹ in closed form: `psi_inv`, `alpha`, `beta`, `invert` and `zero_dynamics` are evaluated in (ξ, η);
//! * ψ⁻¹ solved numerically: `psi_inv` runs Newton's method on ψ(x) = (ξ, η) with the analytic Jacobian
//!   ∂ψ/∂x (same iteration limit, tolerance and residual scaling as the interpreter), and α, β and the zero
//!   dynamics are evaluated in the states at the solution (L_f^r h, L_g L_f^(r−1) h, f_η + g_η·u).

use crate::emit::{self, BinOp, Ex};
use invsim_expr::lower::{self, Invariants, Lowered, Strategy, Val};
use crate::names::{self, FieldName, Locals};
use crate::CodegenError;
use invsim_expr::{latex_symbol, Id, Pool, Symbol};
use invsim_inversion::interpreter::{NEWTON_MAX_ITER, NEWTON_TOL};
use invsim_inversion::{Derivation, Solution};
use proc_macro2::{Ident, Span, TokenStream};
use quote::{format_ident, quote, ToTokens};
use std::cell::RefCell;
use std::collections::{BTreeSet, HashMap, HashSet};

mod batch;

/// The shape of a function's result.
#[derive(Clone)]
enum Shape {
    Scalar,
    /// `[inner; len]`, `len` given as a constant's name.
    Array(&'static str, usize, Box<Shape>),
    Tuple(Vec<Shape>),
}

impl Shape {
    fn array(len: &'static str, n: usize) -> Shape {
        Shape::Array(len, n, Box::new(Shape::Scalar))
    }

    fn ty(&self) -> TokenStream {
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
    fn build(&self, items: &mut std::vec::IntoIter<TokenStream>) -> TokenStream {
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
enum Arg {
    /// `name: &[f64; LEN]`, destructured into the symbols' locals.
    Array {
        name: &'static str,
        len: &'static str,
        syms: Vec<Symbol>,
    },
    /// `local: f64` for a single symbol (the input u, or y^(r)).
    Scalar(Symbol),
}

/// A per-point function computed by straight-line code.
struct Straight {
    name: &'static str,
    args: Vec<Arg>,
    roots: Vec<Id>,
    shape: Shape,
    doc: Vec<String>,
    lowered: Option<Lowered>,
    /// For `invert`: β is parameter-only, and the last root is 1/β (u = (y^(r) − α)·(1/β)).
    beta_recip: bool,
}

/// Everything needed to write one model's module.
struct Gen<'d> {
    d: &'d Derivation,
    pool: &'d Pool,
    closed: bool,
    fields: HashMap<Symbol, FieldName>,
    locals: HashMap<Symbol, Ident>,
    /// Model names written in a non-snake-case spelling (fields or locals).
    non_snake: bool,
}

/// Doc lines for an equation block: a plain-text block in the contract's language and the same in LaTeX.
fn equation_doc(rows: &[(String, String, String)]) -> Vec<String> {
    let mut doc = vec!["```text".to_string()];
    for (plain, _, rhs) in rows {
        doc.push(format!("{plain} = {rhs}"));
    }
    doc.push("```".into());
    doc.push(String::new());
    doc.push("```math".into());
    if rows.len() == 1 {
        doc.push(format!("{} = {}", rows[0].1, rows[0].2.clone()));
    } else {
        doc.push("\\begin{aligned}".into());
        for (i, (_, tex, rhs)) in rows.iter().enumerate() {
            let end = if i + 1 < rows.len() { " \\\\" } else { "" };
            doc.push(format!("{tex} &= {rhs}{end}"));
        }
        doc.push("\\end{aligned}".into());
    }
    doc.push("```".into());
    doc
}

fn doc_attrs(lines: &[String]) -> TokenStream {
    let attrs = lines.iter().map(|l| {
        let l = if l.is_empty() {
            String::new()
        } else {
            format!(" {l}")
        };
        quote!(#[doc = #l])
    });
    quote!(#(#attrs)*)
}

fn lit_str(s: &str) -> TokenStream {
    s.to_token_stream()
}

fn opt_f64(v: Option<f64>) -> TokenStream {
    match v {
        Some(x) => {
            let t = emit::float_tokens(x, false);
            quote!(Some(#t))
        }
        None => quote!(None),
    }
}

fn opt_string(v: &Option<String>) -> TokenStream {
    match v {
        Some(s) => quote!(Some(#s.to_string())),
        None => quote!(None),
    }
}

impl<'d> Gen<'d> {
    fn new(d: &'d Derivation) -> Gen<'d> {
        let m = &d.model;
        let pool = d.pool();
        let mut all: Vec<&str> = Vec::new();
        all.extend(m.parameters.iter().map(|p| p.name.as_str()));
        all.extend(m.definitions.iter().map(|p| p.name.as_str()));
        all.extend(m.states.iter().map(|p| p.name.as_str()));
        all.push(m.input.name.as_str());
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
        for &s in d.xi.iter().chain(&d.eta) {
            add(s, pool.symbol_name(s).to_string(), &mut non_snake);
        }
        add(d.yr, "yr".to_string(), &mut non_snake);
        Gen {
            d,
            pool,
            closed: d.psi_inv_closed(),
            fields,
            locals: local_map,
            non_snake,
        }
    }

    fn name(&self, s: Symbol) -> &str {
        self.pool.symbol_name(s)
    }

    fn plain(&self, e: Id) -> String {
        self.pool.display(e)
    }

    fn tex(&self, e: Id) -> String {
        self.pool.latex(e)
    }

    fn state_syms(&self) -> Vec<Symbol> {
        self.d.model.state_symbols()
    }

    fn x_arg(&self) -> Arg {
        Arg::Array {
            name: "x",
            len: "N",
            syms: self.state_syms(),
        }
    }
    fn xi_arg(&self) -> Arg {
        Arg::Array {
            name: "xi",
            len: "R",
            syms: self.d.xi.clone(),
        }
    }
    fn eta_arg(&self) -> Arg {
        Arg::Array {
            name: "eta",
            len: "N_ETA",
            syms: self.d.eta.clone(),
        }
    }

    /// The straight-line functions of this model.
    fn straight_functions(&self) -> Vec<Straight> {
        let d = self.d;
        let m = &d.model;
        let n = d.n();
        let r = d.relative_degree;
        let ne = d.eta.len();
        let u = m.input.symbol;
        let states = self.state_syms();
        let rows =
            |lhs: Vec<(String, String)>, es: &[Id], plain: bool| -> Vec<(String, String, String)> {
                lhs.into_iter()
                    .zip(es)
                    .map(|((a, b), &e)| (a, b, if plain { self.plain(e) } else { self.tex(e) }))
                    .collect()
            };
        // Doc: a plain block from the `plain` rows and a LaTeX block from the `tex` rows.
        let eq = |lhs: Vec<(String, String)>, es: &[Id]| -> Vec<String> {
            let p = rows(lhs.clone(), es, true);
            let t = rows(lhs, es, false);
            let mut doc = vec!["```text".to_string()];
            for (plain, _, rhs) in &p {
                doc.push(format!("{plain} = {rhs}"));
            }
            doc.push("```".into());
            doc.push(String::new());
            let mut tex_doc = equation_doc(&t);
            // equation_doc repeats a text block; keep only its math block.
            let start = tex_doc.iter().position(|l| l == "```math").unwrap_or(0);
            doc.extend(tex_doc.drain(start..));
            doc
        };
        let xi_lhs: Vec<(String, String)> = (1..=r)
            .map(|k| (format!("xi{k}"), format!("\\xi_{{{k}}}")))
            .collect::<Vec<_>>();
        let eta_lhs: Vec<(String, String)> = (1..=ne)
            .map(|k| (format!("eta{k}"), format!("\\eta_{{{k}}}")))
            .collect();
        let state_lhs: Vec<(String, String)> = m
            .states
            .iter()
            .map(|s| (s.name.clone(), latex_symbol(&s.name)))
            .collect();
        let dot_lhs: Vec<(String, String)> = m
            .states
            .iter()
            .map(|s| {
                (
                    format!("d({})/dt", s.name),
                    format!("\\dot{{{}}}", latex_symbol(&s.name)),
                )
            })
            .collect();
        let deta_lhs: Vec<(String, String)> = (1..=ne)
            .map(|k| (format!("d(eta{k})/dt"), format!("\\dot\\eta_{{{k}}}")))
            .collect();
        let out_lhs: Vec<(String, String)> = m
            .outputs
            .iter()
            .map(|o| (o.name.clone(), latex_symbol(&o.name)))
            .collect();
        let mut psi_lhs = xi_lhs.clone();
        psi_lhs.extend(eta_lhs.clone());

        let mut fs = Vec::new();
        let mut doc = vec![
            format!("The tracked output y = h(x) (`{}`).", m.output.name),
            String::new(),
        ];
        doc.extend(eq(vec![("y".into(), "y".into())], &[m.output.h]));
        fs.push(Straight {
            name: "h",
            args: vec![self.x_arg()],
            roots: vec![m.output.h],
            shape: Shape::Scalar,
            doc,
            lowered: None,
            beta_recip: false,
        });
        let mut doc = vec![
            "Normal-form coordinates (ξ, η) = ψ(x): ξ_k = L_f^(k−1) h for k = 1 … r, η the internal states."
                .to_string(),
            String::new(),
        ];
        doc.extend(eq(psi_lhs.clone(), &d.psi));
        fs.push(Straight {
            name: "psi",
            args: vec![self.x_arg()],
            roots: d.psi.clone(),
            shape: Shape::Tuple(vec![Shape::array("R", r), Shape::array("N_ETA", ne)]),
            doc,
            lowered: None,
            beta_recip: false,
        });
        if self.closed {
            let inv: Vec<Id> = d
                .psi_inv
                .iter()
                .filter_map(|s| match s {
                    Solution::Closed(e) => Some(*e),
                    Solution::Numeric => None,
                })
                .collect();
            let mut doc = vec![
                "The states at normal-form coordinates: x = ψ⁻¹(ξ, η), in closed form.".to_string(),
            ];
            if !d.domain.is_empty() {
                doc.push(String::new());
                doc.push(format!("Valid where: {}.", d.domain.join("; ")));
            }
            doc.push(String::new());
            doc.extend(eq(state_lhs.clone(), &inv));
            fs.push(Straight {
                name: "psi_inv",
                args: vec![self.xi_arg(), self.eta_arg()],
                roots: inv.clone(),
                shape: Shape::array("N", n),
                doc,
                lowered: None,
                beta_recip: false,
            });
            let mut doc = vec![
                "α(ξ, η) = L_f^r h ∘ ψ⁻¹, the drift term of y^(r) = α(ξ, η) + β(ξ, η)·u."
                    .to_string(),
                String::new(),
            ];
            doc.extend(eq(vec![("alpha".into(), "\\alpha".into())], &[d.alpha]));
            fs.push(Straight {
                name: "alpha",
                args: vec![self.xi_arg(), self.eta_arg()],
                roots: vec![d.alpha],
                shape: Shape::Scalar,
                doc,
                lowered: None,
                beta_recip: false,
            });
            let mut doc = vec![
                "β(ξ, η) = L_g L_f^(r−1) h ∘ ψ⁻¹, the gain of the input in y^(r) = α + β·u."
                    .to_string(),
            ];
            if !d.singular.is_empty() {
                doc.push(String::new());
                doc.push(format!("Vanishes {}.", d.singular.join("; ")));
            }
            doc.push(String::new());
            doc.extend(eq(vec![("beta".into(), "\\beta".into())], &[d.beta]));
            fs.push(Straight {
                name: "beta",
                args: vec![self.xi_arg(), self.eta_arg()],
                roots: vec![d.beta],
                shape: Shape::Scalar,
                doc,
                lowered: None,
                beta_recip: false,
            });
            let mut roots = inv;
            roots.push(d.alpha);
            roots.push(d.beta);
            fs.push(Straight {
                name: "invert",
                args: vec![self.xi_arg(), self.eta_arg()],
                roots,
                shape: Shape::Tuple(vec![Shape::array("N", n), Shape::Scalar, Shape::Scalar]),
                doc: vec![
                    "The inverse at one point (paper eq. 26): x = ψ⁻¹(ξ, η) and the input that gives the output \
                     derivative y^(r) = `yr`, with ψ⁻¹, α and β evaluated together."
                        .to_string(),
                    String::new(),
                    "```text".into(),
                    "u = (yr - alpha)/beta".into(),
                    "```".into(),
                    String::new(),
                    "```math".into(),
                    "u = \\frac{y^{(r)} - \\alpha(\\xi, \\eta)}{\\beta(\\xi, \\eta)}".into(),
                    "```".into(),
                ],
                lowered: None,
                beta_recip: false,
            });
            if ne > 0 {
                let mut doc = vec![
                    "The zero dynamics dη/dt = L_f η + L_g η · (y^(r) − α)/β in (ξ, η, y^(r))."
                        .to_string(),
                    String::new(),
                ];
                doc.extend(eq(deta_lhs.clone(), &d.zero_dynamics));
                let mut args = vec![self.xi_arg(), self.eta_arg()];
                args.push(Arg::Scalar(d.yr));
                fs.push(Straight {
                    name: "zero_dynamics",
                    args,
                    roots: d.zero_dynamics.clone(),
                    shape: Shape::array("N_ETA", ne),
                    doc,
                    lowered: None,
                    beta_recip: false,
                });
            }
        } else {
            let mut roots = d.psi.clone();
            let mut jac_lhs = Vec::new();
            for (i, row) in d.jacobian.iter().enumerate() {
                roots.extend(row.iter().copied());
                for (j, st) in states.iter().enumerate() {
                    let _ = j;
                    jac_lhs.push((
                        format!("d({})/d({})", psi_lhs[i].0, self.name(*st)),
                        format!(
                            "\\frac{{\\partial {}}}{{\\partial {}}}",
                            psi_lhs[i].1,
                            latex_symbol(self.name(*st))
                        ),
                    ));
                }
            }
            let mut lhs = psi_lhs.clone();
            lhs.extend(jac_lhs);
            let mut doc = vec![
                "ψ(x) and its Jacobian ∂ψ/∂x (row i = ∂ψ_i/∂x), for Newton's method on ψ(x) = (ξ, η).".to_string(),
                String::new(),
            ];
            doc.extend(eq(lhs, &roots));
            fs.push(Straight {
                name: "psi_jacobian",
                args: vec![self.x_arg()],
                roots,
                shape: Shape::Tuple(vec![
                    Shape::array("N", n),
                    Shape::Array("N", n, Box::new(Shape::array("N", n))),
                ]),
                doc,
                lowered: None,
                beta_recip: false,
            });
            let mut doc = vec!["α in the states: L_f^r h(x).".to_string(), String::new()];
            doc.extend(eq(vec![("alpha".into(), "\\alpha".into())], &[d.alpha_x]));
            fs.push(Straight {
                name: "alpha_x",
                args: vec![self.x_arg()],
                roots: vec![d.alpha_x],
                shape: Shape::Scalar,
                doc,
                lowered: None,
                beta_recip: false,
            });
            let mut doc = vec!["β in the states: L_g L_f^(r−1) h(x).".to_string()];
            if !d.singular.is_empty() {
                doc.push(String::new());
                doc.push(format!("Vanishes {}.", d.singular.join("; ")));
            }
            doc.push(String::new());
            doc.extend(eq(vec![("beta".into(), "\\beta".into())], &[d.beta_x]));
            fs.push(Straight {
                name: "beta_x",
                args: vec![self.x_arg()],
                roots: vec![d.beta_x],
                shape: Shape::Scalar,
                doc,
                lowered: None,
                beta_recip: false,
            });
            if ne > 0 {
                let mut doc = vec![
                    "The zero dynamics in the states: dη/dt = f_η(x) + g_η(x)·(y^(r) − L_f^r h)/(L_g L_f^(r−1) h)."
                        .to_string(),
                    String::new(),
                ];
                doc.extend(eq(deta_lhs.clone(), &d.zero_dynamics_x));
                fs.push(Straight {
                    name: "zero_dynamics_x",
                    args: vec![self.x_arg(), Arg::Scalar(d.yr)],
                    roots: d.zero_dynamics_x.clone(),
                    shape: Shape::array("N_ETA", ne),
                    doc,
                    lowered: None,
                    beta_recip: false,
                });
            }
        }
        let rhs: Vec<Id> = m.states.iter().map(|s| s.rhs).collect();
        let mut doc = vec![
            format!(
                "The original model dx/dt = f(x) + g(x)·u, for forward simulation (u = `{}`).",
                m.input.name
            ),
            String::new(),
        ];
        doc.extend(eq(dot_lhs, &rhs));
        fs.push(Straight {
            name: "rhs",
            args: vec![self.x_arg(), Arg::Scalar(u)],
            roots: rhs,
            shape: Shape::array("N", n),
            doc,
            lowered: None,
            beta_recip: false,
        });
        if !m.outputs.is_empty() {
            let outs: Vec<Id> = m.outputs.iter().map(|o| o.expr).collect();
            let mut doc = vec![
                "The extra outputs of the model's `[outputs]` table at (x, u).".to_string(),
                String::new(),
            ];
            doc.extend(eq(out_lhs, &outs));
            fs.push(Straight {
                name: "outputs",
                args: vec![self.x_arg(), Arg::Scalar(u)],
                roots: outs,
                shape: Shape::array("N_OUTPUTS", m.outputs.len()),
                doc,
                lowered: None,
                beta_recip: false,
            });
        }
        fs
    }
}

/// The fused inverse's results from the roots of its lowered code (x…, α, β and, with `beta_recip`, 1/β):
/// `let` statements naming α and β where they are not single tokens, the states, and
/// u = (y^(r) − α)/β (or (y^(r) − α)·(1/β) when β depends on parameters only).
fn invert_result(mut items: Vec<Ex>, beta_recip: bool) -> (TokenStream, Vec<Ex>, Ex) {
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

fn arg_syms(args: &[Arg]) -> Vec<Symbol> {
    args.iter()
        .flat_map(|a| match a {
            Arg::Array { syms, .. } => syms.clone(),
            Arg::Scalar(s) => vec![*s],
        })
        .collect()
}

/// The tokens of one model's module and the comments to place above some of its lines.
pub(crate) struct ModuleOut {
    pub tokens: TokenStream,
    pub comments: Vec<(String, String)>,
}

pub(crate) fn module(d: &Derivation, source_name: &str) -> Result<ModuleOut, CodegenError> {
    let g = Gen::new(d);
    let m = &d.model;
    let pool = d.pool();
    let n = d.n();
    let r = d.relative_degree;
    let ne = d.eta.len();
    let np = m.parameters.len();
    let no = m.outputs.len();
    let param_syms: Vec<Symbol> = m.parameters.iter().map(|p| p.symbol).collect();
    let module_ident = format_ident!("{}", names::module_name(&m.name));
    let lit = |i: usize| proc_macro2::Literal::usize_unsuffixed(i);
    let (n_lit, r_lit, ne_lit, np_lit, no_lit) = (lit(n), lit(r), lit(ne), lit(np), lit(no));

    // ----- lower every function; parameter-only work lands in one shared arena ------------------------
    let mut inv = Invariants::new(pool, &param_syms, Strategy::GENERATED);
    let mut fns = g.straight_functions();
    for f in fns.iter_mut() {
        let inputs = arg_syms(&f.args);
        let l = lower::lower(&mut inv, &f.roots, &inputs).map_err(|e| CodegenError::Unbound {
            model: m.name.clone(),
            function: f.name,
            symbol: e.0,
        })?;
        let mut l = l;
        if f.name == "invert" {
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
    for f in &fns {
        let Some(l) = &f.lowered else { continue };
        let mut note = |v: Val| {
            if let Val::Inv(i) = v {
                exported.insert(i);
            }
        };
        for op in l.arena.ops() {
            op.operands().into_iter().for_each(&mut note);
        }
        l.roots.iter().copied().for_each(&mut note);
    }
    let k_names: HashMap<usize, Ident> = exported
        .iter()
        .enumerate()
        .map(|(j, &i)| (i, format_ident!("k{}", j)))
        .collect();

    let field_of = |s: Symbol| -> TokenStream {
        match g.fields.get(&s) {
            Some(f) => f.ident.to_token_stream(),
            None => quote!(missing),
        }
    };

    // ----- Precomputed::new ------------------------------------------------------------------------------
    let inv_roots: Vec<Val> = exported.iter().map(|&i| Val::Inv(i)).collect();
    let inv_index = |v: Val| match v {
        Val::Inv(i) => Some(i),
        _ => None,
    };
    let inv_atom = |v: Val| -> Ex {
        match v {
            Val::Sym(s) => {
                let f = field_of(s);
                Ex::atom(quote!(p.#f))
            }
            Val::Num(x) => Ex::Lit(x.to_f64()),
            Val::Pi => Ex::Lit(std::f64::consts::PI),
            Val::Inv(_) | Val::Loc(_) => Ex::Lit(f64::NAN),
        }
    };
    let pre_block = emit::render(inv.arena(), &inv_roots, &inv_index, &inv_atom, &k_names, "t");
    let mut uses_sign = pre_block.uses_sign;
    let pre_lets = &pre_block.lets;
    let k_idents: Vec<&Ident> = exported.iter().map(|i| &k_names[i]).collect();
    let mut describe_pool = pool.clone();
    let mut describe_memo: HashMap<usize, Id> = HashMap::new();
    let k_fields: Vec<TokenStream> = exported
        .iter()
        .map(|&i| {
            let e = describe(
                &mut describe_pool,
                inv.arena(),
                Val::Inv(i),
                &mut describe_memo,
            );
            let text = format!(" `{}`", describe_pool.display(e));
            let k = &k_names[&i];
            quote!(#[doc = #text] #k: f64,)
        })
        .collect();

    // ----- per-point methods --------------------------------------------------------------------------------
    let mut methods: Vec<TokenStream> = Vec::new();
    let mut batch_methods: Vec<TokenStream> = Vec::new();
    let (mut has_invert_batch, mut has_outputs_batch, mut uses_pow_slice) = (false, false, false);
    let mut free_fns: Vec<TokenStream> = Vec::new();
    for f in &fns {
        let Some(l) = &f.lowered else { continue };
        let used: RefCell<HashSet<Symbol>> = RefCell::new(HashSet::new());
        let uses_p = RefCell::new(false);
        let loc_index = |v: Val| match v {
            Val::Loc(i) => Some(i),
            _ => None,
        };
        let atom = |v: Val| -> Ex {
            match v {
                Val::Sym(s) if g.fields.contains_key(&s) => {
                    *uses_p.borrow_mut() = true;
                    let f = field_of(s);
                    Ex::atom(quote!(p.#f))
                }
                Val::Sym(s) => {
                    used.borrow_mut().insert(s);
                    match g.locals.get(&s) {
                        Some(id) => Ex::atom(id.to_token_stream()),
                        None => Ex::Lit(f64::NAN),
                    }
                }
                Val::Num(x) => Ex::Lit(x.to_f64()),
                Val::Pi => Ex::Lit(std::f64::consts::PI),
                Val::Inv(i) => {
                    let k = &k_names[&i];
                    Ex::atom(quote!(self.#k))
                }
                Val::Loc(_) => Ex::Lit(f64::NAN),
            }
        };
        let block = emit::render(&l.arena, &l.roots, &loc_index, &atom, &HashMap::new(), "t");
        uses_sign |= block.uses_sign;
        let used = used.into_inner();
        let (params_sig, destructure, call_args) =
            signature(&g, &f.args, &used, f.name == "invert");
        let p_let = if *uses_p.borrow() {
            quote!(let p = &self.params;)
        } else {
            quote!()
        };
        let lets = &block.lets;
        let name = format_ident!("{}", f.name);
        let doc = doc_attrs(&f.doc);
        let allow_clamp = if block.clamp_like {
            quote!(#[allow(clippy::manual_clamp)])
        } else {
            quote!()
        };
        let (ret_ty, result) = if f.name == "invert" {
            let (extra, xs, u) = invert_result(block.roots.clone(), f.beta_recip);
            let xs = xs.iter().map(|e| e.tokens(0));
            let u = u.tokens(0);
            (quote!(([f64; N], f64)), quote!(#extra ([#(#xs),*], #u)))
        } else {
            let items: Vec<TokenStream> = block.roots.iter().map(|e| e.tokens(0)).collect();
            (f.shape.ty(), f.shape.build(&mut items.into_iter()))
        };
        methods.push(quote! {
            #doc
            #allow_clamp
            pub fn #name(&self, #(#params_sig),*) -> #ret_ty {
                #p_let
                #(#destructure)*
                #(#lets)*
                #result
            }
        });
        // The same over columns of points, block by block (ψ⁻¹ in closed form; outputs for every model).
        let kind = match f.name {
            "invert" if g.closed => Some(batch::Kind::Invert),
            "outputs" => Some(batch::Kind::Outputs),
            _ => None,
        };
        if let Some(kind) = kind {
            let is_param = |v: Val| match v {
                Val::Sym(s) => g.fields.contains_key(&s),
                Val::Num(_) | Val::Pi | Val::Inv(_) => true,
                Val::Loc(_) => false,
            };
            let plan = batch::Plan::new(&l.arena, &l.roots, &is_param);
            uses_pow_slice |= plan.has_powers();
            let (tokens, sign) = batch::method(&g, f, l, &plan, kind, &k_names, &is_param);
            uses_sign |= sign;
            batch_methods.push(tokens);
            match kind {
                batch::Kind::Invert => has_invert_batch = true,
                batch::Kind::Outputs => has_outputs_batch = true,
            }
        }
        let free_doc = format!(
            " {} at the parameters `p`; the equation and the code are in [`Precomputed::{}`].",
            short_title(f.name),
            f.name
        );
        let free_sig = free_signature(&g, &f.args, f.name == "invert");
        free_fns.push(quote! {
            #[doc = #free_doc]
            #[inline]
            pub fn #name(p: &Params, #(#free_sig),*) -> #ret_ty {
                Precomputed::new(p).#name(#(#call_args),*)
            }
        });
    }

    // ----- Newton's method for a numeric ψ⁻¹ -----------------------------------------------------------------
    let mut helpers: Vec<TokenStream> = Vec::new();
    if !g.closed {
        let target: Vec<TokenStream> = (0..r)
            .map(|i| {
                let i = lit(i);
                quote!(xi[#i])
            })
            .chain((0..ne).map(|j| {
                let j = lit(j);
                quote!(eta[#j])
            }))
            .collect();
        let xi_name = if r > 0 { quote!(xi) } else { quote!(_xi) };
        let eta_name = if ne > 0 { quote!(eta) } else { quote!(_eta) };
        let tol = emit::float_tokens(NEWTON_TOL, false);
        methods.push(quote! {
            /// The states at normal-form coordinates, x = ψ⁻¹(ξ, η), by Newton's method on ψ(x) = (ξ, η) with
            /// the analytic Jacobian, started from `guess`.
            ///
            /// Stops when max_i |ψ_i(x) − target_i| / max(|target_i|, 1e-12) < [`NEWTON_TOL`]; after
            /// [`NEWTON_MAX_ITER`] iterations, a singular Jacobian or a non-finite iterate it returns
            /// [`ModelError::NewtonDidNotConverge`], never an unconverged x.
            pub fn psi_inv(
                &self,
                #xi_name: &[f64; R],
                #eta_name: &[f64; N_ETA],
                guess: &[f64; N],
            ) -> Result<[f64; N], ModelError> {
                let target: [f64; N] = [#(#target),*];
                let mut x = *guess;
                let mut residual = f64::INFINITY;
                for _ in 0..NEWTON_MAX_ITER {
                    let (value, jacobian) = self.psi_jacobian(&x);
                    let mut step = [0.0; N];
                    residual = 0.0;
                    for ((s, v), t) in step.iter_mut().zip(value).zip(target) {
                        *s = v - t;
                        let scaled = (*s / t.abs().max(1e-12)).abs();
                        if scaled.is_nan() || scaled > residual {
                            residual = scaled;
                        }
                    }
                    if residual < NEWTON_TOL {
                        return Ok(x);
                    }
                    if !lu_solve(jacobian, &mut step) {
                        break;
                    }
                    for (xk, s) in x.iter_mut().zip(step) {
                        *xk -= s;
                    }
                    if !x.iter().all(|v| v.is_finite()) {
                        break;
                    }
                }
                Err(ModelError::NewtonDidNotConverge { iterations: NEWTON_MAX_ITER, residual })
            }

            /// α(ξ, η) = L_f^r h at x = ψ⁻¹(ξ, η) (Newton from `guess`); see [`Precomputed::alpha_x`].
            pub fn alpha(&self, xi: &[f64; R], eta: &[f64; N_ETA], guess: &[f64; N]) -> Result<f64, ModelError> {
                Ok(self.alpha_x(&self.psi_inv(xi, eta, guess)?))
            }

            /// β(ξ, η) = L_g L_f^(r−1) h at x = ψ⁻¹(ξ, η) (Newton from `guess`); see [`Precomputed::beta_x`].
            pub fn beta(&self, xi: &[f64; R], eta: &[f64; N_ETA], guess: &[f64; N]) -> Result<f64, ModelError> {
                Ok(self.beta_x(&self.psi_inv(xi, eta, guess)?))
            }

            /// The inverse at one point (paper eq. 26): x = ψ⁻¹(ξ, η) by Newton from `guess`, and
            /// u = (y^(r) − α)/β at that x.
            ///
            /// ```math
            /// u = \frac{y^{(r)} - \alpha(x)}{\beta(x)}
            /// ```
            pub fn invert(
                &self,
                xi: &[f64; R],
                eta: &[f64; N_ETA],
                yr: f64,
                guess: &[f64; N],
            ) -> Result<([f64; N], f64), ModelError> {
                let x = self.psi_inv(xi, eta, guess)?;
                Ok((x, (yr - self.alpha_x(&x)) / self.beta_x(&x)))
            }
        });
        if ne > 0 {
            methods.push(quote! {
                /// The zero dynamics dη/dt at x = ψ⁻¹(ξ, η) (Newton from `guess`); see
                /// [`Precomputed::zero_dynamics_x`].
                pub fn zero_dynamics(
                    &self,
                    xi: &[f64; R],
                    eta: &[f64; N_ETA],
                    yr: f64,
                    guess: &[f64; N],
                ) -> Result<[f64; N_ETA], ModelError> {
                    Ok(self.zero_dynamics_x(&self.psi_inv(xi, eta, guess)?, yr))
                }
            });
        }
        let mut numeric_free = vec![quote! {
            /// x = ψ⁻¹(ξ, η) by Newton's method at the parameters `p`; see [`Precomputed::psi_inv`].
            #[inline]
            pub fn psi_inv(p: &Params, xi: &[f64; R], eta: &[f64; N_ETA], guess: &[f64; N]) -> Result<[f64; N], ModelError> {
                Precomputed::new(p).psi_inv(xi, eta, guess)
            }
            /// α(ξ, η) at the parameters `p`; see [`Precomputed::alpha`].
            #[inline]
            pub fn alpha(p: &Params, xi: &[f64; R], eta: &[f64; N_ETA], guess: &[f64; N]) -> Result<f64, ModelError> {
                Precomputed::new(p).alpha(xi, eta, guess)
            }
            /// β(ξ, η) at the parameters `p`; see [`Precomputed::beta`].
            #[inline]
            pub fn beta(p: &Params, xi: &[f64; R], eta: &[f64; N_ETA], guess: &[f64; N]) -> Result<f64, ModelError> {
                Precomputed::new(p).beta(xi, eta, guess)
            }
            /// The inverse at one point at the parameters `p`; see [`Precomputed::invert`].
            #[inline]
            pub fn invert(
                p: &Params,
                xi: &[f64; R],
                eta: &[f64; N_ETA],
                yr: f64,
                guess: &[f64; N],
            ) -> Result<([f64; N], f64), ModelError> {
                Precomputed::new(p).invert(xi, eta, yr, guess)
            }
        }];
        if ne > 0 {
            numeric_free.push(quote! {
                /// The zero dynamics at the parameters `p`; see [`Precomputed::zero_dynamics`].
                #[inline]
                pub fn zero_dynamics(
                    p: &Params,
                    xi: &[f64; R],
                    eta: &[f64; N_ETA],
                    yr: f64,
                    guess: &[f64; N],
                ) -> Result<[f64; N_ETA], ModelError> {
                    Precomputed::new(p).zero_dynamics(xi, eta, yr, guess)
                }
            });
        }
        free_fns.extend(numeric_free);
        helpers.push(quote! {
            /// Solves a·s = b in place of `b` by Gaussian elimination with partial pivoting; `false` when `a`
            /// is singular.
            fn lu_solve(mut a: [[f64; N]; N], b: &mut [f64; N]) -> bool {
                for k in 0..N {
                    let pivot = (k..N).fold(k, |best, i| if a[i][k].abs() > a[best][k].abs() { i } else { best });
                    if a[pivot][k] == 0.0 {
                        return false;
                    }
                    a.swap(k, pivot);
                    b.swap(k, pivot);
                    let (row, bk) = (a[k], b[k]);
                    for (ai, bi) in a.iter_mut().zip(b.iter_mut()).skip(k + 1) {
                        let factor = ai[k] / row[k];
                        for (aij, rj) in ai.iter_mut().zip(row).skip(k) {
                            *aij -= factor * rj;
                        }
                        *bi -= factor * bk;
                    }
                }
                for k in (0..N).rev() {
                    b[k] /= a[k][k];
                    let bk = b[k];
                    for (bi, ai) in b.iter_mut().zip(a).take(k) {
                        *bi -= ai[k] * bk;
                    }
                }
                true
            }
        });
        let iter = lit(NEWTON_MAX_ITER);
        helpers.push(quote! {
            /// Largest number of Newton iterations for ψ⁻¹ (the interpreter's limit).
            pub const NEWTON_MAX_ITER: usize = #iter;
            /// Newton's method for ψ⁻¹ stops when the scaled residual is below this (the interpreter's tolerance).
            pub const NEWTON_TOL: f64 = #tol;
        });
    }
    if uses_sign {
        helpers.push(quote! {
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
        });
    }

    // ----- constants and Params ----------------------------------------------------------------------------
    let name = &m.name;
    let hash = &m.source_hash;
    let description = m.description.clone().unwrap_or_default();
    let state_names: Vec<&str> = m.states.iter().map(|s| s.name.as_str()).collect();
    let param_names: Vec<&str> = m.parameters.iter().map(|p| p.name.as_str()).collect();
    let output_names: Vec<&str> = m.outputs.iter().map(|o| o.name.as_str()).collect();
    let input_name = &m.input.name;
    let output_name = &m.output.name;
    let field_defs: Vec<TokenStream> = m
        .parameters
        .iter()
        .map(|p| {
            let f = &g.fields[&p.symbol];
            let id = &f.ident;
            let mut text = p
                .doc
                .clone()
                .unwrap_or_else(|| format!("Parameter `{}`", p.name));
            if let Some(u) = &p.unit {
                text.push_str(&format!(" ({u})"));
            }
            text.push_str(&format!("; default {}.", number_text(p.value)));
            let text = format!(" {}", escape_doc(&text));
            let rename = f
                .serde_rename
                .as_ref()
                .map(|n| quote!(#[serde(rename = #n)]));
            quote!(#[doc = #text] #rename pub #id: f64,)
        })
        .collect();
    let all_zero = m
        .parameters
        .iter()
        .all(|p| p.value == 0.0 && p.value.is_sign_positive());
    let defaults: Vec<TokenStream> = m
        .parameters
        .iter()
        .map(|p| {
            let id = &g.fields[&p.symbol].ident;
            let v = emit::float_tokens(p.value, false);
            quote!(#id: #v,)
        })
        .collect();
    let field_ids: Vec<&Ident> = m
        .parameters
        .iter()
        .map(|p| &g.fields[&p.symbol].ident)
        .collect();
    let (derive_default, default_impl) = if all_zero {
        (quote!(Default,), quote!())
    } else {
        (
            quote!(),
            quote! {
                impl Default for Params {
                    /// The model file's values.
                    fn default() -> Params {
                        Params { #(#defaults)* }
                    }
                }
            },
        )
    };
    let idx: Vec<proc_macro2::Literal> = (0..np).map(lit).collect();
    let (get_fn, set_fn, from_array_fn) = if np == 0 {
        (
            quote! {
                /// The value of the parameter called `name` (this model has none).
                pub fn get(&self, _name: &str) -> Option<f64> {
                    None
                }
            },
            quote! {
                /// Set the parameter called `name` (this model has none: always an error).
                pub fn set(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
                    if !value.is_finite() {
                        return Err(ModelError::NonFiniteParameter { name: name.to_string(), value });
                    }
                    Err(ModelError::UnknownParameter { name: name.to_string(), known: String::new() })
                }
            },
            quote! {
                /// Parameters from values in [`PARAMETERS`] order (this model has none).
                pub fn from_array(_values: &[f64; N_PARAMS]) -> Params {
                    Params {}
                }
            },
        )
    } else {
        (
            quote! {
                /// The value of the parameter called `name`, as written in the model file.
                pub fn get(&self, name: &str) -> Option<f64> {
                    match name {
                        #(#param_names => Some(self.#field_ids),)*
                        _ => None,
                    }
                }
            },
            quote! {
                /// Set the parameter called `name` (as written in the model file) to a finite value.
                pub fn set(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
                    if !value.is_finite() {
                        return Err(ModelError::NonFiniteParameter { name: name.to_string(), value });
                    }
                    match name {
                        #(#param_names => self.#field_ids = value,)*
                        _ => {
                            return Err(ModelError::UnknownParameter {
                                name: name.to_string(),
                                known: PARAMETERS.join(", "),
                            })
                        }
                    }
                    Ok(())
                }
            },
            quote! {
                /// Parameters from values in [`PARAMETERS`] order.
                pub fn from_array(values: &[f64; N_PARAMS]) -> Params {
                    Params { #(#field_ids: values[#idx],)* }
                }
            },
        )
    };

    // ----- the trait impl ----------------------------------------------------------------------------------
    let has_outputs = no > 0;
    let outputs_impl = if has_outputs {
        quote! {
            fn outputs(&self, x: &[f64], u: f64, out: &mut [f64]) {
                out.copy_from_slice(&self.pre.outputs(arr(x), u));
            }
            /// The outputs over columns, block by block ([`Precomputed::outputs_batch`]).
            fn outputs_batch(&self, x: &[&[f64]], u: &[f64], out: &mut [&mut [f64]]) {
                self.pre.outputs_batch(cols(x), u, cols_mut(out));
            }
        }
    } else {
        quote! {
            fn outputs(&self, _x: &[f64], _u: f64, _out: &mut [f64]) {}
            fn outputs_batch(&self, _x: &[&[f64]], _u: &[f64], _out: &mut [&mut [f64]]) {}
        }
    };
    let invert_batch_impl = if has_invert_batch {
        quote! {
            /// ψ⁻¹, α and β over columns, block by block ([`Precomputed::invert_batch`]).
            fn invert_batch(
                &self,
                xi: &[&[f64]],
                eta: &[&[f64]],
                yr: &[f64],
                x: &mut [&mut [f64]],
                u: &mut [f64],
            ) -> Result<(), (usize, ModelError)> {
                self.pre.invert_batch(cols(xi), cols(eta), yr, cols_mut(x), u);
                Ok(())
            }
        }
    } else {
        quote!()
    };
    if has_invert_batch || has_outputs_batch {
        helpers.push(quote! {
            /// The fixed-size array of columns behind a slice of columns (a wrong count is a bug in the
            /// caller, as the trait documents).
            fn cols<'a, const K: usize>(s: &[&'a [f64]]) -> [&'a [f64]; K] {
                s.try_into().expect("column count matches the model's dimensions")
            }

            /// The same for columns written to.
            fn cols_mut<'a, const K: usize>(s: &'a mut [&mut [f64]]) -> [&'a mut [f64]; K] {
                let s: &'a mut [&mut [f64]; K] = s
                    .try_into()
                    .expect("column count matches the model's dimensions");
                s.each_mut().map(|c| &mut **c)
            }
        });
    }
    let (psi_inv_impl, alpha_impl, beta_impl, zero_impl, invert_impl) = if g.closed {
        (
            quote! {
                fn psi_inv(&self, xi: &[f64], eta: &[f64], x: &mut [f64]) -> Result<(), ModelError> {
                    x.copy_from_slice(&self.pre.psi_inv(arr(xi), arr(eta)));
                    Ok(())
                }
            },
            quote! {
                fn alpha(&self, xi: &[f64], eta: &[f64]) -> f64 {
                    self.pre.alpha(arr(xi), arr(eta))
                }
            },
            quote! {
                fn beta(&self, xi: &[f64], eta: &[f64]) -> f64 {
                    self.pre.beta(arr(xi), arr(eta))
                }
            },
            if ne > 0 {
                quote! {
                    fn zero_dynamics(&self, xi: &[f64], eta: &[f64], yr: f64, deta: &mut [f64]) {
                        deta.copy_from_slice(&self.pre.zero_dynamics(arr(xi), arr(eta), yr));
                    }
                }
            } else {
                quote! {
                    fn zero_dynamics(&self, _xi: &[f64], _eta: &[f64], _yr: f64, _deta: &mut [f64]) {}
                }
            },
            quote! {
                /// ψ⁻¹, α and β in one evaluation.
                fn invert(&self, xi: &[f64], eta: &[f64], yr: f64, x: &mut [f64]) -> Result<f64, ModelError> {
                    let (states, u) = self.pre.invert(arr(xi), arr(eta), yr);
                    x.copy_from_slice(&states);
                    Ok(u)
                }
            },
        )
    } else {
        (
            quote! {
                fn psi_inv(&self, xi: &[f64], eta: &[f64], x: &mut [f64]) -> Result<(), ModelError> {
                    let states = self.pre.psi_inv(arr(xi), arr(eta), arr(x))?;
                    x.copy_from_slice(&states);
                    Ok(())
                }
            },
            quote! {
                /// Newton from x = 1 (as the interpreter); NaN if it does not converge.
                fn alpha(&self, xi: &[f64], eta: &[f64]) -> f64 {
                    self.pre.alpha(arr(xi), arr(eta), &[1.0; N]).unwrap_or(f64::NAN)
                }
            },
            quote! {
                /// Newton from x = 1 (as the interpreter); NaN if it does not converge.
                fn beta(&self, xi: &[f64], eta: &[f64]) -> f64 {
                    self.pre.beta(arr(xi), arr(eta), &[1.0; N]).unwrap_or(f64::NAN)
                }
            },
            if ne > 0 {
                quote! {
                    /// Newton from x = 1 (as the interpreter); NaN if it does not converge.
                    fn zero_dynamics(&self, xi: &[f64], eta: &[f64], yr: f64, deta: &mut [f64]) {
                        match self.pre.zero_dynamics(arr(xi), arr(eta), yr, &[1.0; N]) {
                            Ok(q) => deta.copy_from_slice(&q),
                            Err(_) => deta.fill(f64::NAN),
                        }
                    }
                }
            } else {
                quote! {
                    fn zero_dynamics(&self, _xi: &[f64], _eta: &[f64], _yr: f64, _deta: &mut [f64]) {}
                }
            },
            quote! {
                /// Newton from the guess in `x`, then u = (y^(r) − α)/β at the solution.
                fn invert(&self, xi: &[f64], eta: &[f64], yr: f64, x: &mut [f64]) -> Result<f64, ModelError> {
                    let (states, u) = self.pre.invert(arr(xi), arr(eta), yr, arr(x))?;
                    x.copy_from_slice(&states);
                    Ok(u)
                }
            },
        )
    };

    let outputs_info: Vec<TokenStream> = m
        .outputs
        .iter()
        .map(|o| {
            let (name, unit, acc) = (&o.name, opt_string(&o.unit), o.accumulate);
            quote!(OutputInfo { name: #name.to_string(), unit: #unit, accumulate: #acc })
        })
        .collect();
    let outputs_vec = if outputs_info.is_empty() {
        quote!(Vec::new())
    } else {
        quote!(Vec::from([#(#outputs_info),*]))
    };
    let (input_min, input_max) = (opt_f64(m.input.min), opt_f64(m.input.max));

    // ----- module doc and attributes ------------------------------------------------------------------------
    let states_list = state_names.join(", ");
    let psi_inv_note = if g.closed {
        "ψ⁻¹ is in closed form.".to_string()
    } else {
        "ψ⁻¹ is solved by Newton's method on the analytic Jacobian (no closed form was found)."
            .to_string()
    };
    let mut mod_doc = vec![format!("Compiled `{name}` model.")];
    if !description.is_empty() {
        mod_doc.push(String::new());
        mod_doc.push(escape_doc(&description));
    }
    mod_doc.push(String::new());
    mod_doc.push(format!(
        "States x = ({states_list}), input u = `{input_name}`, output y = `{output_name}`: n = {n}, relative \
         degree r = {r}, {ne} internal state(s) η. {psi_inv_note}"
    ));
    mod_doc.push(String::new());
    // Links in a module's outer docs resolve from the enclosing module, hence the module-qualified paths.
    let md = names::module_name(&m.name);
    mod_doc.push(format!(
        "[`Model`]({md}::Model) implements the runtime's [`InverseModel`](invsim_model_api::InverseModel). \
         [`Precomputed`]({md}::Precomputed) holds a parameter set with its parameter-only subexpressions and \
         evaluates every function per point; the free functions take [`Params`]({md}::Params) directly. Each \
         method's documentation shows its equation."
    ));
    mod_doc.push(String::new());
    mod_doc.push(format!("Generated from `{source_name}` (sha256 `{hash}`)."));
    let mod_doc = doc_attrs(&mod_doc);
    let mut comments: Vec<(String, String)> = Vec::new();
    let mut attrs = TokenStream::new();
    comments.push((
        "#[allow(clippy::manual_clamp)]".to_string(),
        "min(max(x, a), b) as the model language defines it: NaN gives a bound, where `clamp` would give NaN."
            .to_string(),
    ));
    if g.non_snake {
        attrs.extend(quote!(#[allow(non_snake_case)]));
        comments.push((
            "#[allow(non_snake_case)]".to_string(),
            "Parameter and state names are the model file's own (`C_d`, `T_i`), kept as written."
                .to_string(),
        ));
    }

    let description_lit = lit_str(&description);
    let imports = if has_outputs {
        quote!(
            use invsim_model_api::{InverseModel, ModelError, ModelInfo, OutputInfo, ReferenceMap};
        )
    } else {
        quote!(
            use invsim_model_api::{InverseModel, ModelError, ModelInfo, ReferenceMap};
        )
    };
    let imports = if uses_pow_slice {
        quote!(#imports use invsim_model_api::math::pow_pos_slice;)
    } else {
        imports
    };
    let block_const = if has_invert_batch || has_outputs_batch {
        quote! {
            /// Points per block of the batch methods of [`Precomputed`] (`*_batch`): their block buffers hold
            /// this many values each, on the stack.
            pub const BLOCK: usize = 256;
        }
    } else {
        quote!()
    };
    let ref_offset = emit::float_tokens(m.output.reference_offset, false);
    let ref_scale = emit::float_tokens(m.output.reference_scale, false);
    let body = quote! {
        #imports

        /// Model name.
        pub const NAME: &str = #name;
        /// One-line description from the model file.
        pub const DESCRIPTION: &str = #description_lit;
        /// The model file this code was generated from.
        pub const SOURCE_FILE: &str = #source_name;
        /// SHA-256 of the model file's bytes (lower-case hex).
        pub const SOURCE_HASH: &str = #hash;
        /// Number of states n.
        pub const N: usize = #n_lit;
        /// Relative degree r.
        pub const R: usize = #r_lit;
        /// Number of internal coordinates η (n − r).
        pub const N_ETA: usize = #ne_lit;
        /// Number of parameters.
        pub const N_PARAMS: usize = #np_lit;
        /// Number of extra outputs.
        pub const N_OUTPUTS: usize = #no_lit;
        /// State names, in the model file's order.
        pub const STATES: [&str; N] = [#(#state_names),*];
        /// The input's name.
        pub const INPUT: &str = #input_name;
        /// The tracked output's name.
        pub const OUTPUT: &str = #output_name;
        /// Parameter names, in the model file's order (the order of [`InverseModel::params`]).
        pub const PARAMETERS: [&str; N_PARAMS] = [#(#param_names),*];
        /// Names of the extra outputs.
        pub const OUTPUTS: [&str; N_OUTPUTS] = [#(#output_names),*];
        /// How a drive cycle defines the tracked output's reference: y_d = offset + scale · (smoothed cycle).
        pub const REFERENCE: ReferenceMap = ReferenceMap { offset: #ref_offset, scale: #ref_scale };
        #block_const

        /// The model's parameters; [`Default`] gives the model file's values.
        #[derive(Debug, Clone, Copy, PartialEq, #derive_default serde::Serialize, serde::Deserialize)]
        #[serde(default, deny_unknown_fields)]
        pub struct Params {
            #(#field_defs)*
        }

        #default_impl

        impl Params {
            /// The values in [`PARAMETERS`] order.
            pub fn to_array(&self) -> [f64; N_PARAMS] {
                [#(self.#field_ids),*]
            }
            #from_array_fn
            #get_fn
            #set_fn
        }

        /// A parameter set with its parameter-only subexpressions computed once, and the model's functions
        /// evaluated per point.
        #[derive(Debug, Clone, PartialEq)]
        pub struct Precomputed {
            params: Params,
            #(#k_fields)*
        }

        impl Precomputed {
            /// Compute the parameter-only subexpressions for `p`.
            #[inline(always)]
            pub fn new(p: &Params) -> Precomputed {
                #(#pre_lets)*
                Precomputed { params: *p, #(#k_idents),* }
            }

            /// The parameters.
            pub fn params(&self) -> &Params {
                &self.params
            }

            #(#methods)*

            #(#batch_methods)*
        }

        #(#free_fns)*

        /// The model's static description (names, sizes, bounds), as the interpreter reports it.
        pub fn model_info() -> ModelInfo {
            ModelInfo {
                name: NAME.to_string(),
                source_hash: Some(SOURCE_HASH.to_string()),
                states: STATES.iter().map(|s| s.to_string()).collect(),
                input: INPUT.to_string(),
                output: OUTPUT.to_string(),
                relative_degree: R,
                n_eta: N_ETA,
                input_min: #input_min,
                input_max: #input_max,
                outputs: #outputs_vec,
                parameters: PARAMETERS.iter().map(|s| s.to_string()).collect(),
            }
        }

        /// The compiled model behind the runtime's [`InverseModel`] trait.
        #[derive(Debug, Clone)]
        pub struct Model {
            pre: Precomputed,
            values: [f64; N_PARAMS],
            info: ModelInfo,
        }

        impl Model {
            /// The model at parameters `params`.
            pub fn new(params: Params) -> Model {
                Model { pre: Precomputed::new(&params), values: params.to_array(), info: model_info() }
            }
            /// The current parameters.
            pub fn parameters(&self) -> &Params {
                self.pre.params()
            }
            /// Replace the parameters (recomputing their subexpressions).
            pub fn set_parameters(&mut self, params: Params) {
                self.pre = Precomputed::new(&params);
                self.values = params.to_array();
            }
            /// The precomputed evaluator (typed, array-based access to every function).
            pub fn precomputed(&self) -> &Precomputed {
                &self.pre
            }
        }

        impl Default for Model {
            /// The model at the model file's parameter values.
            fn default() -> Model {
                Model::new(Params::default())
            }
        }

        impl InverseModel for Model {
            fn info(&self) -> &ModelInfo {
                &self.info
            }
            fn params(&self) -> &[f64] {
                &self.values
            }
            fn set_param(&mut self, name: &str, value: f64) -> Result<(), ModelError> {
                let mut params = *self.pre.params();
                params.set(name, value)?;
                self.set_parameters(params);
                Ok(())
            }
            fn h(&self, x: &[f64]) -> f64 {
                self.pre.h(arr(x))
            }
            fn psi(&self, x: &[f64], xi: &mut [f64], eta: &mut [f64]) {
                let (a, b) = self.pre.psi(arr(x));
                xi.copy_from_slice(&a);
                eta.copy_from_slice(&b);
            }
            #psi_inv_impl
            #alpha_impl
            #beta_impl
            #zero_impl
            fn rhs(&self, x: &[f64], u: f64, dx: &mut [f64]) {
                dx.copy_from_slice(&self.pre.rhs(arr(x), u));
            }
            #outputs_impl
            fn reference(&self) -> ReferenceMap {
                REFERENCE
            }
            #invert_impl
            #invert_batch_impl
        }

        /// The fixed-size array behind a slice of one of the model's dimensions (a wrong length is a bug in
        /// the caller, as the trait documents).
        fn arr<const K: usize>(s: &[f64]) -> &[f64; K] {
            s.try_into().expect("slice length matches the model's dimensions")
        }

        #(#helpers)*
    };
    if resembles_std_constant(body.clone()) {
        attrs.extend(quote!(#[allow(clippy::approx_constant)]));
        comments.push((
            "#[allow(clippy::approx_constant)]".to_string(),
            "Numbers from the model file that resemble `std::f64::consts` values are its data, not approximations."
                .to_string(),
        ));
    }
    let body = if uses_pi(body.clone(), None) {
        quote!(use std::f64::consts::PI; #body)
    } else {
        body
    };
    let tokens = quote! {
        #mod_doc
        #attrs
        pub mod #module_ident {
            #body
        }
    };
    Ok(ModuleOut { tokens, comments })
}

/// The first words of a function's description, for the free wrappers' docs.
fn short_title(name: &str) -> &'static str {
    match name {
        "h" => "The tracked output y = h(x)",
        "psi" => "(ξ, η) = ψ(x)",
        "psi_inv" => "x = ψ⁻¹(ξ, η)",
        "alpha" => "α(ξ, η)",
        "beta" => "β(ξ, η)",
        "invert" => "The inverse (x, u) at one point",
        "zero_dynamics" => "The zero dynamics dη/dt",
        "psi_jacobian" => "ψ(x) and ∂ψ/∂x",
        "alpha_x" => "α = L_f^r h in the states",
        "beta_x" => "β = L_g L_f^(r−1) h in the states",
        "zero_dynamics_x" => "The zero dynamics in the states",
        "rhs" => "dx/dt = f(x) + g(x)·u",
        "outputs" => "The extra outputs",
        _ => "The function",
    }
}

/// Does any float literal in `tokens` look like a `std::f64::consts` value to clippy's `approx_constant`?
fn resembles_std_constant(tokens: TokenStream) -> bool {
    tokens.into_iter().any(|t| match t {
        proc_macro2::TokenTree::Group(g) => resembles_std_constant(g.stream()),
        proc_macro2::TokenTree::Literal(l) => {
            let text = l.to_string();
            let digits = text.trim_end_matches("_f64");
            !text.starts_with('"')
                && digits.contains(['.', 'e'])
                && emit::looks_like_std_constant(digits)
        }
        _ => false,
    })
}

/// Does the code use `PI` as a name of its own (not as a field `p.PI` or a path segment)?
fn uses_pi(tokens: TokenStream, mut prev: Option<char>) -> bool {
    for t in tokens {
        match t {
            proc_macro2::TokenTree::Group(g) => {
                if uses_pi(g.stream(), None) {
                    return true;
                }
                prev = None;
            }
            proc_macro2::TokenTree::Ident(i) => {
                if i == "PI" && !matches!(prev, Some('.' | ':')) {
                    return true;
                }
                prev = None;
            }
            proc_macro2::TokenTree::Punct(p) => prev = Some(p.as_char()),
            proc_macro2::TokenTree::Literal(_) => prev = None,
        }
    }
    false
}

/// Brackets in doc text would read as intra-doc links.
fn escape_doc(s: &str) -> String {
    s.replace('[', "\\[").replace(']', "\\]")
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

/// A parameter value for reading: `1300`, `0.32`, `4.4e7`.
fn number_text(x: f64) -> String {
    let plain = format!("{x}");
    if plain.len() <= 12 {
        plain
    } else {
        format!("{x:e}")
    }
}

/// The expression an invariant value stands for, in the model language (for the field docs).
fn describe(pool: &mut Pool, arena: &lower::Arena, v: Val, memo: &mut HashMap<usize, Id>) -> Id {
    use lower::Op;
    match v {
        Val::Sym(s) => pool.var(s),
        Val::Num(n) => pool.num(n),
        Val::Pi => pool.pi(),
        Val::Loc(_) => pool.zero(),
        Val::Inv(i) => {
            if let Some(&e) = memo.get(&i) {
                return e;
            }
            let mut sub = |pool: &mut Pool, v: Val| describe(pool, arena, v, memo);
            let e = match arena.ops()[i] {
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
    }
}
