//! Models whose right-hand side is not affine in the input (contract §5). The method only has to solve
//! y^(r) = yr for u, so affinity is not needed:
//!
//! * D e is the total derivative along rhs(x, w, u) (`total_derivative.rs`), and the relative degree r is the
//!   first k with ∂(D^k h)/∂u ≢ 0; D^k h, k < r, are free of u, and ξ, η, ψ⁻¹ follow as for affine models;
//! * y^(r) = φ(x, w, u) = D^r h; its expression in (ξ, η, w, u), φ ∘ ψ⁻¹, is the `yr_equation`, and
//!   ∂φ/∂u (the decoupling term, which may contain u) is what Newton's method needs;
//! * u from φ ∘ ψ⁻¹ = yr by isolation (as ψ⁻¹, `psi_inv.rs`) where u can be isolated: the `input_solution`;
//!   else Newton's method at run time with the analytic ∂φ/∂u;
//! * the zero dynamics dη/dt = rhs_η(x, w, u) ∘ ψ⁻¹ with u the input solution (or, where there is none,
//!   the input's symbol: evaluated at the Newton solution).

use super::normal_form::ToCoordinates;
use super::psi_inv::isolate;
use super::relative_degree::{NoRelativeDegree, RelativeDegree, MAX_LIE_DERIVATIVE_NODES};
use super::total_derivative::TotalDerivative;
use invsim_expr::{zero_test, DecidedBy, Id, Pool, Symbol, ZeroVerdict};
use std::collections::HashMap;

/// The first k ≤ n with ∂(D^k h)/∂u ≢ 0, D along rhs(x, w, u): `lie[k]` = D^k h for k = 0 … r (the last one
/// contains u) and `lg_lie[k]` = ∂(D^(k+1) h)/∂u for k = 0 … r − 1.
pub(super) fn relative_degree_u(
    pool: &mut Pool,
    (h, u): (Id, Symbol),
    field: &TotalDerivative,
    n: usize,
    nominal: &HashMap<Symbol, f64>,
    warnings: &mut Vec<String>,
) -> Result<RelativeDegree, NoRelativeDegree> {
    let zero = pool.zero();
    let u_zero = HashMap::from([(u, zero)]);
    let mut lie = vec![h];
    let mut lg_lie = Vec::new();
    let mut lg_decided_by = Vec::new();
    for k in 0..n {
        let next = field.drift(pool, lie[k]);
        let nodes = pool.dag_size(&[next]);
        if nodes > MAX_LIE_DERIVATIVE_NODES {
            return Err(NoRelativeDegree::TooLarge { k: k + 1, nodes });
        }
        let d = if pool.depends_on(next, u) {
            pool.diff(next, u)
        } else {
            zero
        };
        let verdict = zero_test(pool, d, nominal);
        lg_lie.push(d);
        lg_decided_by.push(verdict.decided_by());
        if let ZeroVerdict::Zero(DecidedBy::Probing) = verdict {
            warnings.push(format!(
                "∂(D^{} h)/∂u = {} was taken as identically zero by numeric probing",
                k + 1,
                pool.display(d)
            ));
        }
        if !verdict.is_zero() {
            lie.push(next);
            return Ok(RelativeDegree {
                r: k + 1,
                lie,
                lg_lie,
                lg_decided_by,
            });
        }
        // Free of u (identically): drop any syntactic trace of it.
        lie.push(pool.substitute(next, &u_zero));
    }
    Err(NoRelativeDegree::Unreachable)
}

/// y^(r) = φ, ∂φ/∂u, the input solution and the zero dynamics in (ξ, η) and in the states.
pub(super) struct NonAffineForm {
    /// φ ∘ ψ⁻¹ and ∂φ/∂u ∘ ψ⁻¹ (in ξ, η, w, u).
    pub(super) yr_equation: Id,
    pub(super) dphi_du: Id,
    /// u in (ξ, η, w, yr) where it can be isolated, and in (x, w, yr).
    pub(super) input_solution: Option<Id>,
    pub(super) input_solution_x: Option<Id>,
    /// dη/dt in (ξ, η, w, yr) (or u where there is no input solution), and in the states.
    pub(super) zero_dynamics: Vec<Id>,
    pub(super) zero_dynamics_x: Vec<Id>,
    /// Conditions of the isolation.
    pub(super) domain: Vec<(Id, String)>,
}

