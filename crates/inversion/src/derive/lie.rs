//! The Lie derivative of a scalar field along a vector field: L_v φ = ∇φ · v = Σ_i ∂φ/∂x_i · v_i, and
//! L_f^k h = L_f(L_f^{k−1} h) (Isidori, *Nonlinear Control Systems*, 3rd ed., §4.1; Khalil, *Nonlinear
//! Systems*, 3rd ed., §13.2).

use invsim_expr::{Id, Pool, Symbol};

/// L_v φ = Σ_i ∂φ/∂x_i · v_i.
pub fn lie_derivative(pool: &mut Pool, phi: Id, v: &[Id], states: &[Symbol]) -> Id {
    let mut terms = Vec::with_capacity(states.len());
    for (i, &x) in states.iter().enumerate() {
        if !pool.depends_on(phi, x) || pool.is_zero(v[i]) {
            continue;
        }
        let d = pool.diff(phi, x);
        terms.push(pool.mul(&[d, v[i]]));
    }
    pool.add(&terms)
}
