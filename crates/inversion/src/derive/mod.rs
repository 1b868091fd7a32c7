//! The derivation: Lie derivatives, relative degree, normal-form coordinates, ψ⁻¹, α, β and zero dynamics.
//!
//! For x' = f(x) + g(x)u, y = h(x) (Isidori, *Nonlinear Control Systems*, 3rd ed., §4.1; Khalil,
//! *Nonlinear Systems*, 3rd ed., §13.2; Fröberg & Nielsen 2004, eq. 24–32):
//!
//! * L_f φ = ∇φ · f, and L_f^k h = L_f(L_f^{k−1} h);
//! * the relative degree r is the first k with L_g L_f^{k−1} h ≢ 0 (Isidori Def. 4.1.1, here "not
//!   identically zero" rather than "nonzero at x°", so that singular sets are reported, not hidden);
//! * ξ = (h, L_f h, …, L_f^{r−1} h), η = n − r states chosen so that ∂(ξ, η)/∂x is nonsingular, preferring
//!   states with L_g η = g_η ≡ 0 (Isidori Prop. 4.1.3);
//! * y^(r) = α(ξ, η) + β(ξ, η) u with α = L_f^r h ∘ ψ⁻¹, β = L_g L_f^{r−1} h ∘ ψ⁻¹ (paper eq. 26–28);
//! * zero dynamics dη/dt = L_f η + L_g η · (y^(r) − α)/β, expressed in (ξ, η, y^(r)).
//!
//! Where each step lives (one file per concept): the Lie derivative in `lie.rs`, the relative degree in
//! `relative_degree.rs`, the generic rank test in `rank.rs`, the greedy choice of ξ and η in
//! `coordinates.rs`, ψ⁻¹ (isolation or Newton) in `psi_inv.rs`, α, β and the zero dynamics in
//! `normal_form.rs`, the singular set and the domain conditions in `domain.rs`, which results are free of η
//! in `eta_free.rs`, whether the zero dynamics are affine in η in `zd_affine.rs`; this file composes them.
//! Constant subexpressions that are not finite are refused first (`model/finite.rs`, which the reader
//! already runs with positions). Imports go one way: lie ←
//! relative_degree ← this file; rank ← coordinates ← this file; psi_inv, normal_form, domain and zd_affine
//! import only the model and are imported here; eta_free reads the finished [`Derivation`].

mod coordinates;
mod domain;
mod eta_free;
mod lie;
mod map_calls;
mod non_affine;
mod normal_form;
mod normal_form_jacobian;
mod psi_inv;
mod rank;
mod relative_degree;
mod sensitivity;
mod total_derivative;
mod zd_affine;

pub use lie::lie_derivative;
pub use psi_inv::{isolate, Solution};
pub use rank::SINGULAR_VALUE_TOL;
pub use total_derivative::TotalDerivative;

use crate::model::Model;
use coordinates::{choose_coordinates, coordinate_symbols, Coordinates};
use domain::{domain_conditions, singular_set};
use invsim_expr::{DecidedBy, Id, Pool, Symbol};
use normal_form::{normal_form, NormalForm, ToCoordinates};
use psi_inv::{psi_inverse, Inverse};
pub use relative_degree::MAX_LIE_DERIVATIVE_NODES;
use relative_degree::{relative_degree, NoRelativeDegree, RelativeDegree};
use thiserror::Error;

/// Why a model cannot be inverted.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DeriveError {
    #[error(
        "{file}: the output `{output}` does not depend on the input `{input}` through any number of \
         derivatives: L_g L_f^k h is identically zero for k = 0 … {last} (n = {n}), so the model has no \
         relative degree and cannot be inverted for this output; choose an output the input reaches, or \
         check that the input enters the right-hand sides"
    )]
    NoRelativeDegree {
        file: String,
        output: String,
        input: String,
        n: usize,
        last: usize,
    },
    #[error(
        "{file}: {what} holds `{expr}` = {value} at the parameters' values ({params}): it is not finite, \
         so α, β or the zero dynamics would be infinite or NaN everywhere; correct the expression or the \
         parameter values"
    )]
    NotFinite {
        file: String,
        what: String,
        expr: String,
        value: f64,
        params: String,
    },
    #[error(
        "{file}: the Lie derivative L_f^{k} h of the output `{output}` has {nodes} distinct expression nodes, \
         more than the limit of {max} (MAX_LIE_DERIVATIVE_NODES): the model's derivatives grow too fast to \
         derive symbolically (a long chain of nonlinear states); shorten the chain or simplify the \
         right-hand sides"
    )]
    LieDerivativeTooLarge {
        file: String,
        output: String,
        k: usize,
        nodes: usize,
        max: usize,
    },
    #[error(
        "{file}: ξ = (h, …, L_f^(r-1) h) with r = {r} are not independent functions of the {n} states: the \
         {r} × {n} matrix ∂ξ/∂x has rank below {r} (exact triangular elimination, then the smallest \
         singular value of the row-scaled remainder at most random probe points is below {tol:e}), so no \
         choice of the {m} internal state(s) η completes ξ to a coordinate change"
    )]
    NoCoordinates {
        file: String,
        r: usize,
        n: usize,
        m: usize,
        tol: f64,
    },
}