/// The derivation's quantities of a non-affine model: where y^(r) = φ is itself affine in u (only internal
/// states are non-affine, as a charge state with I²R losses), α = φ|_(u=0) and β = ∂φ/∂u are free of u and
/// every affine code path (α, β, the fused inverse, generated code) applies; otherwise α and β are φ and
/// ∂φ/∂u (both may contain u).
pub(super) struct NonAffine {
    pub(super) form: NonAffineForm,
    pub(super) yr_affine: bool,
    /// α, β in (ξ, η) and in the states.
    pub(super) alpha: Id,
    pub(super) beta: Id,
    pub(super) alpha_x: Id,
    pub(super) beta_x: Id,
}

/// [`NonAffine`] from φ = D^r h and ∂φ/∂u in the states.
pub(super) fn non_affine(
    pool: &mut Pool,
    coords: &ToCoordinates<'_>,
    (phi_x, dphi_x): (Id, Id),
    (rhs, eta_states): (&[Id], &[usize]),
    (u, yr, nominal): (Symbol, Symbol, &HashMap<Symbol, f64>),
) -> NonAffine {
    let form = non_affine_form(pool, coords, (phi_x, dphi_x), (rhs, eta_states), (u, yr));
    let d2 = pool.diff(dphi_x, u);
    let yr_affine = zero_test(pool, d2, nominal).is_zero();
    if !yr_affine {
        return NonAffine {
            alpha: form.yr_equation,
            beta: form.dphi_du,
            alpha_x: phi_x,
            beta_x: dphi_x,
            form,
            yr_affine,
        };
    }
    let zero = pool.zero();
    let u_zero = HashMap::from([(u, zero)]);
    let alpha_x = pool.substitute(phi_x, &u_zero);
    let beta_x = pool.substitute(dphi_x, &u_zero);
    NonAffine {
        alpha: coords.apply(pool, alpha_x),
        beta: coords.apply(pool, beta_x),
        alpha_x,
        beta_x,
        form,
        yr_affine,
    }
}

/// The normal form of a non-affine model from φ = D^r h and ∂φ/∂u in the states.
fn non_affine_form(
    pool: &mut Pool,
    coords: &ToCoordinates<'_>,
    (phi_x, dphi_x): (Id, Id),
    (rhs, eta_states): (&[Id], &[usize]),
    (u, yr): (Symbol, Symbol),
) -> NonAffineForm {
    let yr_equation = coords.apply(pool, phi_x);
    let dphi_du = coords.apply(pool, dphi_x);
    let yr_e = pool.var(yr);
    // φ − yr = 0 for u, in (ξ, η) and in the states.
    let residual = pool.sub(yr_equation, yr_e);
    let solved = isolate(pool, residual, u);
    let residual_x = pool.sub(phi_x, yr_e);
    let solved_x = isolate(pool, residual_x, u);
    let (input_solution, domain) = match solved {
        Some((e, conds)) => (Some(pool.tidy(e)), conds),
        None => (None, Vec::new()),
    };
    let input_solution_x = solved_x.map(|(e, _)| e);
    let with_u = |pool: &mut Pool, e: Id, sol: Option<Id>| match sol {
        Some(s) => pool.substitute(e, &HashMap::from([(u, s)])),
        None => e,
    };
    let mut zero_dynamics = Vec::with_capacity(eta_states.len());
    let mut zero_dynamics_x = Vec::with_capacity(eta_states.len());
    for &c in eta_states {
        let q_x = with_u(pool, rhs[c], input_solution_x);
        zero_dynamics_x.push(q_x);
        let q = coords.apply(pool, rhs[c]);
        let q = with_u(pool, q, input_solution);
        zero_dynamics.push(pool.tidy(q));
    }
    NonAffineForm {
        yr_equation,
        dphi_du,
        input_solution,
        input_solution_x,
        zero_dynamics,
        zero_dynamics_x,
        domain,
    }
}
