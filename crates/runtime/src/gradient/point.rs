//! The chain rule at one point of a run: how x = ψ⁻¹(ξ, η) and the input u move when η or a parameter moves,
//! and so how the internal states' right-hand sides and the outputs move (implicit function theorem).
//!
//! With ξ, y^(r) and the signals w fixed by the reference, x solves ψ(x; p) = (ξ, η) and u solves
//! φ(x, u; p) = y^(r) (φ = α_x + β_x·u where y^(r) is affine in u). Differentiating both:
//!
//! ```text
//! (∂ψ/∂x) dx = (0, dη) − (∂ψ/∂p) dp          (the η rows of ψ are states, η_j = x_{s_j}: parameter-free)
//! du = −(∂φ/∂x · dx + ∂φ/∂p · dp) / (∂φ/∂u)
//! d row = ∂row/∂x · dx + ∂row/∂u · du + ∂row/∂p · dp   (row: an internal state's rhs, or an output)
//! ```
//!
//! (Isidori, *Nonlinear Control Systems*, 3rd ed., §4.1 for ψ; the implicit function theorem e.g. Rudin,
//! *Principles of Mathematical Analysis*, Thm. 9.28.)

use std::cell::RefCell;

use invsim_model_api::{InverseModel, ModelError, SensitivityLayout};
use nalgebra::DMatrix;

/// The partial derivatives at one point (x, w, u) and the inverse of ∂ψ/∂x (n is small: every direction is
/// then a product with it, without a factorisation or an allocation per direction).
pub(crate) struct Point {
    layout: SensitivityLayout,
    sens: Vec<f64>,
    /// (∂ψ/∂x)⁻¹, row-major; NaN where ∂ψ/∂x is singular.
    inverse: Vec<f64>,
    /// The right-hand side of a direction, reused.
    b: RefCell<Vec<f64>>,
}

/// A direction of change at a point: dx and du.
pub(crate) struct Direction {
    pub dx: Vec<f64>,
    pub du: f64,
}

impl Point {
    /// The model's partial derivatives at (x, w, u); `eta_states` are the states chosen as η.
    pub(crate) fn new<M: InverseModel + ?Sized>(
        model: &M,
        (x, w, u): (&[f64], &[f64], f64),
        eta_states: &[usize],
        sens: Vec<f64>,
    ) -> Result<Point, ModelError> {
        let layout = SensitivityLayout::of(model.info());
        let mut sens = sens;
        sens.resize(layout.len(), 0.0);
        model.sensitivity(x, w, u, &mut sens)?;
        let (n, r) = (layout.n, layout.r);
        let jac = DMatrix::from_fn(n, n, |i, j| {
            if i < r {
                sens[layout.at(layout.psi(i), layout.x(j))]
            } else if eta_states[i - r] == j {
                1.0
            } else {
                0.0
            }
        });
        let inverse = match jac.try_inverse() {
            Some(m) => (0..n * n).map(|k| m[(k / n, k % n)]).collect(),
            None => vec![f64::NAN; n * n],
        };
        Ok(Point {
            layout,
            sens,
            inverse,
            b: RefCell::new(vec![0.0; n]),
        })
    }

    /// The buffer of the partial derivatives, to reuse for the next point.
    pub(crate) fn into_buffer(self) -> Vec<f64> {
        self.sens
    }

    fn d(&self, row: usize, column: usize) -> f64 {
        self.sens[self.layout.at(row, column)]
    }

    /// dx and du for a change dη of the internal coordinates and (`param`) a unit change of parameter k.
    /// NaN where ∂ψ/∂x is singular.
    pub(crate) fn direction(&self, deta: &[f64], param: Option<usize>) -> Direction {
        let mut dir = Direction {
            dx: vec![0.0; self.layout.n],
            du: 0.0,
        };
        self.direction_into(deta, param, &mut dir);
        dir
    }

    /// [`Point::direction`] into `dir` (its `dx` of length n), without allocating.
    pub(crate) fn direction_into(&self, deta: &[f64], param: Option<usize>, dir: &mut Direction) {
        self.moved_into(&[], 0.0, deta, param, dir);
    }