/// Everything derived for one model. Expressions live in `model.pool`.
#[derive(Debug, Clone)]
pub struct Derivation {
    pub model: Model,
    /// Relative degree r.
    pub relative_degree: usize,
    /// L_f^k h for k = 0 … r, in the original states.
    pub lie: Vec<Id>,
    /// L_g L_f^k h for k = 0 … r − 1 (all but the last identically zero), in the states.
    pub lg_lie: Vec<Id>,
    /// How each L_g L_f^k h was found zero or nonzero.
    pub lg_decided_by: Vec<DecidedBy>,
    /// The symbols ξ1 … ξr and η1 … η(n−r).
    pub xi: Vec<Symbol>,
    pub eta: Vec<Symbol>,
    /// Indices of the states chosen as η (`η_j = x_{eta_states[j]}`).
    pub eta_states: Vec<usize>,
    /// ψ(x) = (ξ, η) in the states: lie[0..r] then the η states.
    pub psi: Vec<Id>,
    /// ψ⁻¹ per state.
    pub psi_inv: Vec<Solution>,
    /// ∂ψ/∂x (n × n, row i = ∂ψ_i/∂x), for Newton's method and for the chain rule.
    pub jacobian: Vec<Vec<Id>>,
    /// Rank tests the choice of η took (at most n + 1: the greedy choice of `coordinates.rs`).
    pub rank_tests: usize,
    /// α and β in (ξ, η) — with any numerically solved states left as state symbols.
    pub alpha: Id,
    pub beta: Id,
    /// α = L_f^r h and β = L_g L_f^{r−1} h in the original states.
    pub alpha_x: Id,
    pub beta_x: Id,
    /// dη_j/dt in (ξ, η, yr) (and numerically solved states, if any).
    pub zero_dynamics: Vec<Id>,
    /// dη_j/dt in (x, yr).
    pub zero_dynamics_x: Vec<Id>,
    /// Where the zero dynamics are affine in η, written in (ξ, η, w, yr) and the parameters alone
    /// (`zd_affine.rs`): [∂q_i/∂η_j row-major, then q_i], at η = 0 the A and b of q = A η + b.
    pub zero_dynamics_affine: Option<Vec<Id>>,
    /// The symbol `yr` (= y^(r)).
    pub yr: Symbol,
    /// Every right-hand side is affine in the input (contract §5). Otherwise `lie[r]` = y^(r) = φ(x, w, u),
    /// `alpha` = φ ∘ ψ⁻¹ (the `yr_equation`, containing u), `beta` = ∂φ/∂u ∘ ψ⁻¹ (the decoupling term, which
    /// may contain u), `alpha_x`, `beta_x` the same in the states.
    pub affine: bool,
    /// y^(r) is affine in the input (always for affine models; for a non-affine one when only internal
    /// states are non-affine): then `alpha`, `beta`, `alpha_x`, `beta_x` are u-free and u = (yr − α)/β, so
    /// every affine code path applies (the fused inverse, generated code).
    pub yr_affine: bool,
    /// Non-affine models: y^(r) = φ ∘ ψ⁻¹ in (ξ, η, w, u) (the JSON's `yr_equation`).
    pub yr_equation: Option<Id>,
    /// Non-affine models: u from y^(r) = yr by isolation, in (ξ, η, w, yr) and in (x, w, yr); `None` where
    /// only Newton's method solves it (always `None` for affine models, whose u = (yr − α)/β).
    pub input_solution: Option<Id>,
    pub input_solution_x: Option<Id>,
    /// The signal values' symbols in the layout of `InverseModel`'s `w`: S, S_d1, …, S_dr per signal S in
    /// file order (empty without signals).
    pub w: Vec<Symbol>,
    /// Where β vanishes, in words.
    pub singular: Vec<String>,
    /// Conditions under which the closed-form ψ⁻¹ is valid (divisors nonzero, roots real, branches).
    pub domain: Vec<String>,
    pub warnings: Vec<String>,
    /// ∂/∂(x, u, p) of ψ_1 … ψ_r, y^(r), the internal states' right-hand sides and the outputs, row-major in
    /// the layout of `invsim_model_api::SensitivityLayout` (`sensitivity.rs`), with the columns of the map
    /// calls and their arguments.
    pub sensitivity: Vec<Id>,
    /// The map calls of the sensitivity rows, in the order of their columns (`map_calls.rs`).
    pub map_calls: Vec<invsim_model_api::MapCall>,
    /// ∂(dη/dt)/∂(η, ξ, y^(r), p) in (ξ, η, w, y^(r)), row-major, where ψ⁻¹ is closed-form and y^(r) affine
    /// in the input (`normal_form_jacobian.rs`); `None` otherwise.
    pub zero_dynamics_jacobian: Option<Vec<Id>>,
    /// ∂o/∂(η, ξ, y^(r), p) of the extra outputs o(ξ, η, w, y^(r)), row-major, written in (x, w, u) (at
    /// ξ = ψ_ξ(x), η = x_η, y^(r) = α_x + β_x·u), on the same conditions; `None` otherwise.
    pub outputs_jacobian: Option<Vec<Id>>,
}

/// `Err(NotFinite)` naming the first constant subexpression of f, g (the rhs of a non-affine state) or h that
/// is not finite at `nominal`.
fn check_finite(
    model: &Model,
    nominal: &std::collections::HashMap<Symbol, f64>,
    file: &str,
) -> Result<(), DeriveError> {
    let roots: Vec<(String, Id)> = model
        .states
        .iter()
        .flat_map(|s| {
            // A non-affine state's f and g at u = 0 are not evaluated by the method (its rhs is solved
            // for u), and may be undefined where the rhs is not (g of k_T·sqrt(P) at P = 0): its rhs.
            if s.affine {
                vec![
                    (format!("f of state `{}`", s.name), s.f),
                    (format!("g of state `{}`", s.name), s.g),
                ]
            } else {
                vec![(format!("the right-hand side of state `{}`", s.name), s.rhs)]
            }
        })
        .chain([(
            format!("the output `{}`", model.output.name),
            model.output.h,
        )])
        .collect();
    match crate::model::finite::non_finite_constant(&model.pool, &roots, nominal) {
        Some((what, expr, value, params)) => Err(DeriveError::NotFinite {
            file: file.to_string(),
            what,
            expr,
            value,
            params,
        }),
        None => Ok(()),
    }
}

/// The error for a model without a relative degree.
fn no_relative_degree(model: &Model, file: String, why: NoRelativeDegree) -> DeriveError {
    let n = model.states.len();
    match why {
        NoRelativeDegree::Unreachable => DeriveError::NoRelativeDegree {
            file,
            output: model.output.name.clone(),
            input: model.input.name.clone(),
            n,
            last: n.saturating_sub(1),
        },
        NoRelativeDegree::TooLarge { k, nodes } => DeriveError::LieDerivativeTooLarge {
            file,
            output: model.output.name.clone(),
            k,
            nodes,
            max: MAX_LIE_DERIVATIVE_NODES,
        },
    }
}

/// The total derivative's field (along f for affine models, along the whole rhs otherwise) and the relative
/// degree it finds.
fn find_relative_degree(
    model: &mut Model,
    n: usize,
    nominal: &std::collections::HashMap<Symbol, f64>,
    warnings: &mut Vec<String>,
) -> (TotalDerivative, Result<RelativeDegree, NoRelativeDegree>) {
    let h = model.output.h;
    if model.is_affine() {
        let field = TotalDerivative::new(model, n + 1);
        let found = relative_degree(&mut model.pool, h, &field, n, nominal, warnings);
        return (field, found);
    }
    let field = TotalDerivative::along_rhs(model, n + 1);
    let u = model.input.symbol;
    let found =
        non_affine::relative_degree_u(&mut model.pool, (h, u), &field, n, nominal, warnings);
    (field, found)
}