    /// dx and du where the reference moves too: dξ (`dxi`, the first r of ξ; missing entries 0) and dy^(r)
    /// (`dyr`), as a re-entry's transition moves it with the state it started from (`crate::modes`):
    /// (∂ψ/∂x) dx = (dξ − ∂ψ_ξ/∂p dp, dη), du = (dy^(r) − ∂φ/∂x · dx − ∂φ/∂p dp)/(∂φ/∂u).
    pub(crate) fn moved_into(
        &self,
        dxi: &[f64],
        dyr: f64,
        deta: &[f64],
        param: Option<usize>,
        dir: &mut Direction,
    ) {
        let l = &self.layout;
        let (n, r) = (l.n, l.r);
        let mut b = self.b.borrow_mut();
        for (i, bi) in b.iter_mut().enumerate() {
            *bi = if i < r {
                dxi.get(i).copied().unwrap_or(0.0)
                    - param.map_or(0.0, |k| self.d(l.psi(i), l.param(k)))
            } else {
                deta[i - r]
            };
        }
        for (dx, row) in dir.dx.iter_mut().zip(self.inverse.chunks_exact(n)) {
            *dx = row.iter().zip(b.iter()).map(|(a, v)| a * v).sum();
        }
        let phi = l.phi();
        let mut num = param.map_or(0.0, |k| self.d(phi, l.param(k))) - dyr;
        for (j, v) in dir.dx.iter().enumerate() {
            num += self.d(phi, l.x(j)) * v;
        }
        dir.du = -num / self.d(phi, l.u());
    }

    /// The change of `row` along `dir` (with the unit change of parameter `param`, if any).
    pub(crate) fn row_change(&self, row: usize, dir: &Direction, param: Option<usize>) -> f64 {
        let l = &self.layout;
        let mut v = param.map_or(0.0, |k| self.d(row, l.param(k))) + self.d(row, l.u()) * dir.du;
        for (j, dx) in dir.dx.iter().enumerate() {
            v += self.d(row, l.x(j)) * dx;
        }
        v
    }

    /// A = ∂q/∂η (ne × ne) and B = ∂q/∂p (ne × P, the parameters `params`) of the internal states' right-hand
    /// sides q_i = F_(η_i)(x, w, u; p), through x and u (the directions of the module doc, all at once): with
    /// g_i = ∂q_i/∂x − (∂q_i/∂u / ∂φ/∂u) ∂φ/∂x and m_i = (∂ψ/∂x)⁻ᵀ g_i,
    ///
    /// ```text
    /// A_ij = m_i[r + j],   B_ic = ∂q_i/∂p_c − (∂q_i/∂u / ∂φ/∂u) ∂φ/∂p_c − Σ_(l<r) m_i[l] ∂ψ_l/∂p_c
    /// ```
    ///
    /// into `a` and `b`, column-major (entry (i, j) at j·ne + i).
    pub(crate) fn eta_jacobians(&self, params: &[usize], a: &mut [f64], b: &mut [f64]) {
        let l = &self.layout;
        let (n, r, ne, phi) = (l.n, l.r, l.n_eta, l.phi());
        let mut m = vec![0.0; n];
        for i in 0..ne {
            let row = l.eta(i);
            let ratio = self.d(row, l.u()) / self.d(phi, l.u());
            m.fill(0.0);
            for (j, inverse_row) in self.inverse.chunks_exact(n).enumerate() {
                let g = self.d(row, l.x(j)) - ratio * self.d(phi, l.x(j));
                for (mk, v) in m.iter_mut().zip(inverse_row) {
                    *mk += g * v;
                }
            }
            for j in 0..ne {
                a[j * ne + i] = m[r + j];
            }
            for (c, &k) in params.iter().enumerate() {
                let through_psi: f64 = (0..r).map(|q| m[q] * self.d(l.psi(q), l.param(k))).sum();
                b[c * ne + i] =
                    self.d(row, l.param(k)) - ratio * self.d(phi, l.param(k)) - through_psi;
            }
        }
    }

    pub(crate) fn layout(&self) -> &SensitivityLayout {
        &self.layout
    }
}