/// y^(r) in (ξ, η) and the zero dynamics: the affine normal form, or that of a non-affine model.
struct Form {
    normal: NormalForm,
    alpha_x: Id,
    beta_x: Id,
    yr_affine: bool,
    yr_equation: Option<Id>,
    input_solution: Option<Id>,
    input_solution_x: Option<Id>,
    domain: Vec<(Id, String)>,
}

fn input_output_form(
    affine: bool,
    pool: &mut Pool,
    coords: &ToCoordinates<'_>,
    (alpha_x, decoupling): (Id, Id),
    (f, g, rhs): (&[Id], &[Id], &[Id]),
    (eta_states, u, yr, nominal): (
        &[usize],
        Symbol,
        Symbol,
        &std::collections::HashMap<Symbol, f64>,
    ),
) -> Form {
    if affine {
        let normal = normal_form(pool, coords, (alpha_x, decoupling), (f, g), eta_states, yr);
        return Form {
            normal,
            alpha_x,
            beta_x: decoupling,
            yr_affine: true,
            yr_equation: None,
            input_solution: None,
            input_solution_x: None,
            domain: Vec::new(),
        };
    }
    let na = non_affine::non_affine(
        pool,
        coords,
        (alpha_x, decoupling),
        (rhs, eta_states),
        (u, yr, nominal),
    );
    Form {
        normal: NormalForm {
            alpha: na.alpha,
            beta: na.beta,
            zero_dynamics: na.form.zero_dynamics,
            zero_dynamics_x: na.form.zero_dynamics_x,
        },
        alpha_x: na.alpha_x,
        beta_x: na.beta_x,
        yr_affine: na.yr_affine,
        yr_equation: Some(na.form.yr_equation),
        input_solution: na.form.input_solution,
        input_solution_x: na.form.input_solution_x,
        domain: na.form.domain,
    }
}

/// The warnings for where β vanishes (non-affine models: ∂y^(r)/∂u).
fn singular_warnings(singular: &[String], affine: bool, input: &str) -> Vec<String> {
    let mut warnings = Vec::new();
    for s in singular {
        if affine {
            warnings.push(format!("β vanishes: {s}"));
        } else {
            warnings.push(format!(
                "∂y^(r)/∂{input} vanishes: {s} (Newton's method for the input fails there)"
            ));
        }
    }
    warnings
}

/// What a derivation computes besides the normal form, the inverse and the partial derivatives of
/// `sensitivity`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Extent {
    /// Everything, the normal-form Jacobians of the gradient too (generated code, `invsim derive`).
    Full,
    /// Without the normal-form Jacobians (`zero_dynamics_jacobian`, `outputs_jacobian`: `None`): a run
    /// without a gradient does not read them, and a gradient takes the implicit function theorem's route
    /// without them. Symbolically they are most of a model with modes' derivation.
    Run,
}

impl Derivation {
    /// Derive the normal form of a loaded model ([`Extent::Full`]).
    pub fn new(model: Model) -> Result<Derivation, DeriveError> {
        Derivation::to(model, Extent::Full)
    }

    /// Derive the normal form of a loaded model as far as `extent` asks.
    pub fn to(model: Model, extent: Extent) -> Result<Derivation, DeriveError> {
        let mut model = model;
        let n = model.states.len();
        let nominal = model.nominal();
        let f: Vec<Id> = model.states.iter().map(|s| s.f).collect();
        let g: Vec<Id> = model.states.iter().map(|s| s.g).collect();
        let file = model.file.display().to_string();
        let params: Vec<Symbol> = model.parameters.iter().map(|p| p.symbol).collect();
        let mut warnings = Vec::new();

        // No constant part of f, g or h may be infinite or NaN at the parameters' values.
        check_finite(&model, &nominal, &file)?;

        // r: the first k with L_g D_f^(k-1) h ≢ 0, D the total derivative along states and signals.
        let affine = model.is_affine();
        let (field, found) = find_relative_degree(&mut model, n, &nominal, &mut warnings);
        let RelativeDegree {
            r,
            lie,
            lg_lie,
            lg_decided_by,
        } = found.map_err(|why| no_relative_degree(&model, file.clone(), why))?;
        let decoupling = *lg_lie.last().expect("r ≥ 1 implies one L_g L_f^k h");
        let alpha_x = lie[r];

        let (xi, eta, yr) = coordinate_symbols(&mut model.pool, r, n);

        // η among the states, ψ = (ξ, η) and ∂ψ/∂x; then ψ⁻¹ by isolation (or Newton at run time).
        let Coordinates {
            eta_states,
            psi,
            jacobian,
            rank_tests,
        } = choose_coordinates(&mut model, &lie, r, &eta, &mut warnings).map_err(|_| {
            DeriveError::NoCoordinates {
                file: file.clone(),
                r,
                n,
                m: n - r,
                tol: SINGULAR_VALUE_TOL,
            }
        })?;
        let Inverse {
            psi_inv,
            closed,
            domain,
        } = psi_inverse(&mut model, &lie, &xi, &eta, &eta_states, &mut warnings);

        // y^(r) = α + β u and the zero dynamics, in (ξ, η); then where β vanishes.
        let coords = ToCoordinates {
            lie: &lie,
            xi: &xi,
            closed: &closed,
        };
        let u = model.input.symbol;
        let rhs: Vec<Id> = model.states.iter().map(|s| s.rhs).collect();
        let pool = &mut model.pool;
        let Form {
            normal,
            alpha_x,
            beta_x,
            yr_affine,
            yr_equation,
            input_solution,
            input_solution_x,
            domain: more_domain,
        } = input_output_form(
            affine,
            pool,
            &coords,
            (alpha_x, decoupling),
            (&f, &g, &rhs),
            (&eta_states, u, yr, &nominal),
        );
        let mut domain = domain;
        domain.extend(more_domain);
        let NormalForm {
            alpha,
            beta,
            zero_dynamics,
            zero_dynamics_x,
        } = normal;

        // Where β (non-affine: ∂y^(r)/∂u, which may depend on u) vanishes.
        let mut coords_u = eta.clone();
        if !affine {
            coords_u.push(u);
        }
        let singular = singular_set(pool, beta, &nominal, &xi, &coords_u);
        warnings.extend(singular_warnings(&singular, affine, &model.input.name));
        let domain = domain_conditions(pool, domain, &params);

        let (sensitivity, map_calls) = sensitivity::sensitivity(
            &mut model,
            &psi[..r],
            (alpha_x, beta_x, yr_affine),
            &eta_states,
        );
        let zero_dynamics_affine = zd_affine::affine_in_eta(&mut model, &zero_dynamics, &eta);
        let closed_form = yr_affine && psi_inv.iter().all(|s| matches!(s, Solution::Closed(_)));
        let (zero_dynamics_jacobian, outputs_jacobian) = if closed_form && extent == Extent::Full {
            let normal = normal_form_jacobian::Normal {
                xi: &xi,
                eta: &eta,
                yr,
                psi_xi: &psi[..r],
                eta_states: &eta_states,
                phi: (alpha_x, beta_x),
                zero_dynamics: &zero_dynamics,
            };
            normal_form_jacobian::jacobians(&mut model, &coords, &normal)
        } else {
            (None, None)
        };
        Ok(Derivation {
            model,
            relative_degree: r,
            lie,
            lg_lie,
            lg_decided_by,
            xi,
            eta,
            eta_states,
            psi,
            psi_inv,
            jacobian,
            rank_tests,
            alpha,
            beta,
            alpha_x,
            beta_x,
            zero_dynamics,
            zero_dynamics_x,
            zero_dynamics_affine,
            yr,
            affine,
            yr_affine,
            yr_equation,
            input_solution,
            input_solution_x,
            w: field.w_symbols(r),
            singular,
            domain,
            warnings,
            sensitivity,
            map_calls,
            zero_dynamics_jacobian,
            outputs_jacobian,
        })
    }

    pub fn pool(&self) -> &Pool {
        &self.model.pool
    }

    /// Number of states n.
    pub fn n(&self) -> usize {
        self.model.states.len()
    }

    /// Are all entries of ψ⁻¹ in closed form?
    pub fn psi_inv_closed(&self) -> bool {
        self.psi_inv
            .iter()
            .all(|s| matches!(s, Solution::Closed(_)))
    }
}
